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

/// A restart checkpoint that cannot be used: incomplete, corrupt, of another protocol version, run or solver set-up.
/// Its message is one line saying which checkpoint, what is wrong and what to do.
class CheckpointError : public Error {
public:
  explicit CheckpointError(const std::string& message) : Error(message) {}
};

/// The peer process died, disconnected, stayed silent past the timeout, or aborted.
class PeerLostError : public Error {
public:
  explicit PeerLostError(const std::string& message) : Error(message) {}
};

} // namespace railcosim
