// Participants over real ipc transport: full runs, and a scripted fake peer sending wrong messages.
#define BOOST_TEST_MODULE integration_participant_protocol
#include <boost/test/unit_test.hpp>

#include "com/Channel.hpp"
#include "protocol/Message.hpp"
#include "railcosim/Error.hpp"
#include "railcosim/Participant.hpp"

#include "InterfaceFixtures.hpp"

#include <sys/socket.h>
#include <sys/un.h>
#include <unistd.h>

#include <atomic>
#include <chrono>
#include <cstring>
#include <future>
#include <limits>
#include <thread>

using namespace railcosim;

namespace {

using test::restingAt;
using test::square;
using test::uniqueEndpoint;

/// A scripted participant speaking raw protocol bytes, to send what a correct participant never would.
struct FakePeer {
  explicit FakePeer(const std::string& endpoint, com::Side side)
      : channel(com::ChannelOptions{endpoint, side, 1.0, 1000, 0.1}) {}
  void send(std::vector<std::uint8_t> bytes) {
    com::Timing timing;
    BOOST_REQUIRE(channel.send(std::move(bytes), 5.0, timing) == com::Status::Ok);
  }
  protocol::Header receive(com::Frame& frame) {
    com::Timing timing;
    BOOST_REQUIRE(channel.receive(frame, 5.0, timing) == com::Status::Ok);
    return protocol::decodeHeader(frame.data(), frame.size());
  }
  void sendHello(protocol::Role role, const std::string& name, std::uint16_t version = protocol::protocolVersion) {
    protocol::Hello hello;
    hello.role = role;
    hello.participantName = name;
    send(protocol::encodeHello(hello, version));
  }
  /// Expects an Abort from the participant and returns its reason.
  std::string receiveAbort() {
    com::Frame frame;
    const protocol::Header header = receive(frame);
    BOOST_REQUIRE(header.type == protocol::MessageType::Abort);
    return protocol::decodeAbort(header, frame.data());
  }
  com::Channel channel;
};

template <class Exception, class Future>
std::string expectThrows(Future& future) {
  try {
    future.get();
  } catch (const Exception& error) {
    return error.what();
  }
  BOOST_FAIL("expected exception not thrown");
  return {};
}

bool contains(const std::string& text, const std::string& fragment) {
  const bool found = text.find(fragment) != std::string::npos;
  if (!found) BOOST_TEST_MESSAGE("'" << fragment << "' not in: " << text);
  return found;
}

/// Runs the FEM side's handshake against a fake DEM peer; returns once the mesh was received.
void handshakeAsFakeDem(FakePeer& dem) {
  dem.sendHello(protocol::Role::Dem, "fake-dem");
  com::Frame hello, mesh;
  BOOST_REQUIRE(dem.receive(hello).type == protocol::MessageType::Hello);
  BOOST_REQUIRE(dem.receive(mesh).type == protocol::MessageType::InterfaceMesh);
}

/// A FEM participant (square interface) past its handshake with a scripted DEM peer.
struct FemAfterHandshake {
  std::string endpoint = uniqueEndpoint();
  FemParticipant participant{ParticipantConfig{"fem", endpoint, 10.0, 1.0}};
  FakePeer dem{endpoint, com::Side::Connect};
  FemAfterHandshake() {
    auto init =
        std::async(std::launch::async, [&] { participant.initialize(square(), 1e-4, restingAt(square(), 0.0)); });
    handshakeAsFakeDem(dem);
    init.get();
  }
};

} // namespace

