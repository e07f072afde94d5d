// Public interface of the dilated-polyhedra DEM (GPU with CPU reference): plain C++, no CUDA types.
#pragma once

#include <array>
#include <cstdint>
#include <iosfwd>
#include <memory>
#include <string>
#include <vector>

namespace railcosim::kernels {
struct ContactMaterial;
}

namespace railcosim {
class StateReader;
class StateWriter;
} // namespace railcosim

namespace railcosim::polyhedra {

/// A convex core polyhedron shared by every stone of one shape (a "shape template"). The stone is the
/// Minkowski sum of the core and a sphere of radius `dilationRadius` (Ullrich 2022 §2.3, eq. 2.4).
struct ShapeTemplate {
  std::vector<double> vertices;        ///< core vertices, 3 per vertex, any body frame [m]
  std::vector<std::int32_t> triangles; ///< core surface, 3 vertex indices each, outward (CCW) [-]
  double dilationRadius = 0.0;         ///< r_d [m], > 0
  double density = 2600.0;             ///< [kg/m^3]
};

/// Mass properties the library derived for a template (core moved to its centroid, principal axes).
struct ShapeProperties {
  double mass = 0.0;                        ///< of the dilated body [kg]
  std::array<double, 3> principalInertia{}; ///< [kg m^2]
  double circumradius = 0.0;                ///< core circumradius about the centroid + r_d [m]
  double dilatedVolume = 0.0;               ///< Steiner formula [m^3]
  /// Rotation (w,x,y,z) from the principal frame to the frame the template was given in, and the
  /// centroid in that frame: vertex_given = centroid + rotate(principalToGiven, vertex_principal).
  std::array<double, 4> principalToGiven{1.0, 0.0, 0.0, 0.0};
  std::array<double, 3> centroid{};
};

/// Material of stones and of walls. A pair mixes two materials with the one rule of the contact law
/// (kernels/ContactLaw.hpp, docs/contact-models.md: mean damping ratio, smaller μ, ...), whose curvature is that of
/// the dilation (Ullrich 2022 eqs. 2.20–2.24). Smooth surfaces give Hertz–Mindlin; a roughness selects the
/// Pohrt–Popov laws (Tolomeo & McDowell 2022).
struct Material {
  double youngModulus = 1e10;    ///< E [Pa]
  double poissonRatio = 0.25;    ///< ν [-]
  double restitution = 0.2;      ///< normal coefficient of restitution e [-]
  double friction = 0.6;         ///< Coulomb coefficient μ [-]
  double roughnessRms = 0.0;     ///< h [m]; > 0 selects the rough-surface (Pohrt–Popov) normal law
  double fractalDimension = 0.0; ///< D_f [-], in [2, 3) when roughnessRms > 0
  bool plasticUnloading = false; ///< elasto-plastic Pohrt–Popov (keeps F_max and δ_p per contact)
  double frictionExponent = 0.0; ///< γ_μ ≤ 0 [-] of the stress-dependent friction between stones; 0: constant μ
  double maxContactStress = 0.0; ///< σ_c,max [Pa] of the stress-dependent friction; 0: constant μ
  /// η_r [-] of bounded rolling friction (Irazábal 2017 §5.2.1; a pair takes the larger of its two); 0: none. The
  /// rolling torque acts on sphere stones only (a one-vertex core, whose dilation is the sphere).
  double rollingFriction = 0.0;
};

/// The polyhedra Material of a contact-law material (kernels/ContactLaw.hpp; e.g. YADE's, from contactMaterialOf).
Material materialOf(const kernels::ContactMaterial& material);

enum class Backend { Automatic, Cpu, Cuda };

/// Most distinct wall materials one system holds (setWallMaterials): fixed walls of a few kinds and a coupled surface.
constexpr int maxWallMaterials = 4;

struct Parameters {
  double timeStep = 1e-6;                         ///< Δt [s]
  std::array<double, 3> gravity{0.0, 0.0, -9.81}; ///< [m/s^2]
  /// Non-viscous damping share of the stones' translation [0, 1) (YADE's NewtonIntegrator.damping): for packings.
  double damping = 0.0;
  Material stone;                                 ///< stone–stone contacts
  Material wall; ///< stone–wall/surface contacts (friction, restitution of the pair); per triangle: setWallMaterials
  double neighbourSkin = -1.0;                    ///< Verlet skin [m]; < 0: 0.2 × mean dilation radius
  /// Steps between neighbour-list rebuilds [-]. Every `step` call starts with one; with adaptiveRebuild a
  /// later one is skipped while no stone's displacement since the last rebuild plus its speed × this
  /// interval reaches half the skin (a settled bed then keeps its lists); moving walls count by their nodes' way
  /// since the last rebuild and their speed (a plate pressing a bed slowly skips most rebuilds too).
  int rebuildInterval = 10;
  bool adaptiveRebuild = true; ///< skip rebuilds the lists do not need (see rebuildInterval)
  int maxNeighbours = 24;      ///< candidate partners stored per stone (j > i; a large body's partners: see below) [-]
  /// Bodies whose bounding radius exceeds this multiple of the median one are "large" (pressure cells, blocks among
  /// stones): they stay out of the grid, whose cell then fits the other bodies, and every other body lists the large
  /// ones within reach itself (a scan of at most maxLargeBodies, the largest if more exceed it). A 0.17 m sensor
  /// among 0.03 m stones would otherwise set grid cells of 125 times the volume, 27 of them scanned per stone; a
  /// stone's list (maxNeighbours) then holds its partners j > i plus the large bodies within reach [-]. <= 0: none.
  double largeBodyRatio = 2.5;
  int maxWallNeighbours = 8;   ///< candidate triangles stored per stone [-]
  /// Patch centring, fraction of r_d [-]. 0 (default): the force acts at the closest points of the cores
  /// (Ullrich 2022: two virtual spheres there), a conservative force field. > 0: vertices within this band of
  /// the support height form a face and face–face / edge–face contacts act at the centre of the
  /// overlapping region; more faithful torques for stones resting on faces, but the point jumps when a
  /// vertex enters the band, which feeds energy into resting piles (measured: residual speeds of
  /// 2–5 mm/s with 0.02–0.1 instead of < 0.1 mm/s in the settling test).
  double featureTolerance = 0.0;
  Backend backend = Backend::Automatic; ///< Automatic: CUDA if a GPU is usable, else CPU
};

/// Most large bodies (Parameters::largeBodyRatio) a system lists apart from the grid; with more, all share the grid.
constexpr int maxLargeBodies = 256;

/// One active contact (for checks, output and the comparison between backends).
struct ContactRecord {
  std::int32_t first = 0;  ///< stone index
  std::int32_t second = 0; ///< stone index, or triangle index for a wall contact
  bool wall = false;
  double overlap = 0.0;           ///< δ = r_A + r_B − Δ [m]
  std::array<double, 3> point{};  ///< contact point [m]
  std::array<double, 3> normal{}; ///< unit, from first to second
  std::array<double, 3> force{};  ///< total force on `second` (on the wall for walls) [N]
};

/// Counters of the last `step` call.
struct StepStatistics {
  std::int64_t steps = 0;
  std::int64_t neighbourRebuilds = 0;
  std::int64_t dangerousRebuilds = 0;    ///< a stone moved more than skin/2 between rebuilds
  std::int64_t coreOverlapFallbacks = 0; ///< contact evaluations where the cores intersected
  double meanActiveContacts = 0.0;       ///< stone–stone + stone–wall contacts, mean over the steps
};

/// A bed of dilated polyhedra advanced by velocity Verlet (translation) and the Zhao–van Wachem
/// quaternion predictor–corrector (rotation). State lives on the GPU when the CUDA backend is active and
/// is copied to the host only by the accessors below.
class PolyhedraSystem {
public:
  explicit PolyhedraSystem(const Parameters& parameters);
  ~PolyhedraSystem();
  PolyhedraSystem(const PolyhedraSystem&) = delete;
  PolyhedraSystem& operator=(const PolyhedraSystem&) = delete;

