// Wire format: every message type survives a round trip, and each kind of bad message is rejected naming its field.
#define BOOST_TEST_MODULE bridge_protocol
#include <boost/test/unit_test.hpp>

#include "protocol/Message.hpp"
#include "railcosim/Error.hpp"

#include <cmath>
#include <cstring>
#include <limits>

using namespace railcosim;
using namespace railcosim::protocol;

namespace {

InterfaceMesh twoTriangles() {
  InterfaceMesh mesh;
  mesh.coordinates = {0, 0, 0, 1, 0, 0, 1, 1, 0, 0, 1, 0.5};
  mesh.triangles = {0, 1, 2, 0, 2, 3};
  return mesh;
}

NodalKinematics kinematicsFor(std::size_t nodes, bool withVelocity, bool withAcceleration) {
  NodalKinematics kinematics;
  kinematics.time = 0.125;
  for (std::size_t i = 0; i < 3 * nodes; ++i) {
    kinematics.positions.push_back(0.1 * static_cast<double>(i) - 0.7);
    if (withVelocity) kinematics.velocities.push_back(-1.0e-3 * static_cast<double>(i));
    if (withAcceleration) kinematics.accelerations.push_back(9.81 + static_cast<double>(i));
  }
  return kinematics;
}

/// Expects ProtocolError whose message contains every one of `fragments`.
template <class Call>
void expectRejected(Call call, std::initializer_list<const char*> fragments) {
  try {
    call();
  } catch (const ProtocolError& error) {
    const std::string message = error.what();
    for (const char* fragment : fragments) {
      BOOST_TEST_INFO("message: " << message);
      BOOST_TEST(message.find(fragment) != std::string::npos, "missing '" << fragment << "'");
    }
    return;
  }
  BOOST_FAIL("no ProtocolError thrown");
}

Header decode(const std::vector<std::uint8_t>& bytes) { return decodeHeader(bytes.data(), bytes.size()); }

/// Overwrites a little-endian field of the header at `offset` (layout in docs/protocol.md).
template <class T>
void patch(std::vector<std::uint8_t>& bytes, std::size_t offset, T value) {
  std::memcpy(bytes.data() + offset, &value, sizeof(T)); // the test host is little-endian like the wire
}

constexpr std::size_t offsetVersion = 4, offsetType = 6, offsetIteration = 16, offsetFlags = 20, offsetTime = 24,
                      offsetNodes = 32, offsetTriangles = 40, offsetPayload = 48;

} // namespace

BOOST_AUTO_TEST_CASE(header_is_56_bytes_with_magic_and_version_first) {
  const auto bytes = encodeFinalize(7);
  BOOST_TEST(bytes.size() == headerBytes);
  BOOST_TEST(std::memcmp(bytes.data(), "RCSM", 4) == 0);
  BOOST_TEST(bytes[4] == protocolVersion); // little-endian uint16
  BOOST_TEST(bytes[5] == 0);
  const Header header = decode(bytes);
  BOOST_TEST(header.window == 7u);
  BOOST_TEST((header.type == MessageType::Finalize));
  BOOST_CHECK_NO_THROW(decodeFinalize(header));
}

BOOST_AUTO_TEST_CASE(hello_round_trip) {
  Hello hello;
  hello.role = Role::Dem;
  hello.participantName = "ballast-dem";
  const auto bytes = encodeHello(hello);
  const Header header = decode(bytes);
  BOOST_TEST((header.type == MessageType::Hello));
  const Hello back = decodeHello(header, bytes.data());
  BOOST_TEST(back.couplingScheme.empty());
  hello.couplingScheme = "predictive";
  const auto withScheme = encodeHello(hello);
  BOOST_TEST(decodeHello(decode(withScheme), withScheme.data()).couplingScheme == "predictive");
  BOOST_TEST(back.participantName == "ballast-dem");
  BOOST_TEST(back.unitSystem == "SI");
  BOOST_TEST((back.role == Role::Dem));
}