BOOST_AUTO_TEST_CASE(just_in_time_run_transfers_data_unchanged) {
  const std::string endpoint = uniqueEndpoint();
  const InterfaceMesh mesh = square();
  const int windows = 25;
  auto fem = std::async(std::launch::async, [&] {
    FemParticipant participant(ParticipantConfig{"fem", endpoint, 10.0, 1.0});
    participant.initialize(mesh, 1e-4, restingAt(mesh, 0.0));
    std::uint64_t window = 0;
    // Answers with positions that encode the received forces, so the DEM can check both directions.
    while (auto forces = participant.receiveForces()) {
      BOOST_TEST(forces->window == window);
      NodalKinematics answer = restingAt(mesh, forces->time);
      for (std::size_t i = 0; i < answer.positions.size(); ++i) answer.positions[i] += 2.0 * forces->forces[i];
      participant.sendKinematics(window++, answer);
    }
    BOOST_TEST(window == static_cast<std::uint64_t>(windows));
    BOOST_TEST(participant.statistics().exchanges == 2u * windows);
    return window;
  });
  DemParticipant dem(ParticipantConfig{"dem", endpoint, 10.0, 1.0});
  const InterfaceSetup setup = dem.initialize();
  BOOST_TEST(setup.peerName == "fem");
  BOOST_TEST(setup.femTimeStep == 1e-4);
  BOOST_TEST(setup.mesh.coordinates == mesh.coordinates);
  BOOST_TEST(setup.mesh.triangles == mesh.triangles);
  for (int window = 0; window < windows; ++window) {
    ForceMessage forces;
    forces.window = static_cast<std::uint64_t>(window);
    forces.time = (window + 1) * 1e-4;
    for (int i = 0; i < 12; ++i) forces.forces.push_back(0.001 * window - 0.01 * i);
    dem.sendForces(forces);
    const NodalKinematics answer = dem.receiveKinematics(forces.window);
    BOOST_TEST(answer.time == forces.time);
    for (std::size_t i = 0; i < 12; ++i)
      BOOST_TEST(answer.positions[i] == mesh.coordinates[i] + 2.0 * forces.forces[i]);
  }
  const BridgeStatistics& statistics = dem.statistics();
  BOOST_TEST(statistics.exchanges == 2u * windows);
  BOOST_TEST(statistics.bytes > 0u);
  BOOST_TEST(statistics.bridgeSeconds() > 0.0);
  dem.finalize();
  BOOST_TEST(fem.get() == static_cast<std::uint64_t>(windows));
}

BOOST_AUTO_TEST_CASE(predictive_order_runs_and_ends_cleanly) {
  // FEM sends kinematics of window i before it reads the forces of window i; it is one window ahead
  // when the DEM finalizes, which must still end normally on both sides.
  const std::string endpoint = uniqueEndpoint();
  const InterfaceMesh mesh = square();
  auto fem = std::async(std::launch::async, [&] {
    FemParticipant participant(ParticipantConfig{"fem", endpoint, 10.0, 1.0});
    participant.initialize(mesh, 1e-4, restingAt(mesh, 0.0));
    std::uint64_t window = 0;
    while (true) {
      participant.sendKinematics(window, restingAt(mesh, (window + 1) * 1e-4));
      if (!participant.receiveForces()) break;
      ++window;
    }
    return window;
  });
  DemParticipant dem(ParticipantConfig{"dem", endpoint, 10.0, 1.0});
  dem.initialize();
  for (std::uint64_t window = 0; window < 10; ++window) {
    const NodalKinematics atEnd = dem.receiveKinematics(window);
    BOOST_TEST(atEnd.time == (window + 1) * 1e-4);
    ForceMessage forces;
    forces.window = window;
    forces.forces.assign(12, 1.0);
    dem.sendForces(forces);
  }
  dem.finalize();
  BOOST_TEST(fem.get() == 10u);
}

