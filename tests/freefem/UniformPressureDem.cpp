// DEM stand-in for the FreeFEM round-trip test: applies a uniform pressure to the received surface.
//
// It receives the FEM interface mesh over the bridge, checks it (valid, all triangles facing
// --normal, total area --area), lumps a uniform pressure to the nodes with the bridge's own
// barycentric lumping (a triangle's force at its centroid gives 1/3 to each vertex), sends these
// forces every window and checks the returned kinematics (time stamps, node count, finite values,
// velocities consistent with the positions). The FEM displacement itself is judged by the test
// script against the FEM's direct run: this program only guarantees what went over the wire.
//
// Usage: railcosim_test_pressure_dem --endpoint E --pressure P --windows W
//            [--scheme justInTime|predictive] [--area A] [--normal x,y,z] [--timeout S]
//            [--trapezoid 1]   (FEM runs average-acceleration Newmark: check (p1-p0)/dt = (v0+v1)/2)
// Exit status 0 = all checks passed, 1 = a check failed or an error occurred.

#include "DummyCommon.hpp"
#include "railcosim/Error.hpp"
#include "railcosim/ForceLumping.hpp"
#include "railcosim/InterfaceMesh.hpp"
#include "railcosim/Participant.hpp"
#include "railcosim/CouplingScheme.hpp"

#include <array>
#include <cmath>
#include <cstdio>
#include <cstdlib>
#include <map>
#include <sstream>
#include <stdexcept>
#include <string>
#include <vector>

using namespace railcosim;

namespace {

const char* usage =
    "railcosim_test_pressure_dem --endpoint E --pressure P --windows W [--scheme justInTime|predictive|implicit]\n"
    "    [--area A] [--normal x,y,z] [--timeout S] [--trapezoid 1]";

std::array<double, 3> parseVector(const std::string& text) {
  std::array<double, 3> value{};
  std::stringstream stream(text);
  std::string item;
  for (double& component : value) {
    if (!std::getline(stream, item, ',')) throw std::runtime_error("--normal needs x,y,z, got " + text);
    component = std::stod(item);
  }
  return value;
}

int failures = 0;
void expect(bool condition, const std::string& what) {
  if (!condition) {
    ++failures;
    std::fprintf(stderr, "railcosim_test_pressure_dem: CHECK FAILED: %s\n", what.c_str());
  }
}

} // namespace

