// Writes the protocol fuzzer's seed corpus: real messages from the encoders, one file per message (tests/fuzz/corpus).
#include "protocol/Message.hpp"
#include "railcosim/Error.hpp"

#include <cmath>
#include <cstdio>
#include <exception>
#include <fstream>
#include <limits>
#include <string>
#include <utility>
#include <vector>

using namespace railcosim;
using namespace railcosim::protocol;

namespace {

/// A flat nx x ny surface like the stand-in FEM's, 0.1 m spacing, two counter-clockwise triangles per cell.
InterfaceMesh grid(int nx, int ny) {
  InterfaceMesh mesh;
  for (int j = 0; j < ny; ++j) {
    for (int i = 0; i < nx; ++i) mesh.coordinates.insert(mesh.coordinates.end(), {0.1 * i, 0.1 * j, 0.05});
  }
  for (int j = 0; j + 1 < ny; ++j) {
    for (int i = 0; i + 1 < nx; ++i) {
      const int a = j * nx + i, b = a + 1, c = a + nx + 1, d = a + nx;
      mesh.triangles.insert(mesh.triangles.end(), {a, b, c, a, c, d});
    }
  }
  return mesh;
}

/// The surface sagging under a load at time `time`: a few micrometres, with velocities and accelerations on demand.
NodalKinematics sagging(const InterfaceMesh& mesh, double time, bool velocities, bool accelerations) {
  NodalKinematics kinematics;
  kinematics.time = time;
  kinematics.positions = mesh.coordinates;
  const double omega = 2.0 * M_PI * 180.0; // a sleeper-on-ballast mode, rad/s
  for (std::size_t node = 0; node < mesh.nodeCount(); ++node) {
    const double x = mesh.coordinates[3 * node], y = mesh.coordinates[3 * node + 1];
    const double amplitude = -4.0e-6 * std::sin(M_PI * x / 0.7) * std::sin(M_PI * y / 0.7);
    kinematics.positions[3 * node + 2] += amplitude * (1.0 - std::cos(omega * time));
    if (velocities) {
      kinematics.velocities.insert(kinematics.velocities.end(), {0.0, 0.0, amplitude * omega * std::sin(omega * time)});
    }
    if (accelerations) {
      kinematics.accelerations.insert(kinematics.accelerations.end(),
                                      {0.0, 0.0, amplitude * omega * omega * std::cos(omega * time)});
    }
  }
  return kinematics;
}

/// Contact forces of settling ballast lumped to `nodes` nodes: mostly downward, some tangential, some nodes free.
ForceMessage ballastForces(std::size_t nodes, std::uint64_t window, std::uint32_t iteration, double time) {
  ForceMessage message;
  message.window = window;
  message.iteration = iteration;
  message.time = time;
  for (std::size_t node = 0; node < nodes; ++node) {
    const bool touched = node % 5 != 3;
    const double load = touched ? -9.81 * 0.033 * (1.0 + 0.3 * std::sin(0.7 * static_cast<double>(node))) : 0.0;
    message.forces.insert(message.forces.end(), {0.05 * load * std::cos(1.3 * node), 0.05 * load, load});
  }
  return message;
}

/// The longest Abort plus one byte, payloadBytes raised to match: the one refusal the fuzzer cannot reach by small
/// steps from the other seeds (-max_len must exceed its 65,593 bytes).
std::vector<std::uint8_t> abortOverLimit() {
  std::vector<std::uint8_t> bytes = encodeAbort(3, std::string(maxTextBytes, 'x'));
  bytes.push_back('x');
  const std::uint64_t payload = maxTextBytes + 1;
  for (int i = 0; i < 8; ++i) bytes[48 + i] = static_cast<std::uint8_t>(payload >> (8 * i)); // little-endian
  return bytes;
}

/// A Hello of a participant resumed from the checkpoint after 800 windows (name as railcosim::checkpointName gives it).
Hello resumedAt800(Hello message) {
  message.resumedFrom = "window-00000800";
  message.resumedWindow = 800;
  return message;
}

/// The FEM side's file list of a beam checkpoint, as encodeCheckpointFiles writes it in answer to a Checkpoint.
std::string femFiles() {
  return "fem\tfem_state.bin\t\t61937\t89abcdef\n"
         "fem\tfem_fem_monitor.csv\tfem/fem_monitor.csv\t40213\t01234567\n";
}

/// A Checkpoint whose name has `c` in it (the encoder refuses it, so the byte is patched): a refusal seed.
std::vector<std::uint8_t> checkpointNamePatched(char c) {
  std::vector<std::uint8_t> bytes = encodeCheckpoint(CheckpointOrder{3, 1.5e-3, "window-00000003"});
  bytes[headerBytes + 6] = static_cast<std::uint8_t>(c);
  return bytes;
}

Hello hello(Role role, const std::string& name, const std::string& scheme) {
  Hello message;
  message.role = role;
  message.participantName = name;
  message.couplingScheme = scheme;
  return message;
}

} // namespace

