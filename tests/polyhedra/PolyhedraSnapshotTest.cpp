// Unit tests of the polyhedra state snapshots (saveSnapshot/restoreSnapshot, writeState/readState) and of per-triangle
// wall materials, on the CPU reference.
#define BOOST_TEST_MODULE PolyhedraSnapshot
#include <boost/test/unit_test.hpp>

#include <chrono>
#include <cmath>
#include <map>
#include <sstream>
#include <string>
#include <tuple>
#include <vector>

#include "kernels/HertzMindlin.hpp"
#include "polyhedra/PolyhedraShapes.hpp"
#include "polyhedra/PolyhedraSystem.hpp"
#include "railcosim/Error.hpp"
#include "railcosim/StateStream.hpp"

using namespace railcosim::polyhedra;

namespace {

// A bed whose state has every kind of history: 27 angular stones of two shapes dropped into a box whose floor is a
// moving surface; stones rough and elasto-plastic (Pohrt–Popov, so that pair and wall slots keep F_max and δ_p beside
// the tangential springs), the side walls a second, smooth and frictionless wall material. 27 stones stay below the
// CPU reference's OpenMP threshold (512): its loops run in one thread, so a run is repeatable bit for bit.
Parameters bedParameters() {
  Parameters p;
  p.timeStep = 1e-5;
  p.gravity = {0.0, 0.0, -9.81};
  p.stone = Material{1e8, 0.25, 0.3, 0.6, 2.61e-5, 2.13, true};
  p.wall = p.stone;
  p.backend = Backend::Cpu;
  return p;
}

constexpr double box = 0.09; // m, side of the box's square floor

// Floor: nodes 0–3 at z = 0 (triangles 0, 1); side walls of height 0.12 m (triangles 2–9).
void addBox(PolyhedraSystem& system) {
  std::vector<double> nodes = {0, 0, 0, box, 0, 0, box, box, 0, 0, box, 0};
  for (int k = 0; k < 4; ++k)
    for (int c = 0; c < 3; ++c) nodes.push_back(c == 2 ? 0.12 : nodes[3 * k + c]);
  std::vector<std::int32_t> triangles = {0, 1, 2, 0, 2, 3};
  for (int k = 0; k < 4; ++k) { // counter-clockwise seen from inside
    const int a = k, b = (k + 1) % 4;
    const std::vector<std::int32_t> side = {a, b, b + 4, a, b + 4, a + 4};
    triangles.insert(triangles.end(), side.begin(), side.end());
  }
  system.setWalls(nodes, triangles);
  Material side = bedParameters().stone;
  side.roughnessRms = 0.0;
  side.plasticUnloading = false;
  side.friction = 0.0;
  system.setWallMaterials({bedParameters().stone, side}, {0, 0, 1, 1, 1, 1, 1, 1, 1, 1});
}

// The bed's stones on a 3 × 3 × 3 lattice; `spread` scales the lattice (a fresh system built elsewhere must still
// take the stored state). Orientations vary per stone.
void buildBed(PolyhedraSystem& system, double spread = 1.0) {
  const int a = system.addShape(dodecahedronStone(0.012, 0.010, 0.008, 0.0015, 2600));
  const int b = system.addShape(dodecahedronStone(0.010, 0.011, 0.009, 0.0015, 2600));
  for (int i = 0; i < 3; ++i)
    for (int j = 0; j < 3; ++j)
      for (int k = 0; k < 3; ++k) {
        const double angle = 0.3 * (i + 2 * j + 3 * k);
        system.addStone((i + j + k) % 2 ? a : b,
                        {spread * (0.016 + 0.029 * i), spread * (0.016 + 0.029 * j), spread * (0.016 + 0.029 * k)},
                        {std::cos(angle), 0.3 * std::sin(angle), 0.5 * std::sin(angle), 0.81 * std::sin(angle)});
      }
  addBox(system);
}

// Floor kinematics: nodes 0–3 at height z moving up at speed w; the side nodes at rest.
void moveFloor(PolyhedraSystem& system, double z, double w) {
  std::vector<double> nodes = {0, 0, z, box, 0, z, box, box, z, 0, box, z};
  for (int k = 0; k < 4; ++k)
    for (int c = 0; c < 3; ++c) nodes.push_back(c == 2 ? 0.12 : nodes[3 * k + c]);
  std::vector<double> velocities(nodes.size(), 0.0);
  for (int k = 0; k < 4; ++k) velocities[3 * k + 2] = w;
  system.setSurfaceKinematics(nodes, velocities);
}

std::string stateBytes(const PolyhedraSystem& system) {
  std::ostringstream out;
  system.writeState(out);
  return out.str();
}

// The bed settles for 15000 steps (0.15 s: the stones land and pile up) and then rides one "window" of 500 steps on the
// floor rising at 0.02 m/s from z = 0.
constexpr int settleSteps = 15000, windowSteps = 500;
constexpr double windowSpeed = 0.02;

// What both tests compare: the uninterrupted run's bytes after the window.
std::string uninterruptedRun() {
  PolyhedraSystem system(bedParameters());
  buildBed(system);
  system.step(settleSteps);
  moveFloor(system, 0.0, windowSpeed);
  system.step(windowSteps);
  return stateBytes(system);
}

// Everything the accessors report, for the comparisons that read the state through them.
std::vector<double> observables(const PolyhedraSystem& system) {
  std::vector<double> all;
  for (const auto& part : {system.positions(), system.orientations(), system.velocities(), system.angularVelocities(),
                           system.forces(), system.torques(), system.triangleForces(),
                           system.triangleContactPoints()})
    all.insert(all.end(), part.begin(), part.end());
  all.push_back(system.time());
  all.push_back(system.lastStatistics().meanActiveContacts);
  for (const ContactRecord& c : system.contacts()) {
    all.insert(all.end(), {double(c.first), double(c.second), c.overlap});
    all.insert(all.end(), c.force.begin(), c.force.end());
  }
  return all;
}

} // namespace