  /// Registers a template; returns its index. Throws Error for a degenerate or non-convex core.
  int addShape(const ShapeTemplate& shape);
  const ShapeProperties& shapeProperties(int shape) const;

  /// Adds a stone whose principal frame is at `position` with orientation (w,x,y,z) `orientation`;
  /// velocities in the world frame. Returns its index. Stones may be added until the first `step`, which
  /// stores them in spatial order for speed; every accessor keeps speaking these indices.
  int addStone(int shape, const std::array<double, 3>& position, const std::array<double, 4>& orientation,
               const std::array<double, 3>& velocity = {0, 0, 0},
               const std::array<double, 3>& angularVelocity = {0, 0, 0});

  /// Fixed triangle walls (e.g. a box): coordinates 3 per node, triangles 3 indices each, CCW seen
  /// from the stones. Replaces any previous walls (and the moving surface: both share one mesh).
  void setWalls(const std::vector<double>& coordinates, const std::vector<std::int32_t>& triangles);
  /// Moving, deforming triangle surface (the FEM interface): call setWalls once for the connectivity,
  /// then this before each coupling window with node positions and velocities (3 per node). Nodes
  /// move with that constant velocity during the following `step` call.
  void setSurfaceKinematics(const std::vector<double>& positions, const std::vector<double>& velocities);
  /// Materials of the wall triangles: triangle t of setWalls meets the stones as materials[materialOfTriangle[t]],
  /// mixed with Parameters::stone by the one rule of the contact law (at most maxWallMaterials; e.g. frictionless
  /// side walls beside a coupled surface). Without this call every triangle is Parameters::wall. After setWalls,
  /// before the first step.
  void setWallMaterials(const std::vector<Material>& materials, const std::vector<std::int32_t>& materialOfTriangle);

