// The bridge wire format, defined once: header layout, message types, encoders and validating decoders.
#pragma once

#include "railcosim/InterfaceMesh.hpp"
#include "railcosim/BridgeTypes.hpp"

#include <cstddef>
#include <cstdint>
#include <string>
#include <vector>

namespace railcosim::protocol {

/// Bumped on any change of the byte layout or the transport; both participants must speak the same version.
/// 3: PLAIN authentication with the run token and empty keepalive frames (docs/protocol.md §1).
/// 4: Checkpoint and CheckpointWritten, the coordinated restart checkpoint (docs/protocol.md §12).
constexpr std::uint16_t protocolVersion = 4;
/// Every message starts with these 4 bytes.
constexpr char magic[4] = {'R', 'C', 'S', 'M'};
/// Fixed header size in bytes (docs/protocol.md, "Header").
constexpr std::size_t headerBytes = 56;
/// Upper bounds that keep a corrupt count from allocating unbounded memory.
constexpr std::uint64_t maxNodes = 100'000'000;
constexpr std::uint64_t maxTriangles = 200'000'000;
constexpr std::size_t maxTextBytes = 65'536;
/// The largest message these limits allow (an InterfaceMesh of maxNodes nodes and maxTriangles triangles
/// with velocities and accelerations): the transport drops a connection that announces more.
constexpr std::uint64_t maxMessageBytes = headerBytes + sizeof(double) + maxNodes * 3 * sizeof(double) +
                                          maxTriangles * 3 * sizeof(std::int32_t) + 3 * maxNodes * 3 * sizeof(double);
/// The largest message the FEM side can legally receive once its interface has `nodes` nodes: Forces,
/// or a Hello/Abort/Checkpoint carrying texts of at most maxTextBytes each.
constexpr std::uint64_t maxMessageBytesTowardsFem(std::uint64_t nodes) {
  const std::uint64_t forces = nodes * 3 * sizeof(double);
  const std::uint64_t texts = 1 + 4 * (2 + maxTextBytes);
  return headerBytes + (forces > texts ? forces : texts);
}

enum class MessageType : std::uint16_t {
  Hello = 1,
  InterfaceMesh = 2,
  Forces = 3,
  Kinematics = 4,
  Finalize = 5,
  Abort = 6,
  Checkpoint = 7,        // DEM -> FEM: save a restart checkpoint now
  CheckpointWritten = 8, // FEM -> DEM: its files of the checkpoint are written (their list)
};
std::string toString(MessageType type);

enum class Role : std::uint8_t { Fem = 1, Dem = 2 };
std::string toString(Role role);

/// Header flags of Kinematics and InterfaceMesh messages: which optional arrays follow the positions.
constexpr std::uint32_t flagVelocities = 1u << 0;
constexpr std::uint32_t flagAccelerations = 1u << 1;

struct Header {
  std::uint16_t version = protocolVersion;
  MessageType type = MessageType::Hello;
  std::uint64_t window = 0;
  std::uint32_t iteration = 0; // implicit coupling: pass k of window `window` (Forces, Kinematics); else 0
  std::uint32_t flags = 0;
  double time = 0.0;
  std::uint64_t nodeCount = 0;
  std::uint64_t triangleCount = 0;
  std::uint64_t payloadBytes = 0;
};

struct Hello {
  Role role = Role::Fem;
  std::string participantName;
  std::string unitSystem = "SI";
  std::string couplingScheme;      // "" (not stated), "justInTime", "predictive" or "implicit"
  std::string resumedFrom;         // the checkpoint this participant resumed from ("" for a fresh start)
  std::uint64_t resumedWindow = 0; // its window (header field `window`; 0 for a fresh start)
};

struct MeshSetup {
  InterfaceMesh mesh;
  double femTimeStep = 0.0;
  NodalKinematics initial;
};

/// Encoders. `version` exists so tests can build a message of another protocol version. `buffer`
/// may pass the memory of an earlier message for reuse. Reals are checked as they are copied:
/// a NaN or infinity throws ProtocolError naming the field and index, and nothing is sent.
std::vector<std::uint8_t> encodeHello(const Hello& hello, std::uint16_t version = protocolVersion,
                                      std::vector<std::uint8_t> buffer = {});
std::vector<std::uint8_t> encodeMesh(const InterfaceMesh& mesh, double femTimeStep, const NodalKinematics& initial,
                                     std::vector<std::uint8_t> buffer = {});
std::vector<std::uint8_t> encodeForces(const ForceMessage& message, std::vector<std::uint8_t> buffer = {});
std::vector<std::uint8_t> encodeKinematics(std::uint64_t window, const NodalKinematics& kinematics,
                                           std::vector<std::uint8_t> buffer = {}, std::uint32_t iteration = 0);
std::vector<std::uint8_t> encodeFinalize(std::uint64_t window, std::vector<std::uint8_t> buffer = {});
std::vector<std::uint8_t> encodeAbort(std::uint64_t window, const std::string& reason,
                                      std::vector<std::uint8_t> buffer = {});
/// `order.name` must be a folder name (letters, digits, '.', '-', '_'; not starting with '.').
std::vector<std::uint8_t> encodeCheckpoint(const CheckpointOrder& order, std::vector<std::uint8_t> buffer = {});
/// `files`: encodeCheckpointFiles() of the FEM side's files (text: tabs and line breaks, no other control characters).
std::vector<std::uint8_t> encodeCheckpointWritten(std::uint64_t window, const std::string& files,
                                                  std::vector<std::uint8_t> buffer = {});

/// Decoders: each throws ProtocolError naming the field that is wrong.
/// decodeHeader checks magic, version, type, reserved fields and that the payload size matches
/// what the header announces (truncated or oversized messages).
Header decodeHeader(const std::uint8_t* data, std::size_t size);
/// The body decoders take the whole message (header included) and the header decodeHeader returned.
Hello decodeHello(const Header& header, const std::uint8_t* data);
MeshSetup decodeMesh(const Header& header, const std::uint8_t* data);
/// `expectedNodes`: node count of the interface agreed at the handshake.
ForceMessage decodeForces(const Header& header, const std::uint8_t* data, std::size_t expectedNodes);
NodalKinematics decodeKinematics(const Header& header, const std::uint8_t* data, std::size_t expectedNodes);
std::string decodeAbort(const Header& header, const std::uint8_t* data);
CheckpointOrder decodeCheckpoint(const Header& header, const std::uint8_t* data);
std::string decodeCheckpointWritten(const Header& header, const std::uint8_t* data);
/// Finalize carries no payload, nodes or triangles.
void decodeFinalize(const Header& header);

/// "Forces for window 3" / "Finalize" / "Hello": used in "expected X, got Y" messages.
std::string describe(const Header& header);

} // namespace railcosim::protocol