BOOST_AUTO_TEST_CASE(dem_learns_that_the_fem_finalized_early) {
  const std::string endpoint = uniqueEndpoint();
  const InterfaceMesh mesh = square();
  auto fem = std::async(std::launch::async, [&] {
    FemParticipant participant(ParticipantConfig{"fem", endpoint, 10.0, 1.0});
    participant.initialize(mesh, 1e-4, restingAt(mesh, 0.0));
    participant.receiveForces();
    participant.sendKinematics(0, restingAt(mesh, 1e-4));
    participant.finalize();
  });
  DemParticipant dem(ParticipantConfig{"dem", endpoint, 10.0, 1.0});
  dem.initialize();
  ForceMessage forces;
  forces.forces.assign(12, 0.0);
  dem.sendForces(forces);
  dem.receiveKinematics(0);
  fem.get();
  forces.window = 1;
  dem.sendForces(forces); // the FEM side may already be gone: not an error by itself
  auto next = std::async(std::launch::async, [&] { dem.receiveKinematics(1); });
  const std::string message = expectThrows<PeerLostError>(next);
  BOOST_TEST(contains(message, "finalized"));
  BOOST_TEST(contains(message, "kinematics of window 1"));
  BOOST_TEST(contains(message, "'fem'"));
}

BOOST_AUTO_TEST_CASE(fem_rejects_hello_of_another_protocol_version) {
  const std::string endpoint = uniqueEndpoint();
  auto fem = std::async(std::launch::async, [&] {
    FemParticipant participant(ParticipantConfig{"fem", endpoint, 10.0, 1.0});
    participant.initialize(square(), 1e-4, restingAt(square(), 0.0));
  });
  FakePeer dem(endpoint, com::Side::Connect);
  dem.sendHello(protocol::Role::Dem, "old-dem", 1);
  const std::string message = expectThrows<ProtocolError>(fem);
  BOOST_TEST(contains(message, "version 1"));
  BOOST_TEST(contains(message, "version " + std::to_string(protocol::protocolVersion)));
  BOOST_TEST(contains(message, "fem"));
  // The peer is told why, so its own log says the same.
  BOOST_TEST(contains(dem.receiveAbort(), "version 1"));
}

BOOST_AUTO_TEST_CASE(dem_rejects_hello_of_another_protocol_version) {
  const std::string endpoint = uniqueEndpoint();
  FakePeer fem(endpoint, com::Side::Bind);
  auto dem = std::async(std::launch::async, [&] {
    DemParticipant participant(ParticipantConfig{"dem", endpoint, 10.0, 1.0});
    participant.initialize();
  });
  com::Frame hello;
  BOOST_REQUIRE(fem.receive(hello).type == protocol::MessageType::Hello);
  const auto newer = static_cast<std::uint16_t>(protocol::protocolVersion + 1);
  fem.sendHello(protocol::Role::Fem, "new-fem", newer);
  const std::string message = expectThrows<ProtocolError>(dem);
  BOOST_TEST(contains(message, "version " + std::to_string(newer)));
  BOOST_TEST(contains(message, "version " + std::to_string(protocol::protocolVersion)));
}

BOOST_AUTO_TEST_CASE(two_fem_participants_cannot_couple) {
  const std::string endpoint = uniqueEndpoint();
  auto fem = std::async(std::launch::async, [&] {
    FemParticipant participant(ParticipantConfig{"fem", endpoint, 10.0, 1.0});
    participant.initialize(square(), 1e-4, restingAt(square(), 0.0));
  });
  FakePeer other(endpoint, com::Side::Connect);
  other.sendHello(protocol::Role::Fem, "second-fem");
  const std::string message = expectThrows<ProtocolError>(fem);
  BOOST_TEST(contains(message, "two FEM"));
  BOOST_TEST(contains(message, "second-fem"));
}

BOOST_AUTO_TEST_CASE(participants_with_the_same_name_are_rejected) {
  const std::string endpoint = uniqueEndpoint();
  auto fem = std::async(std::launch::async, [&] {
    FemParticipant participant(ParticipantConfig{"solver", endpoint, 10.0, 1.0});
    participant.initialize(square(), 1e-4, restingAt(square(), 0.0));
  });
  FakePeer dem(endpoint, com::Side::Connect);
  dem.sendHello(protocol::Role::Dem, "solver");
  BOOST_TEST(contains(expectThrows<ProtocolError>(fem), "distinct names"));
}

