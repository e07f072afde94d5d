// Exceptions thrown by the railcosim bridge: every message says what, where, which value, what to do.
#pragma once

#include <stdexcept>
#include <string>

namespace railcosim {

/// Base of every error the library throws.
class Error : public std::runtime_error {
public:
  explicit Error(const std::string& message) : std::runtime_error(message) {}
};

/// A message that does not follow the protocol (bad magic, version, type, size, or field value).
class ProtocolError : public Error {
public:
  explicit ProtocolError(const std::string& message) : Error(message) {}
};

/// The peer process died, disconnected, stayed silent past the timeout, or aborted.
class PeerLostError : public Error {
public:
  explicit PeerLostError(const std::string& message) : Error(message) {}
};

} // namespace railcosim