  /// Smallest critical time step over the shape templates [s] (kernels/CriticalTimeStep.hpp, Hertz estimate):
  /// two equal stones (R* = r_d/2, m* = m/2) and a stone on a wall of each wall material (R* = r_d, m* = m), each for a contact carrying
  /// `normalForce` [N] (if > 0) and an impact at `impactVelocity` [m/s] (if > 0). The stone's rotation enters as
  /// the kernel's 3.5 k_t; several contacts per stone and lever arms longer than a sphere's call for 0.2–0.5 of it.
  double criticalTimeStep(double normalForce, double impactVelocity) const;

  /// Changes Δt [s] / gravity [m/s^2] for the following steps (e.g. a coarse packing phase, YADE's O.dt).
  void setTimeStep(double timeStep);
  void setGravity(const std::array<double, 3>& gravity);
  void setDamping(double damping);

  /// Advances `steps` time steps. Throws Error if a neighbour list overflowed (raise maxNeighbours).
  void step(int steps);

  std::size_t stoneCount() const;
  std::size_t triangleCount() const;
  double time() const;
  Backend activeBackend() const;
  /// Why this backend runs (e.g. "no CUDA device: CUDA driver version is insufficient ...").
  const std::string& backendReason() const;
  const StepStatistics& lastStatistics() const;

