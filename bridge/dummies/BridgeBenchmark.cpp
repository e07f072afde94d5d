// Cost of the bridge per coupling window against a plain ZeroMQ ping-pong of the same bytes (ipc and tcp).
#include "DummyCommon.hpp"

#include "com/RawTransfer.hpp"
#include "protocol/Message.hpp"
#include "railcosim/Error.hpp"
#include "railcosim/Participant.hpp"

#include <algorithm>
#include <chrono>
#include <cstdio>
#include <exception>
#include <fstream>
#include <sstream>
#include <thread>
#include <unistd.h>

using namespace railcosim;

namespace {

const char* usage =
    "railcosim_bridge_benchmark: bridge cost per coupling window vs raw ZeroMQ transfer of the same bytes.\n"
    "  --nodes LIST       interface sizes, comma-separated (1000,10000,100000)\n"
    "  --transports LIST  ipc,tcp (both)\n"
    "  --port P           first tcp port on 127.0.0.1 (5790)\n"
    "  --total-bytes B  windows per size are chosen so each size moves about B bytes in total (2e8)\n"
    "  --json PATH        also write the table as JSON\n"
    "Both participants run as threads of this process, each with its own ZeroMQ context, so the\n"
    "bytes cross the real ipc or tcp transport exactly as between two processes.";

struct Row {
  std::string transport;
  std::size_t nodes = 0;
  std::size_t forceBytes = 0;
  std::size_t kinematicsBytes = 0;
  int windows = 0;
  double rawRoundTrip = 0.0;             // s per window, plain ZeroMQ
  double bridgeRoundTrip = 0.0;          // s per window through FemParticipant/DemParticipant
  double bridgeSecondsPerExchange = 0.0; // encode + transfer inside the bridge, both sides, per message
  double encodeSecondsPerExchange = 0.0;
};

std::vector<long> parseList(const std::string& text) {
  std::vector<long> values;
  std::stringstream stream(text);
  std::string item;
  while (std::getline(stream, item, ',')) values.push_back(std::stol(item));
  return values;
}

std::vector<std::string> parseWords(const std::string& text) {
  std::vector<std::string> values;
  std::stringstream stream(text);
  std::string item;
  while (std::getline(stream, item, ',')) values.push_back(item);
  return values;
}

/// Runs FEM and DEM participants for `warmup + windows` windows; returns the timed part per window.
Row measureBridge(const std::string& endpoint, long nodesWanted, int windows, int warmup) {
  const long side = dummy::sideForNodes(nodesWanted);
  const InterfaceMesh mesh = dummy::rectangularSurface(side, side, 0.1);
  const std::size_t nodes = mesh.nodeCount();
  NodalKinematics kinematics;
  kinematics.positions = mesh.coordinates;
  kinematics.velocities.assign(3 * nodes, 0.25);
  kinematics.accelerations.assign(3 * nodes, -9.81);
  const double dt = 1e-4;

  ParticipantConfig femConfig{"fem", endpoint, 30.0, 1.0};
  ParticipantConfig demConfig{"dem", endpoint, 30.0, 1.0};
  BridgeStatistics femStatistics;
  std::exception_ptr femError;
  std::thread fem([&] {
    try {
      FemParticipant participant(femConfig);
      participant.initialize(mesh, dt, kinematics);
      std::uint64_t window = 0;
      while (participant.receiveForces()) {
        kinematics.time = static_cast<double>(window + 1) * dt;
        participant.sendKinematics(window++, kinematics);
        if (window == static_cast<std::uint64_t>(warmup)) {
          // statistics() is a snapshot source; the warm-up share is subtracted below
          femStatistics = participant.statistics();
        }
      }
      const BridgeStatistics total = participant.statistics();
      femStatistics.encodeSeconds = total.encodeSeconds - femStatistics.encodeSeconds;
      femStatistics.transferSeconds = total.transferSeconds - femStatistics.transferSeconds;
      femStatistics.exchanges = total.exchanges - femStatistics.exchanges;
    } catch (...) {
      femError = std::current_exception();
    }
  });

  Row row;
  row.nodes = nodes;
  row.windows = windows;
  std::exception_ptr demError;
  try {
    DemParticipant participant(demConfig);
    const InterfaceSetup setup = participant.initialize();
    ForceMessage message;
    message.forces.assign(3 * nodes, -1.5);
    BridgeStatistics atWarmup;
    auto start = std::chrono::steady_clock::now();
    for (int window = 0; window < warmup + windows; ++window) {
      if (window == warmup) {
        atWarmup = participant.statistics();
        start = std::chrono::steady_clock::now();
      }
      message.window = static_cast<std::uint64_t>(window);
      message.time = (window + 1) * setup.femTimeStep;
      participant.sendForces(message);
      participant.receiveKinematics(message.window);
    }
    row.bridgeRoundTrip = std::chrono::duration<double>(std::chrono::steady_clock::now() - start).count() / windows;
    const BridgeStatistics& total = participant.statistics();
    const double demEncode = total.encodeSeconds - atWarmup.encodeSeconds;
    const double demTransfer = total.transferSeconds - atWarmup.transferSeconds;
    const double demExchanges = static_cast<double>(total.exchanges - atWarmup.exchanges);
    participant.finalize();
    fem.join();
    if (femError) std::rethrow_exception(femError);
    const double exchanges = demExchanges + static_cast<double>(femStatistics.exchanges);
    row.encodeSecondsPerExchange = (demEncode + femStatistics.encodeSeconds) / exchanges;
    row.bridgeSecondsPerExchange =
        (demEncode + demTransfer + femStatistics.encodeSeconds + femStatistics.transferSeconds) / exchanges;
  } catch (...) {
    demError = std::current_exception();
  }
  if (fem.joinable()) fem.join();
  if (demError) std::rethrow_exception(demError);
  ForceMessage sizing;
  sizing.forces.assign(3 * nodes, 0.0);
  row.forceBytes = protocol::encodeForces(sizing).size();
  row.kinematicsBytes = protocol::encodeKinematics(0, kinematics).size();
  return row;
}

} // namespace

