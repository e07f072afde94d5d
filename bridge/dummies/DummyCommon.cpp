// Command-line parsing, surface generation and the spring-mass model used by the stand-in participants.
#include "DummyCommon.hpp"
#include "railcosim/Error.hpp"

#include <boost/program_options.hpp>

#include <cstdio>
#include <cstdlib>
#include <fstream>
#include <iostream>
#include <sstream>

namespace railcosim::dummy {

Options::Options(int argc, char** argv, const std::map<std::string, std::string>& defaults, const std::string& usage) {
  namespace po = boost::program_options;
  po::options_description described;
  described.add_options()("help,h", "print the usage");
  // Switches default to "false" and take no value; every other option takes one.
  for (const auto& [key, value] : defaults) {
    if (value == "false" || value == "true") {
      described.add_options()(key.c_str(), po::bool_switch());
    } else {
      described.add_options()(key.c_str(), po::value<std::string>()->default_value(value));
    }
  }
  po::variables_map parsed;
  try {
    // No positional arguments and no abbreviations: a typo must not pass silently.
    po::store(po::command_line_parser(argc, argv)
                  .options(described)
                  .style(po::command_line_style::default_style & ~po::command_line_style::allow_guessing)
                  .positional({})
                  .run(),
              parsed);
    po::notify(parsed);
  } catch (const po::error& error) {
    throw Error(std::string(error.what()) + "\n" + usage);
  }
  if (parsed.count("help")) throw HelpRequested(usage);
  for (const auto& [key, value] : defaults) {
    if (value == "false" || value == "true") {
      values_[key] = parsed[key].as<bool>() ? "true" : "false";
    } else {
      values_[key] = parsed[key].as<std::string>();
    }
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

ParticipantConfig participantConfig(const Options& options, CouplingScheme scheme,
                                    const std::optional<ResumedState>& resumed) {
  ParticipantConfig config;
  config.name = options.text("name");
  config.endpoint = options.text("endpoint");
  config.timeoutSeconds = options.number("timeout");
  config.heartbeatSeconds = options.number("heartbeat");
  config.couplingScheme = toString(scheme);
  if (resumed) {
    config.resumedFrom = resumed->manifest.name;
    config.resumedWindow = resumed->manifest.window;
  }
  return config;
}

std::optional<ResumedState> resumedState(const std::string& file) {
  const CheckpointSettings settings = CheckpointSettings::fromEnvironment();
  if (settings.resumeFrom.empty()) return std::nullopt;
  ResumedState resumed;
  resumed.manifest = verifyCheckpoint(settings.resumeFrom);
  std::ifstream in(settings.resumeFrom + "/" + file, std::ios::binary);
  if (!in) throw CheckpointError("checkpoint " + settings.resumeFrom + " has no " + file);
  std::ostringstream content;
  content << in.rdbuf();
  resumed.state = content.str();
  return resumed;
}

CheckpointFile writeStateFile(const std::string& name, const std::string& file, const std::string& side,
                              const std::string& state) {
  const std::string root = CheckpointSettings::fromEnvironment().folder;
  if (root.empty()) throw Error("restart checkpoint " + name + ": RAILCOSIM_CHECKPOINT_DIR is not set");
  const std::string staging = stagingFolder(root, name);
  std::ofstream out(staging + "/" + file, std::ios::binary | std::ios::trunc);
  out << state;
  out.close();
  if (!out) throw Error("restart checkpoint " + name + ": cannot write " + staging + "/" + file);
  return describeCheckpointFile(staging, file, side);
}

void writeResult(const std::string& path, const std::string& text) {
  if (path.empty()) return;
  {
    std::ofstream out(path + ".tmp", std::ios::trunc);
    out << text;
    if (!out) throw Error("cannot write " + path + ".tmp");
  }
  if (std::rename((path + ".tmp").c_str(), path.c_str()) != 0) throw Error("cannot rename " + path + ".tmp");
}

int runReportingErrors(const char* program, const std::function<int()>& body) {
  try {
    return body();
  } catch (const HelpRequested& help) {
    std::cout << help.what() << '\n';
    return 0;
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
