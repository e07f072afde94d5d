// Replay participant: plays one side of a recorded run back, so the other solver runs, is debugged and
// regression-tested alone; compares what the live side answers with what it answered in the recording.
#include "DummyCommon.hpp"

#include "io/Recording.hpp"
#include "protocol/Message.hpp"
#include "railcosim/Checkpoint.hpp"
#include "railcosim/Error.hpp"
#include "railcosim/Participant.hpp"

#include <algorithm>
#include <cmath>
#include <cstdio>
#include <optional>

using namespace railcosim;

namespace {

const char* usage =
    "railcosim_replay: plays one side of a recorded run (RAILCOSIM_BRIDGE_RECORD / ./railcosim run --record).\n"
    "  --recording FILE  the recording\n"
    "  --play SIDE       fem | dem: the side to stand in for (the live solver is the other one)\n"
    "  --endpoint E      ZeroMQ endpoint (the FEM side binds it, the DEM side connects)\n"
    "  --timeout S       longest wait for the live side [s] (60)\n"
    "  --heartbeat S     keepalive interval [s] (1)\n"
    "  --tolerance T     largest relative difference of an answer still counted equal (1e-12)\n"
    "Prints the largest difference between the live side's answers and the recorded ones.\n"
    "Restart checkpoints in the recording are exchanged again: playing the FEM side, the live DEM side's orders must\n"
    "be the recorded ones and are answered with the recorded file list; playing the DEM side, the orders go to the\n"
    "live FEM side (into RAILCOSIM_CHECKPOINT_DIR), whose file list must be the recorded one (names, sizes, CRC-32).\n"
    "Exit status: 0 answers equal within the tolerance, 1 they differ (or other error), 2 peer lost, 3 protocol error.";

/// A recorded message, decoded far enough to replay it.
struct Step {
  bool fromPlayed = false; // sent by the side this program plays
  protocol::Header header;
  const std::vector<std::uint8_t>* bytes = nullptr;
};

/// max |live - recorded| over max |recorded| (absolute when the recording is all zeros).
struct Difference {
  double worst = 0.0;
  long compared = 0;
  long differing = 0;
  void add(const std::vector<double>& live, const std::vector<double>& recorded, double tolerance) {
    double scale = 0.0, largest = 0.0;
    for (double v : recorded) scale = std::max(scale, std::abs(v));
    for (std::size_t k = 0; k < std::min(live.size(), recorded.size()); ++k)
      largest = std::max(largest, std::abs(live[k] - recorded[k]));
    const double relative = live.size() != recorded.size() ? INFINITY : (scale > 0.0 ? largest / scale : largest);
    worst = std::max(worst, relative);
    ++compared;
    if (relative > tolerance) ++differing;
  }
  /// A checkpoint's files: the same names, sizes and CRC-32 (a solver that saves the same state writes the same bytes).
  void add(const std::vector<CheckpointFile>& live, const std::vector<CheckpointFile>& recorded) {
    bool same = live.size() == recorded.size();
    for (std::size_t k = 0; same && k < live.size(); ++k)
      same =
          live[k].name == recorded[k].name && live[k].bytes == recorded[k].bytes && live[k].crc32 == recorded[k].crc32;
    if (!same) worst = INFINITY;
    ++compared;
    if (!same) ++differing;
  }
};

} // namespace