BOOST_AUTO_TEST_CASE(unexpected_message_type_names_what_was_expected) {
  FemAfterHandshake run;
  FemParticipant& participant = run.participant;
  FakePeer& dem = run.dem;
  dem.send(protocol::encodeKinematics(0, restingAt(square(), 0.0)));
  auto receive = std::async(std::launch::async, [&] { participant.receiveForces(); });
  const std::string message = expectThrows<ProtocolError>(receive);
  BOOST_TEST(contains(message, "expected Forces for window 0, got Kinematics for window 0"));
  BOOST_TEST(contains(dem.receiveAbort(), "expected Forces"));
}

BOOST_AUTO_TEST_CASE(window_out_of_sequence_is_rejected) {
  FemAfterHandshake run;
  FemParticipant& participant = run.participant;
  FakePeer& dem = run.dem;
  ForceMessage forces;
  forces.window = 1;
  forces.forces.assign(12, 0.0);
  dem.send(protocol::encodeForces(forces));
  auto receive = std::async(std::launch::async, [&] { participant.receiveForces(); });
  BOOST_TEST(contains(expectThrows<ProtocolError>(receive), "expected Forces for window 0, got Forces for window 1"));
}

BOOST_AUTO_TEST_CASE(forces_for_another_mesh_size_are_rejected) {
  FemAfterHandshake run;
  FemParticipant& participant = run.participant;
  FakePeer& dem = run.dem;
  ForceMessage forces;
  forces.forces.assign(9, 0.0); // 3 nodes instead of 4
  dem.send(protocol::encodeForces(forces));
  auto receive = std::async(std::launch::async, [&] { participant.receiveForces(); });
  const std::string message = expectThrows<ProtocolError>(receive);
  BOOST_TEST(contains(message, "nodeCount"));
  BOOST_TEST(contains(message, "4 nodes"));
}

BOOST_AUTO_TEST_CASE(abort_from_the_peer_is_quoted) {
  FemAfterHandshake run;
  FemParticipant& participant = run.participant;
  FakePeer& dem = run.dem;
  dem.send(protocol::encodeAbort(0, "fake-dem: contact detection ran out of memory"));
  auto receive = std::async(std::launch::async, [&] { participant.receiveForces(); });
  const std::string message = expectThrows<PeerLostError>(receive);
  BOOST_TEST(contains(message, "contact detection ran out of memory"));
  BOOST_TEST(contains(message, "forces of window 0"));
}

BOOST_AUTO_TEST_CASE(silent_peer_times_out_with_advice) {
  const std::string endpoint = uniqueEndpoint();
  FemParticipant participant(ParticipantConfig{"fem", endpoint, 0.5, 1.0});
  const auto start = std::chrono::steady_clock::now();
  auto init = std::async(std::launch::async, [&] { participant.initialize(square(), 1e-4, restingAt(square(), 0.0)); });
  const std::string message = expectThrows<PeerLostError>(init);
  const double waited = std::chrono::duration<double>(std::chrono::steady_clock::now() - start).count();
  BOOST_TEST(contains(message, "0.5 s"));
  BOOST_TEST(contains(message, "timeoutSeconds"));
  BOOST_TEST(contains(message, "no DEM participant ever connected"));
  BOOST_TEST(contains(message, endpoint));
  // The deadline is kept to within one poll slice (0.1 s) plus scheduling; 2 s is a generous bound.
  BOOST_TEST(waited >= 0.5);
  BOOST_TEST(waited < 2.0);
}

