// Baseline for the cost report: a plain ZeroMQ ping-pong of given message sizes, without the bridge.
#pragma once

#include <cstddef>
#include <string>

namespace railcosim::com {

struct RawRoundTrip {
  double secondsPerRoundTrip = 0.0; // one forward + one backward message, wall-clock
  int roundTrips = 0;
};

/// Two PAIR sockets in two threads (each with its own context, as two participants have) exchange
/// `forwardBytes` one way and `backwardBytes` back, `roundTrips` times after `warmup` untimed ones.
/// Throws Error if the endpoint cannot be used or a message does not arrive within 10 s.
RawRoundTrip measureRawRoundTrip(const std::string& endpoint, std::size_t forwardBytes, std::size_t backwardBytes,
                                 int roundTrips, int warmup);

} // namespace railcosim::com