// (a) An implicit window: snapshot at the window start, a decoy pass with another surface motion (a rejected
// iteration), restore, the accepted pass. Oracle: the uninterrupted run, bit for bit (the whole written state, every
// array) — a restore that missed any array (a tangential spring, a plastic history, the rebuild reference, the
// predictor's forces) or the clock would differ in some byte. The decoy pass must itself change the state, else the
// comparison could not fail.
BOOST_AUTO_TEST_CASE(restored_snapshot_repeats_the_uninterrupted_run_bit_for_bit) {
  const std::string expected = uninterruptedRun();
  PolyhedraSystem system(bedParameters());
  buildBed(system);
  system.step(settleSteps);
  BOOST_TEST(system.contacts().size() > 27u); // stones on each other and on the walls: histories to restore
  BOOST_TEST(!system.hasSnapshot());
  BOOST_CHECK_THROW(system.restoreSnapshot(), railcosim::Error);
  system.saveSnapshot();
  BOOST_TEST(system.hasSnapshot());
  const std::string atStart = stateBytes(system);
  moveFloor(system, 0.0, -3.0 * windowSpeed); // the decoy: the floor sinks instead
  system.step(windowSteps);
  const std::string decoy = stateBytes(system);
  BOOST_TEST((decoy != expected && decoy != atStart));
  for (int pass = 0; pass < 2; ++pass) { // a snapshot stays kept: a window may be repeated several times
    system.restoreSnapshot();
    BOOST_TEST(stateBytes(system) == atStart);
    moveFloor(system, 0.0, windowSpeed);
    system.step(windowSteps);
    BOOST_TEST(stateBytes(system) == expected);
  }
}