BOOST_AUTO_TEST_CASE(a_peer_that_binds_late_is_not_taken_for_a_frozen_one) {
  // The connecting side waits before the binding side exists (a FEM solver still assembling): silence counts
  // from the connection's handshake, not from the start of the wait, so a peer that binds after more than
  // three keepalive intervals and then speaks at once is heard.
  const std::string endpoint = uniqueEndpoint();
  com::Channel waiting(com::ChannelOptions{endpoint, com::Side::Connect, 0.2, 1000, 0.05});
  auto received = std::async(std::launch::async, [&] {
    com::Frame frame;
    com::Timing timing;
    return waiting.receive(frame, 5.0, timing);
  });
  std::this_thread::sleep_for(std::chrono::milliseconds(1000)); // 5 keepalive intervals of silence
  FakePeer late(endpoint, com::Side::Bind);
  late.sendHello(protocol::Role::Fem, "late-fem");
  BOOST_TEST(static_cast<int>(received.get()) == static_cast<int>(com::Status::Ok));
}

BOOST_AUTO_TEST_CASE(non_finite_values_are_refused_before_sending) {
  const std::string endpoint = uniqueEndpoint();
  const InterfaceMesh mesh = square();
  auto fem = std::async(std::launch::async, [&] {
    FemParticipant participant(ParticipantConfig{"fem", endpoint, 10.0, 1.0});
    participant.initialize(mesh, 1e-4, restingAt(mesh, 0.0));
    const auto forces = participant.receiveForces();
    BOOST_TEST(forces->forces == std::vector<double>(12, 2.0)); // the good message after the refused one
    NodalKinematics bad = restingAt(mesh, 1e-4);
    bad.velocities[5] = std::numeric_limits<double>::infinity();
    try {
      participant.sendKinematics(0, bad);
      BOOST_ERROR("infinite velocity was sent");
    } catch (const Error& error) {
      BOOST_TEST(contains(error.what(), "'velocities'[5]"));
      BOOST_TEST(contains(error.what(), "fem"));
    }
    participant.sendKinematics(0, restingAt(mesh, 1e-4));
    BOOST_TEST(!participant.receiveForces().has_value());
  });
  DemParticipant dem(ParticipantConfig{"dem", endpoint, 10.0, 1.0});
  dem.initialize();
  ForceMessage forces;
  forces.forces.assign(12, 2.0);
  forces.forces[4] = std::numeric_limits<double>::quiet_NaN();
  try {
    dem.sendForces(forces);
    BOOST_ERROR("NaN force was sent");
  } catch (const Error& error) {
    BOOST_TEST(contains(error.what(), "'forces'[4]"));
    BOOST_TEST(contains(error.what(), "node 1"));
  }
  forces.forces[4] = 2.0;
  dem.sendForces(forces);
  dem.receiveKinematics(0);
  dem.finalize();
  fem.get();
}

BOOST_AUTO_TEST_CASE(coupling_scheme_is_agreed_at_the_handshake) {
  // Mismatch: refused on the FEM side (which reads the DEM's Hello first), reported to the DEM.
  {
    const std::string endpoint = uniqueEndpoint();
    auto fem = std::async(std::launch::async, [&] {
      FemParticipant participant(ParticipantConfig{"fem", endpoint, 10.0, 1.0, "predictive"});
      participant.initialize(square(), 1e-4, restingAt(square(), 0.0));
    });
    auto dem = std::async(std::launch::async, [&] {
      DemParticipant participant(ParticipantConfig{"dem", endpoint, 10.0, 1.0, "just-in-time"});
      participant.initialize();
    });
    const std::string femMessage = expectThrows<ProtocolError>(fem);
    BOOST_TEST(contains(femMessage, "justInTime"));
    BOOST_TEST(contains(femMessage, "predictive"));
    BOOST_TEST(contains(expectThrows<PeerLostError>(dem), "same couplingScheme"));
  }
  // A DEM side that names no scheme learns the FEM's.
  {
    const std::string endpoint = uniqueEndpoint();
    auto fem = std::async(std::launch::async, [&] {
      FemParticipant participant(ParticipantConfig{"fem", endpoint, 10.0, 1.0, "Predictive"});
      participant.initialize(square(), 1e-4, restingAt(square(), 0.0));
      participant.receiveForces();
    });
    DemParticipant dem(ParticipantConfig{"dem", endpoint, 10.0, 1.0});
    BOOST_TEST(dem.initialize().couplingScheme == "predictive");
    dem.finalize();
    fem.get();
  }
}