BOOST_AUTO_TEST_CASE(mesh_round_trip_with_and_without_optional_arrays) {
  const InterfaceMesh mesh = twoTriangles();
  for (int variant = 0; variant < 4; ++variant) {
    const NodalKinematics initial = kinematicsFor(mesh.nodeCount(), variant & 1, variant & 2);
    const auto bytes = encodeMesh(mesh, 1e-5, initial);
    const MeshSetup setup = decodeMesh(decode(bytes), bytes.data());
    BOOST_TEST(setup.femTimeStep == 1e-5);
    BOOST_TEST(setup.mesh.coordinates == mesh.coordinates);
    BOOST_TEST(setup.mesh.triangles == mesh.triangles);
    BOOST_TEST(setup.initial.time == initial.time);
    BOOST_TEST(setup.initial.positions == initial.positions);
    BOOST_TEST(setup.initial.velocities == initial.velocities);
    BOOST_TEST(setup.initial.accelerations == initial.accelerations);
  }
}

BOOST_AUTO_TEST_CASE(forces_and_kinematics_round_trip_bit_exact) {
  ForceMessage forces;
  forces.window = 42;
  forces.time = 4.3e-3;
  // Values that stress the byte order and sign handling: subnormal, negative zero, extremes.
  forces.forces = {1.0, -0.0, std::numeric_limits<double>::denorm_min(), -1e300, 3.14159, 2.5e-7};
  const auto forceBytes = encodeForces(forces);
  const ForceMessage forcesBack = decodeForces(decode(forceBytes), forceBytes.data(), 2);
  BOOST_TEST(forcesBack.window == 42u);
  BOOST_TEST(forcesBack.time == forces.time);
  BOOST_TEST(std::memcmp(forcesBack.forces.data(), forces.forces.data(), 6 * sizeof(double)) == 0);

  const NodalKinematics kinematics = kinematicsFor(5, true, true);
  const auto kinematicsBytes = encodeKinematics(9, kinematics);
  const Header header = decode(kinematicsBytes);
  BOOST_TEST(header.window == 9u);
  const NodalKinematics back = decodeKinematics(header, kinematicsBytes.data(), 5);
  BOOST_TEST(back.positions == kinematics.positions);
  BOOST_TEST(back.velocities == kinematics.velocities);
  BOOST_TEST(back.accelerations == kinematics.accelerations);
  BOOST_TEST(back.time == kinematics.time);
}

BOOST_AUTO_TEST_CASE(hello_announces_the_checkpoint_resumed_from) {
  Hello hello;
  hello.role = Role::Fem;
  hello.participantName = "fem";
  hello.resumedFrom = "window-00000800";
  hello.resumedWindow = 800;
  const auto bytes = encodeHello(hello);
  const Header header = decode(bytes);
  BOOST_TEST(header.window == 800u);
  const Hello back = decodeHello(header, bytes.data());
  BOOST_TEST(back.resumedFrom == "window-00000800");
  BOOST_TEST(back.resumedWindow == 800u);
  // A window without the checkpoint it comes from, or a name that is no folder name, is refused.
  hello.resumedFrom.clear();
  BOOST_CHECK_THROW(encodeHello(hello), ProtocolError);
  auto fresh = encodeHello(Hello{Role::Fem, "fem", "SI", "", "", 0});
  patch<std::uint64_t>(fresh, 8, 800);
  expectRejected([&] { decodeHello(decode(fresh), fresh.data()); },
                 {"field 'window' is 800", "'resumedFrom' is empty"});
  hello.resumedFrom = "../elsewhere";
  BOOST_CHECK_THROW(encodeHello(hello), ProtocolError);
}

