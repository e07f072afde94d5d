// Validation of ParticipantConfig: name, endpoint transport, timeout and heartbeat.
#include "config/ParticipantConfig.hpp"
#include "railcosim/Error.hpp"
#include "railcosim/CouplingScheme.hpp"

#include <cmath>
#include <sstream>

namespace railcosim::config {

void validate(const ParticipantConfig& config, const char* role) {
  const std::string who = std::string(role) + " participant '" + config.name + "'";
  if (config.name.empty() || config.name.size() > 200) {
    throw Error(std::string(role) +
                " participant: name must be 1 to 200 characters (it is printed in every "
                "error message); got '" +
                config.name + "'");
  }
  const bool knownTransport = config.endpoint.rfind("ipc://", 0) == 0 || config.endpoint.rfind("tcp://", 0) == 0;
  if (!knownTransport || config.endpoint.find("://") + 3 >= config.endpoint.size()) {
    throw Error(who + ": endpoint '" + config.endpoint +
                "' is not usable; write e.g. ipc:///tmp/railcosim-run.sock or tcp://127.0.0.1:5555");
  }
  if (!(config.timeoutSeconds > 0.0) || !std::isfinite(config.timeoutSeconds)) {
    std::ostringstream message;
    message << who << ": timeoutSeconds = " << config.timeoutSeconds << "; it must be a positive number of seconds";
    throw Error(message.str());
  }
  if (!config.couplingScheme.empty()) {
    try {
      parseCouplingScheme(config.couplingScheme);
    } catch (const Error& error) {
      throw Error(who + ": couplingScheme: " + error.what());
    }
  }
  if (config.resumedFrom.empty() && config.resumedWindow != 0)
    throw Error(who + ": resumedWindow = " + std::to_string(config.resumedWindow) +
                " without resumedFrom; name the checkpoint the run resumed from");
  if (!(config.heartbeatSeconds > 0.0) || !std::isfinite(config.heartbeatSeconds) || config.heartbeatSeconds > 3600.0) {
    std::ostringstream message;
    message << who << ": heartbeatSeconds = " << config.heartbeatSeconds << "; it must be in (0, 3600] seconds";
    throw Error(message.str());
  }
}

} // namespace railcosim::config