// (b) The state written after settling and read into a fresh system, built the same way but with its stones first
// placed elsewhere (so its own spatial order would differ), continues exactly as the uninterrupted run.
BOOST_AUTO_TEST_CASE(state_read_into_a_fresh_system_continues_the_run_bit_for_bit) {
  const std::string expected = uninterruptedRun();
  PolyhedraSystem writer(bedParameters());
  buildBed(writer);
  writer.step(settleSteps);
  const std::vector<double> written = observables(writer);
  std::stringstream stream;
  writer.writeState(stream);

  PolyhedraSystem reader(bedParameters());
  buildBed(reader, 1.7);
  reader.readState(stream);
  BOOST_TEST(observables(reader) == written, boost::test_tools::per_element());
  moveFloor(reader, 0.0, windowSpeed);
  reader.step(windowSteps);
  BOOST_TEST(stateBytes(reader) == expected);

  // A started system takes a state too (the same order here): back to the settled state and on again.
  std::istringstream again(stream.str());
  reader.readState(again);
  BOOST_TEST(observables(reader) == written, boost::test_tools::per_element());
}

// (c) A restart inside an implicit window (writeRestartState, used by PolyhedraGpuEngine.restartState and the
// standalone driver): the window's snapshot and the current state written as two streams, read into a fresh system
// (snapshot first, kept, then the current state over it, which must not drop it: same storage order). The rejected
// pass is then repeated from the snapshot: oracle the uninterrupted run, bit for bit; and the writer, which read its
// current state back after writing the snapshot, still holds both.
BOOST_AUTO_TEST_CASE(a_restart_inside_an_implicit_window_keeps_the_window_snapshot) {
  const std::string expected = uninterruptedRun();
  PolyhedraSystem writer(bedParameters());
  buildBed(writer);
  writer.step(settleSteps);
  writer.saveSnapshot();
  moveFloor(writer, 0.0, -3.0 * windowSpeed); // a pass that will be rejected
  writer.step(windowSteps);
  const std::string current = stateBytes(writer);
  std::stringstream restart;
  railcosim::StateWriter out(restart);
  writer.writeRestartState(out);
  BOOST_TEST(writer.hasSnapshot());
  BOOST_TEST(stateBytes(writer) == current);

  PolyhedraSystem reader(bedParameters());
  buildBed(reader, 1.7);
  railcosim::StateReader in(restart, "the restart state");
  reader.readRestartState(in);
  BOOST_TEST(reader.hasSnapshot());
  BOOST_TEST(stateBytes(reader) == current);
  for (PolyhedraSystem* system : {&reader, &writer}) {
    system->restoreSnapshot();
    moveFloor(*system, 0.0, windowSpeed);
    system->step(windowSteps);
    BOOST_TEST(stateBytes(*system) == expected);
  }
}

// A stream that does not fit is refused with the reason, and the system keeps its state.
// (d) A few stones read alone (a sensor's state and contacts every few windows): the same values as the whole bed's
// accessors give for them. Oracle: positions() ... contacts() of the whole bed, filtered here.
BOOST_AUTO_TEST_CASE(a_few_stones_read_alone_match_the_whole_bed) {
  PolyhedraSystem system(bedParameters());
  buildBed(system);
  system.step(settleSteps);
  const std::vector<std::int32_t> chosen = {13, 0, 26}; // the centre stone (neighbours on all sides), two corners
  std::vector<double> p, q, v, w;
  system.stoneStates(chosen, p, q, v, w);
  const std::vector<double> allP = system.positions(), allQ = system.orientations(), allV = system.velocities(),
                            allW = system.angularVelocities();
  for (std::size_t k = 0; k < chosen.size(); ++k) {
    const std::size_t i = static_cast<std::size_t>(chosen[k]);
    for (int c = 0; c < 3; ++c) {
      BOOST_TEST(p[3 * k + c] == allP[3 * i + c]);
      BOOST_TEST(v[3 * k + c] == allV[3 * i + c]);
      BOOST_TEST(w[3 * k + c] == allW[3 * i + c]);
    }
    for (int c = 0; c < 4; ++c) BOOST_TEST(q[4 * k + c] == allQ[4 * i + c]);
  }
  auto concerns = [&](const ContactRecord& c) {
    for (std::int32_t i : chosen)
      if (c.first == i || (!c.wall && c.second == i)) return true;
    return false;
  };
  std::map<std::tuple<int, int, bool>, ContactRecord> expected;
  for (const ContactRecord& c : system.contacts())
    if (concerns(c)) expected[{c.first, c.second, c.wall}] = c;
  const std::vector<ContactRecord> selected = system.contacts(chosen);
  BOOST_TEST(expected.size() >= 4u); // the centre stone touches stones, the corners the walls
  BOOST_TEST(selected.size() == expected.size());
  bool wallContact = false;
  for (const ContactRecord& c : selected) {
    const auto found = expected.find({c.first, c.second, c.wall});
    BOOST_TEST_REQUIRE((found != expected.end()));
    wallContact = wallContact || c.wall;
    for (int k = 0; k < 3; ++k) BOOST_TEST(c.force[k] == found->second.force[k]);
  }
  BOOST_TEST(wallContact);
  BOOST_TEST(system.contacts(std::vector<std::int32_t>{}).empty());
  BOOST_CHECK_THROW(system.contacts(std::vector<std::int32_t>{27}), railcosim::Error);
  BOOST_CHECK_THROW(system.stoneStates({-1}, p, q, v, w), railcosim::Error);
}

