// Implicit coupling, DEM side: repeats a window until the FEM end state agrees with the one the DEM assumed.
#pragma once

#include "railcosim/CouplingScheme.hpp"
#include "railcosim/InterfaceMesh.hpp"

#include <cstdint>
#include <string>
#include <vector>

namespace railcosim {

class StateReader;
class StateWriter;

/// One window of the implicit scheme as the DEM side sees it:
///   guess P~_0 = P + V dt + A dt²/2 from the accepted state at t_i (the FEM's, or the initial one);
///   pass k: the DEM simulates the window with the surface moving linearly from P(t_i) to P~_k
///   (surfaceStart()), sends its forces, the FEM answers with its end state P_k+1 from the saved
///   state at t_i; residual r_k = P_k+1 - P~_k; converged when rms|r_k| <= tol rms|P_k+1 - P_0| + atol;
///   else P~_k+1 = P~_k + ω_k r_k (Aitken: ω_k = -ω_k-1 r_k-1·(r_k - r_k-1) / |r_k - r_k-1|²) and the
///   DEM rolls back to t_i. A window in which no particle touched the surface converges at once: its
///   forces (zero) do not depend on where the surface was assumed to be.
class ImplicitWindowIteration {
public:
  enum class Outcome { Converged, Repeat, GaveUp };

  ImplicitWindowIteration(ImplicitSettings settings, std::vector<double> referencePositions, double windowLength);

  /// Starts window i from the accepted state at t_i (needs positions; velocities/accelerations optional).
  void startWindow(const NodalKinematics& accepted);
  /// Surface motion for the current pass: P = P(t_i), V = (P~_k - P(t_i)) / dt, A = 0 (for extrapolateSurface).
  const NodalKinematics& surfaceStart() const { return surfaceStart_; }
  /// End positions P~_k the current pass assumes [m].
  const std::vector<double>& assumedEnd() const { return assumed_; }
  /// Judges the FEM's answer to pass k; on Repeat the next pass's surface is ready in surfaceStart().
  /// surfaceTouched: whether any particle touched the surface during the pass.
  Outcome judge(const NodalKinematics& femEnd, bool surfaceTouched);

  std::uint32_t iteration() const { return iteration_; } // pass k of the current window (0 = first)
  double residualNorm() const { return residualNorm_; }  // rms|r_k| of the last judged pass [m]
  double convergenceLimit() const { return limit_; }     // the rms|r| it had to reach [m]
  double relaxation() const { return omega_; }           // ω applied after the last judged pass
  const ImplicitSettings& settings() const { return settings_; }
  /// The iteration's state (accepted state, assumed end, residuals, pass, Aitken's factor ω) for a restart
  /// checkpoint; readState() continues from it bit for bit. The settings and the reference positions are the
  /// constructor's and must be the saved ones (checked: reference positions, window length).
  void writeState(StateWriter& state) const;
  void readState(StateReader& state);

private:
  void setSurface();

  ImplicitSettings settings_;
  std::vector<double> reference_; // P_0, mesh coordinates at t = 0
  double windowLength_;
  NodalKinematics accepted_;    // state at t_i
  std::vector<double> assumed_; // P~_k
  std::vector<double> residual_, previousResidual_;
  NodalKinematics surfaceStart_;
  std::uint32_t iteration_ = 0;
  double omega_ = 0.0;
  double residualNorm_ = 0.0;
  double limit_ = 0.0;
};

/// "Converged" | "Repeat" | "GaveUp", for logs.
std::string toString(ImplicitWindowIteration::Outcome outcome);

} // namespace railcosim