BOOST_AUTO_TEST_CASE(checkpoint_messages_round_trip_and_refusals) {
  CheckpointOrder order;
  order.window = 800;
  order.time = 0.4;
  order.name = "window-00000800";
  const auto bytes = encodeCheckpoint(order);
  const Header header = decode(bytes);
  BOOST_TEST((header.type == MessageType::Checkpoint));
  BOOST_TEST(describe(header) == "Checkpoint for window 800");
  const CheckpointOrder back = decodeCheckpoint(header, bytes.data());
  BOOST_TEST(back.window == 800u);
  BOOST_TEST(back.time == 0.4);
  BOOST_TEST(back.name == "window-00000800");
  for (const char* bad : {"", ".hidden", "a/b", "tab\there"}) {
    order.name = bad;
    BOOST_CHECK_THROW(encodeCheckpoint(order), ProtocolError);
  }
  auto slash = bytes;
  slash[headerBytes + 6] = '/';
  expectRejected([&] { decodeCheckpoint(decode(slash), slash.data()); }, {"Checkpoint for window 800", "field 'name'"});

  const std::string files = "fem\tfem_state.bin\t\t9843\tec18bd81\n";
  const auto written = encodeCheckpointWritten(800, files);
  BOOST_TEST(decodeCheckpointWritten(decode(written), written.data()) == files);
  BOOST_CHECK_THROW(encodeCheckpointWritten(800, std::string("bell\a")), ProtocolError);
  auto control = written;
  control[headerBytes] = 0x07;
  expectRejected([&] { decodeCheckpointWritten(decode(control), control.data()); },
                 {"CheckpointWritten for window 800", "control character"});
  auto withNodes = written;
  patch<std::uint64_t>(withNodes, offsetNodes, 1);
  expectRejected([&] { decodeCheckpointWritten(decode(withNodes), withNodes.data()); }, {"nodeCount"});
}

BOOST_AUTO_TEST_CASE(abort_round_trip) {
  const auto bytes = encodeAbort(3, "fem: matrix factorisation failed");
  BOOST_TEST(decodeAbort(decode(bytes), bytes.data()) == "fem: matrix factorisation failed");
}

BOOST_AUTO_TEST_CASE(rejects_bad_magic) {
  auto bytes = encodeFinalize(0);
  bytes[0] = 'X';
  expectRejected([&] { decode(bytes); }, {"magic"});
}

BOOST_AUTO_TEST_CASE(rejects_version_mismatch_naming_both_versions) {
  Hello hello;
  hello.participantName = "dem";
  hello.role = Role::Dem;
  const auto bytes = encodeHello(hello, 7);
  const std::string ours = "version " + std::to_string(protocolVersion);
  expectRejected([&] { decode(bytes); }, {"version", "version 7", ours.c_str()});
}

BOOST_AUTO_TEST_CASE(rejects_unknown_type) {
  auto bytes = encodeFinalize(0);
  patch<std::uint16_t>(bytes, offsetType, 99);
  expectRejected([&] { decode(bytes); }, {"type", "99"});
}

BOOST_AUTO_TEST_CASE(rejects_truncated_and_oversized_messages) {
  ForceMessage forces;
  forces.forces.assign(12, 1.0);
  auto bytes = encodeForces(forces);
  auto truncated = bytes;
  truncated.resize(bytes.size() - 8);
  expectRejected([&] { decode(truncated); }, {"truncated", "payloadBytes"});
  auto oversized = bytes;
  oversized.push_back(0);
  expectRejected([&] { decode(oversized); }, {"oversized", "payloadBytes"});
  std::vector<std::uint8_t> stub(bytes.begin(), bytes.begin() + 20);
  expectRejected([&] { decode(stub); }, {"truncated", "header"});
}