BOOST_AUTO_TEST_CASE(state_streams_that_do_not_fit_are_refused) {
  PolyhedraSystem writer(bedParameters());
  buildBed(writer);
  writer.step(10);
  const std::string bytes = stateBytes(writer);

  auto refused = [](PolyhedraSystem& system, const std::string& stream, const std::string& needle) {
    const std::vector<double> before = observables(system);
    std::istringstream in(stream);
    try {
      system.readState(in);
      BOOST_ERROR("accepted a stream that should be refused (" << needle << ")");
    } catch (const railcosim::Error& e) {
      BOOST_TEST_MESSAGE("refused: " << e.what());
      BOOST_TEST(std::string(e.what()).find(needle) != std::string::npos, e.what() << " should name " << needle);
    }
    BOOST_TEST(observables(system) == before, boost::test_tools::per_element());
  };

  PolyhedraSystem target(bedParameters());
  buildBed(target);
  target.step(3);
  refused(target, "not a state", "does not start with a polyhedra state");
  std::string wrongVersion = bytes;
  wrongVersion[8] = static_cast<char>(wrongVersion[8] + 1); // the version follows the 8-byte tag
  refused(target, wrongVersion, "format version");
  refused(target, bytes.substr(0, bytes.size() / 2), "stream ends");

  // One stone fewer.
  PolyhedraSystem fewer(bedParameters());
  const int shape = fewer.addShape(dodecahedronStone(0.012, 0.010, 0.008, 0.0015, 2600));
  for (int k = 0; k < 26; ++k) fewer.addStone(shape, {0.01 * k, 0.0, 0.1}, {1, 0, 0, 0});
  refused(fewer, bytes, "stones: 27 in the stream, 26 in this system");

  // The same stones on another wall mesh (the floor split the other way).
  PolyhedraSystem otherWalls(bedParameters());
  buildBed(otherWalls);
  std::vector<double> nodes = {0, 0, 0, box, 0, 0, box, box, 0, 0, box, 0};
  for (int k = 0; k < 4; ++k)
    for (int c = 0; c < 3; ++c) nodes.push_back(c == 2 ? 0.12 : nodes[3 * k + c]);
  std::vector<std::int32_t> triangles = {0, 1, 3, 1, 2, 3};
  for (int k = 0; k < 4; ++k) {
    const int a = k, b = (k + 1) % 4;
    triangles.insert(triangles.end(), {a, b, b + 4, a, b + 4, a + 4});
  }
  otherWalls.setWalls(nodes, triangles);
  refused(otherWalls, bytes, "wall triangles differ");

  // Smaller neighbour lists.
  Parameters small = bedParameters();
  small.maxNeighbours = 12;
  PolyhedraSystem otherLists(small);
  buildBed(otherLists);
  refused(otherLists, bytes, "maxNeighbours");
}

