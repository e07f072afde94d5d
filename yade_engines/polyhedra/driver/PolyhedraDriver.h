/* C interface of the dilated-polyhedra DEM without YADE: a bed of stones in their body frames, triangle walls (some
 * of them moving plates), and a FEM surface coupled through the railcosim bridge, advanced one window at a time as
 * YADE's FemCouplingEngine with contactModel 'polyhedra' advances it. For drivers in other languages (Python's
 * ctypes: python/railcosim/polyhedra_driver.py). docs/polyhedra-driver.md.
 *
 * Every function returns 0 (or a count, an index, >= 0) on success and -1 on failure; rcp_last_error() then says why
 * (thread-local, valid until the next call). Vectors are 3 doubles (x, y, z), quaternions 4 (w, x, y, z), materials 4
 * (Young's modulus [Pa], Poisson's ratio, restitution, friction coefficient). SI units. */
#ifndef RAILCOSIM_POLYHEDRA_DRIVER_H
#define RAILCOSIM_POLYHEDRA_DRIVER_H

#include <stdint.h>

#ifdef __cplusplus
extern "C" {
#endif

typedef struct rcp_bed rcp_bed;

const char* rcp_last_error(void);

/* A new bed. backend: "automatic", "cpu" or "cuda". skin < 0: a fifth of the mean dilation radius. large_body_ratio:
   bodies with a bounding radius above this multiple of the median one are kept out of the grid (<= 0: none). */
rcp_bed* rcp_create(double time_step, const double* gravity, const double* stone_material, int max_neighbours,
                    int max_wall_neighbours, int rebuild_interval, double neighbour_skin, int adaptive_rebuild,
                    double large_body_ratio, const char* backend);
void rcp_destroy(rcp_bed* bed);

/* A stone: core vertices (body frame, 3 per vertex), dilation, density; its body frame's state. Returns its index. */
int rcp_add_stone(rcp_bed* bed, const double* vertices, int vertex_count, double dilation, double density,
                  const double* position, const double* orientation, const double* velocity,
                  const double* angular_velocity);
/* Fixed walls: triangle_count triangles, each given by its 3 corner points (9 doubles), and the material index of
 * each into `materials` (material_count x 4). Before the first step; replaces earlier walls. */
int rcp_set_walls(rcp_bed* bed, const double* corners, int triangle_count, const int32_t* material_of_triangle,
                  const double* materials, int material_count);
/* Bounded rolling friction (Irazábal 2017 §5.2.1): η_r of the stones' material and of the first wall_count wall
 * materials of rcp_set_walls (the others 0), one value more being the coupled surface's (rcp_connect's
 * surface_material); a pair takes the larger of its two. The rolling torque acts on sphere
 * stones only (one core vertex, the dilation its radius). Before the first rcp_add_stone. */
int rcp_set_rolling_friction(rcp_bed* bed, double stones, const double* walls, int wall_count);
/* Hands stones and walls to the system (done by the first step otherwise). */
int rcp_initialize(rcp_bed* bed);
/* PolyhedraSystem::criticalTimeStep of the stones and the walls' materials [s]; initializes. -1 on failure. */
double rcp_critical_time_step(rcp_bed* bed, double normal_force, double impact_velocity);
int rcp_set_time_step(rcp_bed* bed, double time_step);
double rcp_time_step(rcp_bed* bed);
/* Non-viscous damping of the stones' translation from the next batch on (YADE's NewtonIntegrator.damping): each force
 * component loses this share [0, 1) while it accelerates its stone, gains it while it brakes it. For packings; 0 (the
 * default) in a physical run. */
int rcp_set_damping(rcp_bed* bed, double damping);
/* Wall triangles moving rigidly with `velocity` (3) from the next batch or coupling window on (a plate). */
int rcp_set_wall_velocity(rcp_bed* bed, const int32_t* triangles, int count, const double* velocity);
/* Wall triangles whose corners move each with its own velocity (9 per triangle: corner 1, 2, 3), constant over the next
 * batches or coupling windows until set again (a turning flap: the chord velocities of one window). Coupled or not;
 * an implicit window's repetition starts again from the window's start. */
int rcp_set_wall_node_velocities(rcp_bed* bed, const int32_t* triangles, int count, const double* velocities);
/* Advances `steps` steps in one batch (the moving walls at constant velocity). */
int rcp_step(rcp_bed* bed, int steps);
/* Sum of the mean forces of the last batch on the wall triangles `triangles` [N] into force (3). */
int rcp_wall_force(rcp_bed* bed, const int32_t* triangles, int count, double* force);
double rcp_time(rcp_bed* bed);
int rcp_stone_count(rcp_bed* bed);
int rcp_templates(rcp_bed* bed);
double rcp_mean_contacts(rcp_bed* bed);
/* Since the bed was made: contact evaluations whose cores intersected (the dilated contact law's fallback), and
 * neighbour-list rebuilds after which a stone had moved more than half the skin (contacts may have been missed), into
 * counters (2). */
int rcp_step_counters(rcp_bed* bed, int64_t* counters);
/* 0: cpu, 1: cuda, and why it runs (backend_reason, up to `size` bytes). */
int rcp_backend(rcp_bed* bed, char* reason, int size);
/* Body-frame states (3, 4, 3, 3 per stone) and masses (1 per stone) of the stones `indices` (count of them: only
 * these cross from a GPU), or of all stones when indices is null. Any output pointer may be null. Returns the number
 * of stones written. */
int rcp_states(rcp_bed* bed, const int32_t* indices, int count, double* positions, double* orientations,
               double* velocities, double* angular_velocities, double* masses);
/* Active contacts of the last force evaluation: the count; then rcp_contacts copies them (first, second: stone
 * indices, second the wall triangle when wall[k] = 1; point, normal, force on second (3 each), overlap). */
int rcp_contact_count(rcp_bed* bed);
/* As rcp_contact_count, but only the contacts that the stones `indices` (count of them) take part in, selected where
 * the lists live (a few sensor blocks' contacts read often, without the bed's). */
int rcp_contact_count_of(rcp_bed* bed, const int32_t* indices, int count);
int rcp_contacts(rcp_bed* bed, int32_t* first, int32_t* second, int32_t* wall, double* point, double* normal,
                 double* force, double* overlap);

/* Coupling with a FEM participant (the bridge's DEM side): handshake on `endpoint`; the FEM surface joins the walls
 * with `surface_material` (4). scheme: justInTime | predictive | implicit, with the implicit settings. The DEM step
 * becomes window / subcycles (subcycles: 0 = the fewest steps whose length does not exceed the current step).
 * Before the first step. Returns the subcycles. */
int rcp_connect(rcp_bed* bed, const char* endpoint, const char* name, const char* scheme, double timeout,
                double heartbeat, int subcycles, double implicit_tolerance, double implicit_absolute_tolerance,
                int implicit_max_iterations, double implicit_relaxation, int aitken, const double* surface_material);
/* One coupling window, repeated as the scheme orders until it stands. */
int rcp_window(rcp_bed* bed);
/* Figures of the coupling (RCP_FIGURES doubles, in this order): window length, subcycles, windows, surface nodes,
 * surface triangles, total force sent (3), surface force (3), interface work DEM, FEM, passes, last window passes,
 * max window passes, unconverged windows, last residual, loaded surface triangles, polyhedra time, mapping time,
 * bridge time, wait time, checkpoint time [s], time [s], restart checkpoint time [s], restart checkpoints written
 * (both over the whole run, a resumed one included). */
#define RCP_FIGURES 27
int rcp_coupling_figures(rcp_bed* bed, double* figures);
/* The surface triangles (3 node indices each) into triangles (3 x surface triangles). */
int rcp_surface_triangles(rcp_bed* bed, int32_t* triangles);
/* The surface's node positions now, the start of the next window (3 per node), and the nodal forces sent at the last
 * exchange (3 per node); either pointer may be null. Returns the number of surface nodes. */
int rcp_surface_state(rcp_bed* bed, double* positions, double* forces);
/* Restart checkpoints (docs/protocol.md section 12), set before rcp_connect: `folder` holds them (both sides'),
 * `run` identifies the run in each manifest, one is ordered every `every` seconds of simulated time (0: none) at
 * the exchange that ends a window; `resume_from` (a checkpoint folder; "" for a fresh run) is checked whole by
 * rcp_connect, which then goes on from it: the polyhedra system, the coupling scheme and this driver's counters. */
int rcp_set_restart(rcp_bed* bed, const char* folder, const char* run, double every, const char* resume_from);
/* 1 when the last rcp_window ordered a restart checkpoint, which waits for rcp_complete_checkpoint; else 0. */
int rcp_checkpoint_pending(rcp_bed* bed);
/* Completes the ordered checkpoint: this side's state, `state` (`size` bytes: the driving script's own, given back
 * by rcp_resumed_state) and `files` (paths in the working folder, one a line, copied and put back on resume);
 * commits it. */
int rcp_complete_checkpoint(rcp_bed* bed, const char* files, const char* state, long size);
/* In a resumed run, after rcp_connect: puts the checkpoint's DEM files back into the working folder (first call) and
 * returns the size of the script's saved state, copied into `buffer` when `capacity` holds it. */
long rcp_resumed_state(rcp_bed* bed, char* buffer, long capacity);
/* Tells the FEM side the run is over. */
int rcp_finalize(rcp_bed* bed);

#ifdef __cplusplus
}
#endif
#endif