BOOST_AUTO_TEST_CASE(rejects_counts_inconsistent_with_the_mesh) {
  ForceMessage forces;
  forces.forces.assign(12, 1.0); // 4 nodes
  const auto bytes = encodeForces(forces);
  expectRejected([&] { decodeForces(decode(bytes), bytes.data(), 5); }, {"nodeCount", "4", "5 nodes"});
  const auto kinematicsBytes = encodeKinematics(0, kinematicsFor(3, true, false));
  expectRejected([&] { decodeKinematics(decode(kinematicsBytes), kinematicsBytes.data(), 4); }, {"nodeCount"});
  // Header counts that disagree with the payload length.
  auto inconsistent = encodeForces(forces);
  patch<std::uint64_t>(inconsistent, offsetNodes, 5);
  expectRejected([&] { decodeForces(decode(inconsistent), inconsistent.data(), 5); }, {"payloadBytes", "needs"});
  // Kinematics flags announce velocities that are not in the payload.
  auto missingArray = encodeKinematics(0, kinematicsFor(3, false, false));
  patch<std::uint32_t>(missingArray, offsetFlags, flagVelocities);
  expectRejected([&] { decodeKinematics(decode(missingArray), missingArray.data(), 3); }, {"payloadBytes"});
}

BOOST_AUTO_TEST_CASE(rejects_non_finite_values_naming_field_and_node) {
  // The encoders refuse non-finite values, so bad messages are made by patching valid ones.
  const double nan = std::numeric_limits<double>::quiet_NaN();
  const double infinity = std::numeric_limits<double>::infinity();
  ForceMessage forces;
  forces.forces.assign(12, 1.0);
  auto bytes = encodeForces(forces);
  patch<double>(bytes, headerBytes + 7 * sizeof(double), nan);
  expectRejected([&] { decodeForces(decode(bytes), bytes.data(), 4); }, {"'forces'[7]", "node 2", "y"});

  // Kinematics of 3 nodes: positions (9 values), velocities (9), accelerations (9).
  auto kinematicsBytes = encodeKinematics(1, kinematicsFor(3, true, true));
  patch<double>(kinematicsBytes, headerBytes + (18 + 2) * sizeof(double), infinity);
  expectRejected([&] { decodeKinematics(decode(kinematicsBytes), kinematicsBytes.data(), 3); },
                 {"'accelerations'[2]", "node 0", "Kinematics for window 1"});

  auto badTime = encodeFinalize(0);
  patch<double>(badTime, offsetTime, nan);
  expectRejected([&] { decode(badTime); }, {"'time'"});

  // InterfaceMesh payload: femTimeStep, then the coordinates.
  auto meshBytes = encodeMesh(twoTriangles(), 1e-4, kinematicsFor(4, false, false));
  patch<double>(meshBytes, headerBytes + (1 + 4) * sizeof(double), -infinity);
  expectRejected([&] { decodeMesh(decode(meshBytes), meshBytes.data()); }, {"'coordinates'[4]", "node 1"});
}

BOOST_AUTO_TEST_CASE(encoders_refuse_non_finite_values) {
  ForceMessage forces;
  forces.window = 5;
  forces.forces.assign(6, 0.0);
  forces.forces[3] = std::numeric_limits<double>::infinity();
  expectRejected([&] { encodeForces(forces); }, {"cannot encode", "Forces for window 5", "'forces'[3]", "node 1"});
  NodalKinematics kinematics = kinematicsFor(2, true, false);
  kinematics.velocities[0] = std::numeric_limits<double>::quiet_NaN();
  expectRejected([&] { encodeKinematics(2, kinematics); }, {"'velocities'[0]", "Kinematics for window 2"});
  InterfaceMesh mesh = twoTriangles();
  mesh.coordinates[0] = std::numeric_limits<double>::quiet_NaN();
  expectRejected([&] { encodeMesh(mesh, 1e-4, kinematicsFor(4, false, false)); }, {"'coordinates'[0]"});
}