int main(int argc, char** argv) {
  if (argc != 2) {
    std::fprintf(stderr, "usage: %s OUTPUT_DIR   (writes one file per seed message; the folder must exist)\n", argv[0]);
    return 2;
  }
  const std::string folder = argv[1];
  try {
    const double dt = 5.0e-4; // the beam case's FEM step, s
    const InterfaceMesh grid8 = grid(8, 8), grid3 = grid(3, 3);
    InterfaceMesh triangle;
    triangle.coordinates = {0.0, 0.0, 0.0, 0.6, 0.0, 0.0, 0.0, 0.25, 0.0};
    triangle.triangles = {0, 1, 2}; // odd triangle count: the arrays after it are not 8-byte aligned
    const std::vector<std::pair<std::string, std::vector<std::uint8_t>>> seeds = {
        {"hello-fem-justInTime", encodeHello(hello(Role::Fem, "beam-fem", "justInTime"))},
        {"hello-dem-predictive", encodeHello(hello(Role::Dem, "ballast-dem", "predictive"))},
        {"hello-dem-implicit", encodeHello(hello(Role::Dem, "dem", "implicit"))},
        {"hello-dem-unstated", encodeHello(hello(Role::Dem, "dem", ""))},
        {"hello-fem-resumed-window800", encodeHello(resumedAt800(hello(Role::Fem, "fem", "predictive")))},
        {"mesh-8x8-positions", encodeMesh(grid8, dt, sagging(grid8, 0.0, false, false))},
        {"mesh-8x8-all", encodeMesh(grid8, dt, sagging(grid8, 0.0, true, true))},
        {"mesh-3x3-velocities", encodeMesh(grid3, dt, sagging(grid3, 0.0, true, false))},
        {"mesh-triangle-accelerations", encodeMesh(triangle, dt, sagging(triangle, 0.0, false, true))},
        {"forces-64-window0", encodeForces(ballastForces(64, 0, 0, dt))},
        {"forces-256-window41", encodeForces(ballastForces(256, 41, 0, 42 * dt))},
        {"forces-64-window7-iteration3", encodeForces(ballastForces(64, 7, 3, 8 * dt))},
        {"forces-0-nodes", encodeForces(ballastForces(0, 2, 0, 3 * dt))},
        {"kinematics-64-positions-window12", encodeKinematics(12, sagging(grid8, 13 * dt, false, false))},
        {"kinematics-64-all-window0", encodeKinematics(0, sagging(grid8, dt, true, true))},
        {"kinematics-9-velocities-window3-iteration2", encodeKinematics(3, sagging(grid3, 4 * dt, true, false), {}, 2)},
        {"finalize-window1000", encodeFinalize(1000)},
        {"checkpoint-window800", encodeCheckpoint(CheckpointOrder{800, 800 * dt, "window-00000800"})},
        {"checkpoint-written-window800", encodeCheckpointWritten(800, femFiles())},
        {"abort-protocol-error",
         encodeAbort(42,
                     "dem: rejected a message from peer 'fem' while waiting for kinematics of window 42: "
                     "Kinematics for window 42: field 'positions'[7] (node 2, y) is nan; the sender produced "
                     "a non-finite value (diverged solution?)")},
        {"abort-over-limit", abortOverLimit()},
        // Refusals a sender can encode but a receiver must reject; rarely reached by mutation from valid seeds.
        {"hello-empty-name", encodeHello(hello(Role::Dem, "", ""))},
        {"mesh-3x3-infinite-step",
         encodeMesh(grid3, std::numeric_limits<double>::infinity(), sagging(grid3, 0.0, false, false))},
        {"checkpoint-name-with-slash", checkpointNamePatched('/')},
    };
    for (const auto& [name, bytes] : seeds) {
      const std::string path = folder + "/" + name;
      std::ofstream file(path, std::ios::binary | std::ios::trunc);
      file.write(reinterpret_cast<const char*>(bytes.data()), static_cast<std::streamsize>(bytes.size()));
      if (!file) throw Error("cannot write seed " + path);
    }
    std::printf("wrote %zu seed messages to %s\n", seeds.size(), folder.c_str());
  } catch (const std::exception& error) {
    std::fprintf(stderr, "protocol seeds: %s\n", error.what());
    return 1;
  }
  return 0;
}
