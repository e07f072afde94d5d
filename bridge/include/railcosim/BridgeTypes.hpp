// Data the bridge's participants, protocol and coupling schemes share: configuration, handshake result,
// force messages and cost statistics (no behaviour, so that protocol and config need not see the facade).
#pragma once

#include "railcosim/InterfaceMesh.hpp"

#include <cstdint>
#include <string>
#include <vector>

namespace railcosim {

/// How a participant reaches its peer. The FEM side binds, the DEM side connects; either may start
/// first (the connecting side retries until the peer appears or `timeoutSeconds` passes). A tcp endpoint
/// written with host '*' binds to 127.0.0.1 only.
struct ParticipantConfig {
  std::string name;                // this participant, e.g. "fem" (printed in every error)
  std::string endpoint;            // ZeroMQ endpoint, e.g. "ipc:///tmp/railcosim-1234.sock" or "tcp://127.0.0.1:5555"
  double timeoutSeconds = 60.0;    // longest wait for any expected message before PeerLostError
  double heartbeatSeconds = 1.0;   // transport heartbeat: a frozen or dead peer is detected in ~3x this
  std::string couplingScheme;      // optional "justInTime" | "predictive" | "implicit": announced at the handshake;
                                   // when both sides name one, a mismatch is refused there
  std::string token;               // run secret shared by both sides (empty: the environment variable
                                   // RAILCOSIM_BRIDGE_TOKEN, else none); the FEM side admits only the first
                                   // participant presenting it, and binding a non-loopback tcp host needs one
  std::string recordPath;          // file to record every interface message of the run into (empty: the
                                   // environment variable RAILCOSIM_BRIDGE_RECORD, else none); railcosim_replay
                                   // plays either side back from it
  std::string resumedFrom;         // restart checkpoint this participant resumed from ("": a fresh start), announced
  std::uint64_t resumedWindow = 0; // at the handshake with its window; both sides must name the same one
};

/// What the DEM side learns at the handshake.
struct InterfaceSetup {
  std::string peerName;       // the FEM participant's name
  InterfaceMesh mesh;         // surface nodes + triangles at t = 0
  double femTimeStep = 0.0;   // s; the coupling window length
  NodalKinematics initial;    // kinematics at t = 0
  std::string couplingScheme; // the FEM side's ParticipantConfig::couplingScheme ("" if it named none)
};

/// Nodal forces of one coupling window (DEM -> FEM).
struct ForceMessage {
  std::uint64_t window = 0;    // window index i: forces for the step t_i -> t_i+1
  std::uint32_t iteration = 0; // implicit scheme: pass k over window i (0 = first); other schemes: 0
  double time = 0.0;           // s, the time the forces refer to
  std::vector<double> forces;  // N, 3 per interface node
};

/// A restart checkpoint the DEM side orders at a window boundary (docs/protocol.md §12).
struct CheckpointOrder {
  std::uint64_t window = 0; // windows completed; the run goes on with window `window`
  double time = 0.0;        // s, t_window
  std::string name;         // the checkpoint's folder name, e.g. "window-00000800"
};

/// Time spent inside the bridge, for the cost report. Waiting for the peer is counted separately.
struct BridgeStatistics {
  std::uint64_t exchanges = 0;  // messages sent + received after the handshake
  std::uint64_t bytes = 0;      // payload bytes sent + received
  double encodeSeconds = 0.0;   // packing and unpacking messages
  double transferSeconds = 0.0; // inside ZeroMQ send/receive calls once the message is available
  double waitSeconds = 0.0;     // waiting for the peer's message to arrive (peer computing)
  double bridgeSeconds() const { return encodeSeconds + transferSeconds; }
};

} // namespace railcosim