int main(int argc, char** argv) {
  try {
    const dummy::Options options(argc, argv,
                                 {{"endpoint", ""},
                                  {"pressure", "0"},
                                  {"windows", "10"},
                                  {"scheme", "justInTime"},
                                  {"area", "-1"},
                                  {"normal", "0,0,1"},
                                  {"timeout", "60"},
                                  {"trapezoid", "0"}},
                                 usage);
    if (options.text("endpoint").empty()) throw std::runtime_error("--endpoint is required");
    const double pressure = options.number("pressure");
    const long windows = options.integer("windows");
    const double expectedArea = options.number("area");
    const std::array<double, 3> expectedNormal = parseVector(options.text("normal"));
    const CouplingScheme scheme = parseCouplingScheme(options.text("scheme"));

    ParticipantConfig config;
    config.name = "pressure-dem";
    config.endpoint = options.text("endpoint");
    config.timeoutSeconds = options.number("timeout");
    config.couplingScheme = toString(scheme);
    DemParticipant participant(config);
    const InterfaceSetup setup = participant.initialize();
    const InterfaceMesh& mesh = setup.mesh;
    mesh.validate();
    const std::size_t nodes = mesh.nodeCount();
    const double dt = setup.femTimeStep;
    expect(dt > 0.0, "the window length is positive");
    expect(setup.initial.nodeCount() == nodes, "initial kinematics has one entry per node");

    // Orientation and area: every triangle's right-hand normal must point along expectedNormal.
    std::vector<double> forces(3 * nodes, 0.0);
    double totalArea = 0.0;
    std::size_t misoriented = 0;
    for (std::size_t t = 0; t < mesh.triangleCount(); ++t) {
      const auto a = mesh.node(mesh.triangles[3 * t]);
      const auto b = mesh.node(mesh.triangles[3 * t + 1]);
      const auto c = mesh.node(mesh.triangles[3 * t + 2]);
      const std::array<double, 3> ab = {b[0] - a[0], b[1] - a[1], b[2] - a[2]};
      const std::array<double, 3> ac = {c[0] - a[0], c[1] - a[1], c[2] - a[2]};
      const std::array<double, 3> normal = {ab[1] * ac[2] - ab[2] * ac[1], ab[2] * ac[0] - ab[0] * ac[2],
                                            ab[0] * ac[1] - ab[1] * ac[0]};
      const double twiceArea = std::sqrt(normal[0] * normal[0] + normal[1] * normal[1] + normal[2] * normal[2]);
      const double alignment =
          (normal[0] * expectedNormal[0] + normal[1] * expectedNormal[1] + normal[2] * expectedNormal[2]) / twiceArea;
      if (alignment < 1.0 - 1e-9) ++misoriented; // a flat box face: every normal is the face normal
      const double area = 0.5 * twiceArea;
      totalArea += area;
      // Pressure pushes against the outward normal: force = -p * area * n_unit, at the centroid.
      const std::array<double, 3> centroid = {(a[0] + b[0] + c[0]) / 3.0, (a[1] + b[1] + c[1]) / 3.0,
                                              (a[2] + b[2] + c[2]) / 3.0};
      const std::array<double, 3> force = {-pressure * area * normal[0] / twiceArea,
                                           -pressure * area * normal[1] / twiceArea,
                                           -pressure * area * normal[2] / twiceArea};
      lumpPointForce(mesh.coordinates, mesh.triangles, t, centroid, force, forces);
    }
    expect(misoriented == 0,
           std::to_string(misoriented) + " triangles do not face --normal (counter-clockwise from outside)");
    if (expectedArea > 0.0)
      expect(std::abs(totalArea - expectedArea) <= 1e-12 * expectedArea,
             "interface area " + std::to_string(totalArea) + " m^2 equals --area " + std::to_string(expectedArea));

    ForceMessage message;
    message.forces = forces;
    NodalKinematics previous = setup.initial;
    double worstVelocityMismatch = 0.0;
    for (long window = 0; window < windows; ++window) {
      message.window = static_cast<std::uint64_t>(window);
      message.time = static_cast<double>(window + 1) * dt;
      NodalKinematics received;
      if (scheme == CouplingScheme::JustInTime) {
        participant.sendForces(message);
        received = participant.receiveKinematics(message.window);
      } else if (scheme == CouplingScheme::Implicit) {
        // Two passes per window: a decoy (3x the load) the FEM must forget, then the real load; the FEM
        // re-solves the window from its saved start, so the accepted run equals the just-in-time one.
        ForceMessage decoy = message;
        for (double& f : decoy.forces) f *= 3.0;
        decoy.iteration = 0;
        participant.sendForces(decoy);
        participant.receiveKinematics(message.window);
        message.iteration = 1;
        participant.sendForces(message);
        received = participant.receiveKinematics(message.window);
        message.iteration = 0;
      } else {
        received = participant.receiveKinematics(message.window);
        participant.sendForces(message);
      }
      received.validate(nodes);
      expect(std::abs(received.time - static_cast<double>(window + 1) * dt) <= 1e-9 * dt,
             "kinematics of window " + std::to_string(window) + " refer to t_i+1");
      // Average-acceleration Newmark (beta = 1/4, gamma = 1/2) gives (u1 - u0)/dt = (v0 + v1)/2 exactly:
      // a check that positions and velocities are sent from the same, consistent state.
      for (std::size_t k = 0; k < 3 * nodes; ++k) {
        const double finiteDifference = (received.positions[k] - previous.positions[k]) / dt;
        const double meanVelocity = 0.5 * (received.velocities[k] + previous.velocities[k]);
        worstVelocityMismatch = std::max(worstVelocityMismatch, std::abs(finiteDifference - meanVelocity));
      }
      previous = received;
    }
    participant.finalize();

    double velocityScale = 0.0;
    for (double v : previous.velocities) velocityScale = std::max(velocityScale, std::abs(v));
    // With beta = 1/4, gamma = 1/2 the relation is exact; what remains is the round-off of
    // differencing positions of order 1 m: ~1e-16 m / dt, far below 1e-6 of the velocities.
    if (options.integer("trapezoid") == 1)
      expect(worstVelocityMismatch <= 1e-6 * velocityScale + 1e-14 / dt,
             "sent velocities match the trapezoid rule (p1-p0)/dt = (v0+v1)/2 (mismatch " +
                 std::to_string(worstVelocityMismatch) + " m/s)");
    std::printf(
        "railcosim_test_pressure_dem: %zu nodes, %zu triangles, area %.9g m^2, total force %.9g N, %ld windows, "
        "max |(p1-p0)/dt - (v0+v1)/2| = %.3e m/s\n",
        nodes, mesh.triangleCount(), totalArea, -pressure * totalArea, windows, worstVelocityMismatch);
    std::printf("railcosim_test_pressure_dem: %s\n", failures == 0 ? "OK" : "FAILED");
    return failures == 0 ? 0 : 1;
  } catch (const std::exception& error) {
    std::fprintf(stderr, "railcosim_test_pressure_dem: ERROR: %s\n", error.what());
    return 1;
  }
}