int main(int argc, char** argv) {
  return dummy::runReportingErrors("railcosim_replay", [&]() -> int {
    const dummy::Options options(argc, argv,
                                 {{"recording", ""},
                                  {"play", ""},
                                  {"endpoint", ""},
                                  {"timeout", "60"},
                                  {"heartbeat", "1"},
                                  {"tolerance", "1e-12"}},
                                 usage);
    const std::string play = options.text("play");
    if (play != "fem" && play != "dem") throw Error("--play must be fem or dem, got '" + play + "'\n" + usage);
    if (options.text("recording").empty() || options.text("endpoint").empty())
      throw Error(std::string("--recording and --endpoint are required\n") + usage);
    const double tolerance = options.number("tolerance");
    const io::Recording recording = io::readRecording(options.text("recording"));

    // Which recorded messages the played side sent: the recorder's own when it played that side.
    std::vector<Step> steps;
    std::optional<protocol::Hello> playedHello;
    std::optional<protocol::MeshSetup> meshSetup;
    for (const io::RecordedMessage& message : recording.messages) {
      Step step;
      step.fromPlayed = message.sent == (recording.role == play);
      step.header = protocol::decodeHeader(message.bytes.data(), message.bytes.size());
      step.bytes = &message.bytes;
      if (step.header.type == protocol::MessageType::Hello && step.fromPlayed)
        playedHello = protocol::decodeHello(step.header, message.bytes.data());
      if (step.header.type == protocol::MessageType::InterfaceMesh)
        meshSetup = protocol::decodeMesh(step.header, message.bytes.data());
      steps.push_back(step);
    }
    if (!playedHello || !meshSetup)
      throw Error("recording '" + options.text("recording") + "' holds no complete handshake (Hello of the " + play +
                  " side and the interface mesh)");
    const std::size_t nodes = meshSetup->mesh.nodeCount();

    ParticipantConfig config;
    config.name = playedHello->participantName;
    config.endpoint = options.text("endpoint");
    config.timeoutSeconds = options.number("timeout");
    config.heartbeatSeconds = options.number("heartbeat");
    config.couplingScheme = playedHello->couplingScheme;
    config.resumedFrom = playedHello->resumedFrom; // a recording of a resumed run pairs with a resumed live side
    config.resumedWindow = playedHello->resumedWindow;

    Difference difference;
    long played = 0;
    if (play == "fem") {
      FemParticipant participant(config);
      participant.initialize(meshSetup->mesh, meshSetup->femTimeStep, meshSetup->initial);
      for (const Step& step : steps) {
        const protocol::MessageType type = step.header.type;
        if (type == protocol::MessageType::Hello || type == protocol::MessageType::InterfaceMesh) continue;
        if (type == protocol::MessageType::Abort) break; // the recorded run failed here
        if ((type == protocol::MessageType::Forces || type == protocol::MessageType::Checkpoint) && !step.fromPlayed) {
          const FemIncoming live = participant.receive();
          if (live.kind == FemIncoming::Kind::Finalized)
            throw PeerLostError("the DEM side finalized before the recorded " + protocol::describe(step.header));
          if ((live.kind == FemIncoming::Kind::Checkpoint) != (type == protocol::MessageType::Checkpoint))
            throw Error(std::string("the DEM side sent ") +
                        (live.kind == FemIncoming::Kind::Checkpoint
                             ? "checkpoint order " + live.checkpoint.name
                             : "forces of window " + std::to_string(live.forces.window)) +
                        " where the recording has " + protocol::describe(step.header));
          if (live.kind == FemIncoming::Kind::Checkpoint) {
            const CheckpointOrder recorded = protocol::decodeCheckpoint(step.header, step.bytes->data());
            if (live.checkpoint.window != recorded.window || live.checkpoint.name != recorded.name)
              throw Error("the DEM side ordered checkpoint " + live.checkpoint.name + " where the recording has " +
                          recorded.name);
            continue;
          }
          const ForceMessage recorded = protocol::decodeForces(step.header, step.bytes->data(), nodes);
          if (live.forces.window != recorded.window || live.forces.iteration != recorded.iteration)
            throw Error("the DEM side sent forces of window " + std::to_string(live.forces.window) + " (iteration " +
                        std::to_string(live.forces.iteration) + ") where the recording has " +
                        protocol::describe(step.header));
          difference.add(live.forces.forces, recorded.forces, tolerance);
        } else if (type == protocol::MessageType::CheckpointWritten && step.fromPlayed) {
          participant.confirmCheckpoint(step.header.window, decodeCheckpointFiles(protocol::decodeCheckpointWritten(
                                                                step.header, step.bytes->data())));
        } else if (type == protocol::MessageType::Kinematics && step.fromPlayed) {
          participant.sendKinematics(step.header.window,
                                     protocol::decodeKinematics(step.header, step.bytes->data(), nodes));
          ++played;
        } else if (type == protocol::MessageType::Finalize) {
          if (!step.fromPlayed && participant.receive().kind != FemIncoming::Kind::Finalized)
            throw Error("the DEM side went on where the recorded run ended");
          break;
        }
      }
      participant.finalize();
    } else {
      DemParticipant participant(config);
      std::vector<CheckpointFile> liveFiles; // the live FEM side's answer to the checkpoint ordered last
      const InterfaceSetup setup = participant.initialize();
      if (setup.mesh.coordinates != meshSetup->mesh.coordinates || setup.mesh.triangles != meshSetup->mesh.triangles)
        throw Error("the FEM side's interface mesh differs from the recorded one (" +
                    std::to_string(setup.mesh.nodeCount()) + " nodes now, " + std::to_string(nodes) + " recorded)");
      for (const Step& step : steps) {
        const protocol::MessageType type = step.header.type;
        if (type == protocol::MessageType::Hello || type == protocol::MessageType::InterfaceMesh) continue;
        if (type == protocol::MessageType::Abort) break;
        if (type == protocol::MessageType::Forces && step.fromPlayed) {
          participant.sendForces(protocol::decodeForces(step.header, step.bytes->data(), nodes));
          ++played;
        } else if (type == protocol::MessageType::Checkpoint && step.fromPlayed) {
          const CheckpointOrder order = protocol::decodeCheckpoint(step.header, step.bytes->data());
          const std::string root = CheckpointSettings::fromEnvironment().folder;
          if (!root.empty()) prepareCheckpoint(root, order.name); // where the live FEM side writes its part
          liveFiles = participant.orderCheckpoint(order);
          ++played;
        } else if (type == protocol::MessageType::CheckpointWritten && !step.fromPlayed) {
          difference.add(liveFiles,
                         decodeCheckpointFiles(protocol::decodeCheckpointWritten(step.header, step.bytes->data())));
        } else if (type == protocol::MessageType::Kinematics && !step.fromPlayed) {
          const NodalKinematics live = participant.receiveKinematics(step.header.window);
          const NodalKinematics recorded = protocol::decodeKinematics(step.header, step.bytes->data(), nodes);
          difference.add(live.positions, recorded.positions, tolerance);
          difference.add(live.velocities, recorded.velocities, tolerance);
          difference.add(live.accelerations, recorded.accelerations, tolerance);
        } else if (type == protocol::MessageType::Finalize) {
          break;
        }
      }
      participant.finalize();
    }
    const bool equal = difference.differing == 0;
    std::printf(
        "railcosim_replay: %s played the %s side of %s: %ld messages sent, %ld answers compared, %ld beyond "
        "the tolerance %.1e, largest relative difference %.3e\n",
        equal ? "OK" : "DIFFERENT", play.c_str(), options.text("recording").c_str(), played, difference.compared,
        difference.differing, tolerance, difference.worst);
    return equal ? 0 : 1;
  });
}
