// Command-line parsing, surface generation and the spring-mass model used by the stand-in participants.
#include "DummyCommon.hpp"
#include "railcosim/Error.hpp"

#include <cstdio>
#include <cstdlib>
#include <iostream>

namespace railcosim::dummy {

Options::Options(int argc, char** argv, const std::map<std::string, std::string>& defaults, const std::string& usage)
    : values_(defaults) {
  for (int i = 1; i < argc; ++i) {
    std::string key = argv[i];
    if (key == "--help" || key == "-h") {
      std::cout << usage << '\n';
      std::exit(0);
    }
    if (key.rfind("--", 0) != 0) throw Error("unexpected argument '" + key + "'\n" + usage);
    key = key.substr(2);
    const auto known = defaults.find(key);
    if (known == defaults.end()) throw Error("unknown option --" + key + "\n" + usage);
    // Switches default to "false" and take no value.
    if (known->second == "false" || known->second == "true") {
      values_[key] = "true";
      continue;
    }
    if (i + 1 >= argc) throw Error("option --" + key + " needs a value\n" + usage);
    values_[key] = argv[++i];
  }
}

std::string Options::text(const std::string& key) const { return values_.at(key); }

double Options::number(const std::string& key) const {
  const std::string& value = values_.at(key);
  char* end = nullptr;
  const double result = std::strtod(value.c_str(), &end);
  if (end == value.c_str() || *end != '\0') throw Error("option --" + key + ": '" + value + "' is not a number");
  return result;
}

long Options::integer(const std::string& key) const {
  const std::string& value = values_.at(key);
  char* end = nullptr;
  const long result = std::strtol(value.c_str(), &end, 10);
  if (end == value.c_str() || *end != '\0') throw Error("option --" + key + ": '" + value + "' is not an integer");
  return result;
}

bool Options::flag(const std::string& key) const { return values_.at(key) == "true"; }

InterfaceMesh rectangularSurface(long nx, long ny, double spacing) {
  if (nx < 2 || ny < 2) throw Error("rectangularSurface: need at least 2 x 2 nodes");
  InterfaceMesh mesh;
  mesh.coordinates.reserve(static_cast<std::size_t>(3 * nx * ny));
  for (long j = 0; j < ny; ++j) {
    for (long i = 0; i < nx; ++i) {
      mesh.coordinates.push_back(static_cast<double>(i) * spacing);
      mesh.coordinates.push_back(static_cast<double>(j) * spacing);
      mesh.coordinates.push_back(0.0);
    }
  }
  for (long j = 0; j + 1 < ny; ++j) {
    for (long i = 0; i + 1 < nx; ++i) {
      const auto corner = static_cast<std::int32_t>(j * nx + i);
      const auto right = corner + 1;
      const auto up = static_cast<std::int32_t>(corner + nx);
      const auto diagonal = up + 1;
      mesh.triangles.insert(mesh.triangles.end(), {corner, right, diagonal, corner, diagonal, up});
    }
  }
  return mesh;
}

long sideForNodes(long nodes) {
  const long side = std::lround(std::sqrt(static_cast<double>(nodes)));
  return side < 2 ? 2 : side;
}

double SpringMass::advance(double& displacement, double& velocity, double force, double dt) const {
  const double w = omega();
  const double equilibrium = force / stiffness;
  const double offset = displacement - equilibrium;
  const double c = std::cos(w * dt);
  const double s = std::sin(w * dt);
  displacement = equilibrium + offset * c + velocity / w * s;
  velocity = -offset * w * s + velocity * c;
  return (force - stiffness * displacement) / mass;
}

ParticipantConfig participantConfig(const Options& options, CouplingScheme scheme) {
  ParticipantConfig config;
  config.name = options.text("name");
  config.endpoint = options.text("endpoint");
  config.timeoutSeconds = options.number("timeout");
  config.heartbeatSeconds = options.number("heartbeat");
  config.couplingScheme = toString(scheme);
  return config;
}

int runReportingErrors(const char* program, const std::function<int()>& body) {
  try {
    return body();
  } catch (const PeerLostError& error) {
    std::fprintf(stderr, "%s: PEER LOST: %s\n", program, error.what());
    return 2;
  } catch (const ProtocolError& error) {
    std::fprintf(stderr, "%s: PROTOCOL ERROR: %s\n", program, error.what());
    return 3;
  } catch (const std::exception& error) {
    std::fprintf(stderr, "%s: ERROR: %s\n", program, error.what());
    return 1;
  }
}

} // namespace railcosim::dummy