BOOST_AUTO_TEST_CASE(reused_buffer_gives_identical_bytes) {
  ForceMessage forces;
  forces.window = 1;
  forces.forces.assign(300, 0.5);
  const auto fresh = encodeForces(forces);
  std::vector<std::uint8_t> used = encodeKinematics(0, kinematicsFor(200, true, true)); // larger, other content
  const auto reused = encodeForces(forces, std::move(used));
  BOOST_TEST(reused == fresh);
}

BOOST_AUTO_TEST_CASE(rejects_mesh_problems) {
  InterfaceMesh mesh = twoTriangles();
  mesh.triangles[4] = 4; // only nodes 0..3 exist
  auto bytes = encodeMesh(mesh, 1e-4, kinematicsFor(4, false, false));
  expectRejected([&] { decodeMesh(decode(bytes), bytes.data()); }, {"'triangles'[4]", "triangle 1", "out of range"});

  mesh = twoTriangles();
  bytes = encodeMesh(mesh, 0.0, kinematicsFor(4, false, false));
  expectRejected([&] { decodeMesh(decode(bytes), bytes.data()); }, {"femTimeStep"});

  mesh.triangles = {0, 1, 2, 0, 1, 1}; // second triangle has zero area
  bytes = encodeMesh(mesh, 1e-4, kinematicsFor(4, false, false));
  expectRejected([&] { decodeMesh(decode(bytes), bytes.data()); }, {"degenerate", "triangle 1"});

  mesh = twoTriangles();
  bytes = encodeMesh(mesh, 1e-4, kinematicsFor(4, false, false));
  patch<std::uint64_t>(bytes, offsetNodes, 0);
  expectRejected([&] { decodeMesh(decode(bytes), bytes.data()); }, {"nodeCount"});
}

BOOST_AUTO_TEST_CASE(rejects_reserved_fields_and_foreign_counts) {
  auto bytes = encodeFinalize(0);
  patch<std::uint32_t>(bytes, offsetIteration, 2);
  expectRejected([&] { decode(bytes); }, {"iteration"});
  // Forces and Kinematics carry the implicit pass number through encode and decode.
  ForceMessage pass;
  pass.window = 5;
  pass.iteration = 3;
  pass.forces.assign(3, 2.0);
  const auto passBytes = encodeForces(pass);
  const Header passHeader = decode(passBytes);
  BOOST_TEST(passHeader.iteration == 3u);
  BOOST_TEST(decodeForces(passHeader, passBytes.data(), 1).iteration == 3u);
  BOOST_TEST(describe(passHeader) == "Forces for window 5 (iteration 3)");
  NodalKinematics answer;
  answer.positions.assign(3, 1.0);
  BOOST_TEST(decode(encodeKinematics(5, answer, {}, 3)).iteration == 3u);

  ForceMessage forces;
  forces.forces.assign(3, 1.0);
  auto flagged = encodeForces(forces);
  patch<std::uint32_t>(flagged, offsetFlags, 0x80);
  expectRejected([&] { decodeForces(decode(flagged), flagged.data(), 1); }, {"flags"});

  auto withTriangles = encodeForces(forces);
  patch<std::uint64_t>(withTriangles, offsetTriangles, 1);
  expectRejected([&] { decodeForces(decode(withTriangles), withTriangles.data(), 1); }, {"triangleCount"});

  auto huge = encodeForces(forces);
  patch<std::uint64_t>(huge, offsetNodes, maxNodes + 1);
  expectRejected([&] { decode(huge); }, {"nodeCount", "limits"});

  auto finalizeWithPayload = encodeAbort(0, "x");
  patch<std::uint16_t>(finalizeWithPayload, offsetType, static_cast<std::uint16_t>(MessageType::Finalize));
  expectRejected([&] { decodeFinalize(decode(finalizeWithPayload)); }, {"payloadBytes"});
  (void)offsetVersion;
  (void)offsetPayload;
}