int main(int argc, char** argv) {
  try {
    const dummy::Options options(argc, argv,
                                 {{"nodes", "1000,10000,100000"},
                                  {"transports", "ipc,tcp"},
                                  {"port", "5790"},
                                  {"total-bytes", "2e8"},
                                  {"json", ""}},
                                 usage);
    const double totalBytes = options.number("total-bytes");
    int port = static_cast<int>(options.integer("port"));
    std::vector<Row> rows;
    std::printf("%-5s %8s %10s %10s %7s %12s %12s %7s %14s %12s\n", "trans", "nodes", "F bytes", "K bytes", "windows",
                "raw us/win", "bridge us/win", "ratio", "bridge us/msg", "encode us/msg");
    for (const std::string& transport : parseWords(options.text("transports"))) {
      for (long nodes : parseList(options.text("nodes"))) {
        const double bytesPerWindow = 4.0 * 24.0 * static_cast<double>(nodes); // forces + P,V,A
        const int windows = std::clamp(static_cast<int>(totalBytes / bytesPerWindow), 20, 5000);
        const int warmup = std::max(5, windows / 10);
        auto endpointFor = [&]() {
          if (transport == "tcp") return "tcp://127.0.0.1:" + std::to_string(port++);
          if (transport == "ipc") {
            return "ipc:///tmp/railcosim-benchmark-" + std::to_string(getpid()) + "-" + std::to_string(port++) +
                   ".sock";
          }
          throw Error("unknown transport '" + transport + "'; use ipc or tcp");
        };
        Row row = measureBridge(endpointFor(), nodes, windows, warmup);
        row.transport = transport;
        row.rawRoundTrip = com::measureRawRoundTrip(endpointFor(), row.forceBytes, row.kinematicsBytes, windows, warmup)
                               .secondsPerRoundTrip;
        std::printf("%-5s %8zu %10zu %10zu %7d %12.1f %12.1f %7.2f %14.1f %12.1f\n", row.transport.c_str(), row.nodes,
                    row.forceBytes, row.kinematicsBytes, row.windows, row.rawRoundTrip * 1e6, row.bridgeRoundTrip * 1e6,
                    row.bridgeRoundTrip / row.rawRoundTrip, row.bridgeSecondsPerExchange * 1e6,
                    row.encodeSecondsPerExchange * 1e6);
        std::fflush(stdout);
        rows.push_back(row);
      }
    }
    std::printf("ratio = bridge round trip per window / raw ZeroMQ round trip of the same bytes.\n");
    const std::string jsonPath = options.text("json");
    if (!jsonPath.empty()) {
      std::ofstream json(jsonPath);
      if (!json) throw Error("cannot write --json file '" + jsonPath + "'");
      json << "{\n  \"benchmark\": \"railcosim_bridge_benchmark\",\n  \"protocolVersion\": "
           << protocol::protocolVersion << ",\n  \"rows\": [\n";
      for (std::size_t i = 0; i < rows.size(); ++i) {
        const Row& row = rows[i];
        json << "    {\"transport\": \"" << row.transport << "\", \"nodes\": " << row.nodes
             << ", \"forceBytes\": " << row.forceBytes << ", \"kinematicsBytes\": " << row.kinematicsBytes
             << ", \"windows\": " << row.windows << ", \"rawRoundTripSeconds\": " << row.rawRoundTrip
             << ", \"bridgeRoundTripSeconds\": " << row.bridgeRoundTrip
             << ", \"ratio\": " << row.bridgeRoundTrip / row.rawRoundTrip
             << ", \"bridgeSecondsPerExchange\": " << row.bridgeSecondsPerExchange
             << ", \"encodeSecondsPerExchange\": " << row.encodeSecondsPerExchange << "}"
             << (i + 1 < rows.size() ? "," : "") << "\n";
      }
      json << "  ]\n}\n";
    }
    return 0;
  } catch (const std::exception& error) {
    std::fprintf(stderr, "railcosim_bridge_benchmark: ERROR: %s\n", error.what());
    return 1;
  }
}
