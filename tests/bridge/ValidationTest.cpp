// Input validation (mesh, kinematics, participant configuration) and the logging facility.
#define BOOST_TEST_MODULE bridge_validation
#include <boost/test/unit_test.hpp>

#include "railcosim/Error.hpp"
#include "railcosim/InterfaceMesh.hpp"
#include "railcosim/Log.hpp"
#include "railcosim/Participant.hpp"

#include <cmath>
#include <cstdlib>
#include <limits>
#include <vector>

using namespace railcosim;

namespace {

template <class Call>
void expectError(Call call, std::initializer_list<const char*> fragments) {
  try {
    call();
  } catch (const Error& error) {
    const std::string message = error.what();
    for (const char* fragment : fragments) {
      BOOST_TEST_INFO("message: " << message);
      BOOST_TEST(message.find(fragment) != std::string::npos, "missing '" << fragment << "'");
    }
    return;
  }
  BOOST_FAIL("no Error thrown");
}

InterfaceMesh square() {
  InterfaceMesh mesh;
  mesh.coordinates = {0, 0, 0, 1, 0, 0, 1, 1, 0, 0, 1, 0};
  mesh.triangles = {0, 1, 2, 0, 2, 3};
  return mesh;
}

} // namespace

// Runs first, before anything else in this process touched the logger, so the variable is read.
BOOST_AUTO_TEST_CASE(log_level_comes_from_the_environment) {
  setenv("RAILCOSIM_LOG", "debug", 1);
  BOOST_TEST((logLevel() == LogLevel::Debug));
}

BOOST_AUTO_TEST_CASE(log_sink_receives_messages_at_or_above_the_level) {
  std::vector<std::pair<LogLevel, std::string>> received;
  setLogSink([&](LogLevel level, const std::string& message) { received.emplace_back(level, message); });
  setLogLevel(LogLevel::Warning);
  log(LogLevel::Error, "e");
  log(LogLevel::Warning, "w");
  log(LogLevel::Info, "i");
  log(LogLevel::Debug, "d");
  setLogSink(nullptr);
  BOOST_TEST(received.size() == 2u);
  BOOST_TEST(received[0].second == "e");
  BOOST_TEST(received[1].second == "w");
}

BOOST_AUTO_TEST_CASE(valid_mesh_passes) { BOOST_CHECK_NO_THROW(square().validate()); }

BOOST_AUTO_TEST_CASE(mesh_errors_name_the_problem) {
  InterfaceMesh mesh = square();
  mesh.coordinates.pop_back();
  expectError([&] { mesh.validate(); }, {"coordinates", "multiple of 3"});
  mesh = square();
  mesh.triangles.pop_back();
  expectError([&] { mesh.validate(); }, {"triangles", "multiple of 3"});
  mesh = square();
  mesh.triangles.clear();
  expectError([&] { mesh.validate(); }, {"no triangles"});
  mesh = square();
  mesh.triangles[5] = 4;
  expectError([&] { mesh.validate(); }, {"triangles[5]", "triangle 1", "out of range"});
  mesh = square();
  mesh.triangles[1] = -1;
  expectError([&] { mesh.validate(); }, {"triangles[1]"});
  mesh = square();
  mesh.coordinates[7] = std::numeric_limits<double>::quiet_NaN();
  expectError([&] { mesh.validate(); }, {"coordinates[7]", "node 2", "y"});
  mesh = square();
  mesh.coordinates[6] = 2.0; // node 2 at (2,1,0)? keep collinear instead:
  mesh.coordinates = {0, 0, 0, 1, 0, 0, 2, 0, 0, 0, 1, 0};
  mesh.triangles = {0, 1, 3, 0, 1, 2};
  expectError([&] { mesh.validate(); }, {"triangle 1", "degenerate"});
}

BOOST_AUTO_TEST_CASE(degenerate_test_is_scale_free) {
  // A well-shaped triangle of micrometre size must pass, whatever the unit of length.
  InterfaceMesh mesh;
  mesh.coordinates = {0, 0, 0, 1e-6, 0, 0, 0, 1e-6, 0};
  mesh.triangles = {0, 1, 2};
  BOOST_CHECK_NO_THROW(mesh.validate());
}

BOOST_AUTO_TEST_CASE(kinematics_errors_name_the_problem) {
  NodalKinematics kinematics;
  kinematics.positions.assign(12, 0.0);
  BOOST_CHECK_NO_THROW(kinematics.validate(4));
  expectError([&] { kinematics.validate(5); }, {"positions", "12", "5 nodes"});
  kinematics.velocities.assign(9, 0.0);
  expectError([&] { kinematics.validate(4); }, {"velocities"});
  kinematics.velocities.assign(12, 0.0);
  kinematics.accelerations.assign(12, 0.0);
  kinematics.accelerations[11] = std::numeric_limits<double>::infinity();
  expectError([&] { kinematics.validate(4); }, {"accelerations[11]", "node 3", "z"});
  kinematics.accelerations[11] = 0.0;
  kinematics.time = std::nan("");
  expectError([&] { kinematics.validate(4); }, {"time"});
}

BOOST_AUTO_TEST_CASE(configuration_errors_are_reported_before_any_socket_opens) {
  expectError([] { FemParticipant participant(ParticipantConfig{"", "ipc:///tmp/x.sock", 10, 1}); }, {"name"});
  expectError(
      [] {
        FemParticipant participant(ParticipantConfig{"fem", "/tmp/x.sock", 10, 1});
      },
      {"fem", "endpoint", "/tmp/x.sock"});
  expectError([] { DemParticipant participant(ParticipantConfig{"dem", "tcp://", 10, 1}); }, {"endpoint"});
  expectError(
      [] {
        DemParticipant participant(ParticipantConfig{"dem", "tcp://127.0.0.1:5000", 0, 1});
      },
      {"timeoutSeconds"});
  expectError(
      [] {
        DemParticipant participant(ParticipantConfig{"dem", "tcp://127.0.0.1:5000", 10, -1});
      },
      {"heartbeatSeconds"});
  expectError(
      [] {
        DemParticipant participant(ParticipantConfig{"dem", "tcp://127.0.0.1:5000", 10, 1, "monolithic"});
      },
      {"couplingScheme", "monolithic"});
}

BOOST_AUTO_TEST_CASE(calls_out_of_order_are_errors) {
  DemParticipant dem(ParticipantConfig{"dem", "ipc:///tmp/railcosim-unused.sock", 10, 1});
  ForceMessage forces;
  expectError([&] { dem.sendForces(forces); }, {"dem", "before initialize"});
  expectError([&] { dem.receiveKinematics(0); }, {"before initialize"});
  FemParticipant fem(ParticipantConfig{"fem", "ipc:///tmp/railcosim-unused.sock", 10, 1});
  expectError([&] { fem.receiveForces(); }, {"fem", "before initialize"});
  InterfaceMesh badMesh = square();
  badMesh.triangles[0] = 9;
  NodalKinematics initial;
  initial.positions.assign(12, 0.0);
  expectError([&] { fem.initialize(badMesh, 1e-4, initial); }, {"fem", "initialize", "out of range"});
  expectError([&] { fem.initialize(square(), -1.0, initial); }, {"femTimeStep"});
  BOOST_CHECK_NO_THROW(fem.finalize());
  BOOST_CHECK_NO_THROW(dem.finalize());
}