BOOST_AUTO_TEST_CASE(rejects_bad_hello_fields) {
  Hello hello;
  hello.participantName = "dem";
  hello.role = Role::Dem;
  auto bytes = encodeHello(hello);
  bytes[headerBytes] = 9; // role byte
  expectRejected([&] { decodeHello(decode(bytes), bytes.data()); }, {"'role'", "9"});

  hello.unitSystem = "mm-t-s";
  bytes = encodeHello(hello);
  expectRejected([&] { decodeHello(decode(bytes), bytes.data()); }, {"'unitSystem'", "mm-t-s"});

  hello.unitSystem = "SI";
  hello.couplingScheme = "semiImplicit";
  bytes = encodeHello(hello);
  expectRejected([&] { decodeHello(decode(bytes), bytes.data()); }, {"'couplingScheme'", "semiImplicit"});

  hello.couplingScheme = "";
  hello.participantName = "";
  bytes = encodeHello(hello);
  expectRejected([&] { decodeHello(decode(bytes), bytes.data()); }, {"'participantName'"});

  hello.participantName = "dem";
  bytes = encodeHello(hello);
  bytes[headerBytes + 1] = 200; // name length beyond the payload
  expectRejected([&] { decodeHello(decode(bytes), bytes.data()); }, {"truncated", "participantName"});
}

BOOST_AUTO_TEST_CASE(describe_names_type_and_window) {
  Header header;
  header.type = MessageType::Kinematics;
  header.window = 3;
  BOOST_TEST(describe(header) == "Kinematics for window 3");
  header.type = MessageType::Hello;
  BOOST_TEST(describe(header) == "Hello");
}

BOOST_AUTO_TEST_CASE(decodes_from_unaligned_memory) {
  // A transport buffer need not be 8-byte aligned: decoding must not depend on it.
  const NodalKinematics kinematics = kinematicsFor(7, true, true);
  const auto bytes = encodeKinematics(4, kinematics);
  std::vector<std::uint8_t> shifted(bytes.size() + 1);
  std::memcpy(shifted.data() + 1, bytes.data(), bytes.size());
  const std::uint8_t* unaligned = shifted.data() + 1;
  const NodalKinematics back = decodeKinematics(decodeHeader(unaligned, bytes.size()), unaligned, 7);
  BOOST_TEST(back.positions == kinematics.positions);
  BOOST_TEST(back.velocities == kinematics.velocities);
  BOOST_TEST(back.accelerations == kinematics.accelerations);
  std::vector<std::uint8_t> poisoned(shifted);
  const double nan = std::numeric_limits<double>::quiet_NaN();
  std::memcpy(poisoned.data() + 1 + headerBytes + 5 * sizeof(double), &nan, sizeof(double));
  expectRejected([&] { decodeKinematics(decodeHeader(poisoned.data() + 1, bytes.size()), poisoned.data() + 1, 7); },
                 {"'positions'[5]"});
}

BOOST_AUTO_TEST_CASE(rejects_node_count_in_messages_without_nodes) {
  // docs/protocol.md §2: nodeCount is 0 for Hello, Finalize and Abort. Found by tests/fuzz: Hello and Abort took any.
  Hello hello;
  hello.participantName = "dem";
  hello.role = Role::Dem;
  auto helloBytes = encodeHello(hello);
  patch<std::uint64_t>(helloBytes, offsetNodes, 29);
  expectRejected([&] { decodeHello(decode(helloBytes), helloBytes.data()); }, {"Hello", "'nodeCount'", "29"});

  auto abortBytes = encodeAbort(42, "dem: diverged");
  patch<std::uint64_t>(abortBytes, offsetNodes, 29);
  expectRejected([&] { decodeAbort(decode(abortBytes), abortBytes.data()); }, {"Abort", "'nodeCount'", "29"});

  auto finalizeBytes = encodeFinalize(42);
  patch<std::uint64_t>(finalizeBytes, offsetNodes, 29);
  expectRejected([&] { decodeFinalize(decode(finalizeBytes)); }, {"Finalize", "'nodeCount'", "29"});
}
