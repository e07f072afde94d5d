// Checks a participant's configuration before any socket is opened, so mistakes are reported plainly.
#pragma once

#include "railcosim/BridgeTypes.hpp"

namespace railcosim::config {

/// Throws Error naming the participant and the offending setting (empty name, endpoint scheme,
/// non-positive timeout or heartbeat). `role` is "fem" or "dem", used in the message.
void validate(const ParticipantConfig& config, const char* role);

} // namespace railcosim::config