  // State, copied from the device on each call: 3 (or 4 for quaternions w,x,y,z) values per stone.
  std::vector<double> positions() const;
  std::vector<double> velocities() const;
  std::vector<double> orientations() const;
  std::vector<double> angularVelocities() const;
  /// The same four of the stones `stones` (addStone indices) only, in that order: on the CUDA backend only these
  /// stones cross to the host (a few sensor blocks read often, in a bed of 1e5 stones).
  void stoneStates(const std::vector<std::int32_t>& stones, std::vector<double>& positions,
                   std::vector<double>& orientations, std::vector<double>& velocities,
                   std::vector<double>& angularVelocities) const;
  /// Contact forces + torques of the last force evaluation (gravity excluded): 3 per stone.
  std::vector<double> forces() const;
  std::vector<double> torques() const;
  /// Replaces the state of all stones (3 or 4 values per stone as above).
  void setState(const std::vector<double>& positions, const std::vector<double>& orientations,
                const std::vector<double>& velocities, const std::vector<double>& angularVelocities);

  /// Mean force on each triangle over the steps of the last `step` call (3 per triangle, N) and the
  /// force-weighted mean contact point (3 per triangle, m; the triangle centroid when unloaded).
  std::vector<double> triangleForces() const;
  std::vector<double> triangleContactPoints() const;

  /// Active contacts at the last force evaluation of the last `step` call, in no particular order; `first`
  /// and `second` are addStone indices (`first` may be the larger one).
  std::vector<ContactRecord> contacts() const;
  /// The contacts that the stones `stones` (addStone indices) take part in, gathered where the lists live.
  std::vector<ContactRecord> contacts(const std::vector<std::int32_t>& stones) const;

  // Snapshots of the dynamic state, to simulate a stretch of time again (implicit coupling windows) or to restart.
  // The state is everything a later `step` reads: per stone position, velocity, orientation and angular velocity
  // with the rotation integrator's state, the contact forces and torques of the last evaluation (the next
  // predictor's), the displacement reference of the rebuild test; the neighbour lists with every contact's
  // tangential spring, last normal, GJK warm start and normal-model (plastic) history; the surface node positions
  // and velocities; the time, and what the accessors report of the last call (triangle sums, contacts, statistics).
  // Not state: Parameters, shapes, wall connectivity and materials, which belong to the system's construction. A
  // system not stepped yet is first prepared as its first `step` would (spatial order, lists allocated).
  // Stepping on from a restored state repeats what stepping on from the saved moment gave, bit for bit, wherever
  // that is repeatable at all: the CPU reference below 512 stones or with one OpenMP thread (above, the threads'
  // force sums add in varying order), not the CUDA backend (atomic sums).

  /// Keeps one copy of the state where it lives (host memory, or device buffers on the CUDA backend); a second
  /// call replaces it.
  void saveSnapshot();
  /// Puts the kept copy back (it stays kept: a window may be repeated several times). Throws Error if none.
  void restoreSnapshot();
  bool hasSnapshot() const;
  /// The state as bytes: a header (format version, stone, triangle, node and shape counts, list capacities,
  /// record sizes), the storage order of the stones, the wall connectivity, the stones' shapes, then the arrays
  /// (native byte order: the machine that wrote them, or one of the same architecture, reads them back).
  void writeState(std::ostream& out) const;
  /// Replaces the state with one written by writeState of a system built the same way (same shapes, stones in
  /// the same addStone order with the same shapes, same walls, same list capacities and law history; the
  /// Parameters may differ, e.g. a new time step). Throws Error naming the mismatch, a wrong version or a
  /// truncated stream, leaving the system as it was. A kept snapshot stays kept when the stream has this system's
  /// storage order (a state of the same run), and is dropped otherwise.
  void readState(std::istream& in);
  /// Restart checkpoints: the state (writeState) and, when kept, the snapshot of an implicit window's start, as
  /// length-prefixed sections of `out` (railcosim::StateWriter; the snapshot is written by restoring it, writing it
  /// and reading the current state back, which readState restores exactly). readRestartState puts both back.
  void writeRestartState(railcosim::StateWriter& out);
  void readRestartState(railcosim::StateReader& in);

  struct Implementation;

private:
  std::unique_ptr<Implementation> implementation_;
};

const char* backendName(Backend backend);

} // namespace railcosim::polyhedra