BOOST_AUTO_TEST_CASE(oversized_message_is_dropped_before_it_is_buffered) {
  // 25 MB of "forces" towards a FEM side whose interface has 4 nodes (96 bytes of forces): ZeroMQ drops
  // the connection at the frame header, so the FEM reports a lost peer, never the decoded message (which
  // it would refuse only after buffering all of it: "nodeCount").
  FemAfterHandshake run;
  FemParticipant& participant = run.participant;
  FakePeer& dem = run.dem;
  ForceMessage forces;
  forces.forces.assign(3 * 1'000'000, 0.0);
  dem.send(protocol::encodeForces(forces));
  auto receive = std::async(std::launch::async, [&] { participant.receiveForces(); });
  const std::string message = expectThrows<PeerLostError>(receive);
  BOOST_TEST(contains(message, "disconnected"));
  BOOST_TEST(contains(message, "larger than the protocol allows"));
}

BOOST_AUTO_TEST_CASE(peer_gone_before_its_first_frame_was_read_is_reported) {
  // The DEM sends its Hello and dies before the FEM side reads it: the disconnection reaches the monitor
  // before the connection is known as the peer's. The Hello is still delivered (last words first), then
  // the loss is reported at once, not after the 5 s send timeout.
  const std::string endpoint = uniqueEndpoint();
  com::Channel fem(com::ChannelOptions{endpoint, com::Side::Bind, 1.0, 1000, 0.1});
  {
    FakePeer dem(endpoint, com::Side::Connect);
    dem.sendHello(protocol::Role::Dem, "short-lived");
    std::this_thread::sleep_for(std::chrono::milliseconds(300));
  }
  std::this_thread::sleep_for(std::chrono::milliseconds(300));
  com::Frame frame;
  com::Timing timing;
  BOOST_TEST((fem.receive(frame, 5.0, timing) == com::Status::Ok));
  const auto start = std::chrono::steady_clock::now();
  BOOST_TEST((fem.send(std::vector<std::uint8_t>(64, 0), 5.0, timing) == com::Status::PeerDisconnected));
  BOOST_TEST(std::chrono::duration<double>(std::chrono::steady_clock::now() - start).count() < 1.0);
}

BOOST_AUTO_TEST_CASE(stray_connections_while_the_owner_computes_stall_nothing) {
  // 1500 stray connect-and-close pairs while the owner makes no channel call: 4500 monitor events, more
  // than libzmq's inproc queue holds (about 2000), which would block its I/O thread (no data, no
  // keepalives) and close(). The keepalive thread reads them; a message then arrives and close() returns.
  const std::string endpoint = uniqueEndpoint();
  com::Channel fem(com::ChannelOptions{endpoint, com::Side::Bind, 0.2, 1000, 0.1});
  const std::string path = endpoint.substr(std::string("ipc://").size());
  for (int i = 0; i < 1500; ++i) {
    const int fd = ::socket(AF_UNIX, SOCK_STREAM, 0);
    sockaddr_un address{};
    address.sun_family = AF_UNIX;
    std::strncpy(address.sun_path, path.c_str(), sizeof(address.sun_path) - 1);
    BOOST_REQUIRE(::connect(fd, reinterpret_cast<sockaddr*>(&address), sizeof(address)) == 0);
    ::close(fd);
  }
  FakePeer dem(endpoint, com::Side::Connect);
  dem.sendHello(protocol::Role::Dem, "late");
  com::Frame frame;
  com::Timing timing;
  BOOST_TEST((fem.receive(frame, 10.0, timing) == com::Status::Ok));
  const auto start = std::chrono::steady_clock::now();
  fem.close();
  BOOST_TEST(std::chrono::duration<double>(std::chrono::steady_clock::now() - start).count() < 3.0);
}