// Per-triangle wall materials: a stone sliding across a floor whose two triangles differ only in friction. Oracle:
// Coulomb sliding decelerates at μ g on the frictional triangle and not at all on the frictionless one (velocity
// Verlet integrates a constant deceleration exactly; 1e-6 relative covers the Hertz oscillation of the normal force
// about m g, which the dashpot damps within the first millimetres).
BOOST_AUTO_TEST_CASE(each_wall_triangle_meets_the_stone_with_its_own_material) {
  for (const int material : {0, 1}) {
    Parameters p;
    p.timeStep = 1e-5;
    p.gravity = {0.0, 0.0, -9.81};
    p.stone = Material{1e8, 0.25, 0.2, 0.5};
    p.wall = p.stone;
    p.backend = Backend::Cpu;
    PolyhedraSystem system(p);
    // A point core dilated by 10 mm: a sphere, launched without spin so that it slides.
    ShapeTemplate sphere;
    sphere.vertices = {0.0, 0.0, 0.0};
    sphere.dilationRadius = 0.01;
    sphere.density = 2600;
    const int shape = system.addShape(sphere);
    system.addStone(shape, {0.05, 0.0, 0.01 - 1e-6}, {1, 0, 0, 0}, {1.0, 0.0, 0.0});
    system.setWalls({-1, -1, 0, 1, -1, 0, 1, 1, 0, -1, 1, 0}, {0, 1, 2, 0, 2, 3});
    Material frictionless = p.stone;
    frictionless.friction = 0.0;
    // Triangle 0 (below the diagonal y = x, where the stone slides at y = 0, x > 0) gets `material`.
    system.setWallMaterials({p.stone, frictionless}, {material, 1 - material});
    system.step(2000); // 0.02 s: settles on the floor (the start overlap is 1 µm) and slides
    const double v0 = system.velocities()[0];
    system.step(1000);
    const double deceleration = (v0 - system.velocities()[0]) / 0.01;
    // Sliding sphere: the friction force μ m g decelerates the centre by μ g and spins it up (5/2 μ g / R); it keeps
    // sliding while v > ω R, i.e. for 2/7 v0 / (μ g) = 0.058 s, beyond this window (0.02–0.03 s).
    const double expected = material == 0 ? 0.5 * 9.81 : 0.0;
    BOOST_TEST_MESSAGE("material " << material << ": deceleration " << deceleration << " m/s², expected " << expected);
    BOOST_TEST(std::fabs(deceleration - expected) < 1e-3 * 0.5 * 9.81);
  }
  PolyhedraSystem system(bedParameters());
  buildBed(system);
  BOOST_CHECK_THROW(system.setWallMaterials({bedParameters().stone}, {0, 0}), railcosim::Error);     // 10 triangles
  BOOST_CHECK_THROW(system.setWallMaterials({bedParameters().stone}, std::vector<std::int32_t>(10, 1)),
                    railcosim::Error); // index out of range
  BOOST_CHECK_THROW(system.setWallMaterials(std::vector<Material>(maxWallMaterials + 1, bedParameters().stone),
                                            std::vector<std::int32_t>(10, 0)),
                    railcosim::Error);
}

// Cost of a snapshot against a step, on the test bed (printed for the record; not a test of speed).
BOOST_AUTO_TEST_CASE(snapshot_cost_is_reported) {
  PolyhedraSystem system(bedParameters());
  buildBed(system);
  system.step(settleSteps);
  using Clock = std::chrono::steady_clock;
  auto seconds = [](Clock::time_point start) { return std::chrono::duration<double>(Clock::now() - start).count(); };
  auto start = Clock::now();
  system.step(500);
  const double step = seconds(start) / 500;
  start = Clock::now();
  for (int k = 0; k < 100; ++k) system.saveSnapshot();
  const double save = seconds(start) / 100;
  start = Clock::now();
  for (int k = 0; k < 100; ++k) system.restoreSnapshot();
  const double restore = seconds(start) / 100;
  std::ostringstream out;
  start = Clock::now();
  system.writeState(out);
  const double write = seconds(start);
  BOOST_TEST_MESSAGE("27 stones: step " << step * 1e6 << " µs, saveSnapshot " << save * 1e6 << " µs, restoreSnapshot "
                                        << restore * 1e6 << " µs, writeState " << write * 1e6 << " µs ("
                                        << out.str().size() << " bytes)");
  BOOST_TEST(out.str().size() > 27u * 24u * 64u); // at least the pair slots were written
}
