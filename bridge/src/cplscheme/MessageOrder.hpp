// The sequence of Forces and Kinematics messages a coupling scheme allows; both participants keep one.
#pragma once

#include "railcosim/CouplingScheme.hpp"

#include <cstdint>
#include <memory>
#include <string>

namespace railcosim::cplscheme {

/// Checked by the DEM participant before it sends Forces and when Kinematics arrive, and by the FEM
/// participant when Forces arrive and before it sends Kinematics: one rule for both sides.
class MessageOrder {
public:
  virtual ~MessageOrder() = default;
  /// Empty when Forces may be exchanged at all now; else why not (a reply is still owed).
  virtual std::string forcesBlockedBecause() const { return {}; }
  virtual bool forcesAllowed(std::uint64_t window, std::uint32_t iteration) const = 0;
  virtual std::string expectedForces() const = 0; // e.g. "window 3 (iteration 0) or window 2 (iteration 2)"
  virtual void forcesExchanged(std::uint64_t window, std::uint32_t iteration) = 0;
  virtual bool kinematicsAllowed(std::uint64_t window) const = 0;
  virtual std::string expectedKinematics() const = 0;
  virtual std::uint32_t kinematicsIteration() const { return 0; } // pass the next Kinematics answer
  virtual void kinematicsExchanged(std::uint64_t window) = 0;
  /// A restart checkpoint is taken at a window boundary: after every Forces sent so far has been answered, before
  /// the Forces of window `window` = forcesWindows().
  virtual bool checkpointAllowed(std::uint64_t window) const = 0;
  std::string expectedCheckpoint() const; // "window 3 (at a window boundary: ...)"
  /// The checkpoint of `window` was ordered: the window before it is accepted for good (no further pass over it).
  virtual void checkpointExchanged(std::uint64_t window) { (void)window; }
  /// A resumed run continues from the boundary of `window` as if the windows before it had been exchanged.
  virtual void resumeAt(std::uint64_t window) = 0;
  std::uint64_t forcesWindows() const { return nextForces_; }         // windows with forces so far
  std::uint64_t kinematicsWindows() const { return nextKinematics_; } // windows with kinematics so far

protected:
  std::uint64_t nextForces_ = 0;
  std::uint64_t nextKinematics_ = 0;
};

/// Order of `scheme` (the registry's entry).
std::unique_ptr<MessageOrder> makeMessageOrder(CouplingScheme scheme);

/// One window after the other, each Forces and Kinematics once: just-in-time (Forces first) and
/// predictive (Kinematics first); either side may be at most one window ahead of the other.
class SequentialOrder : public MessageOrder {
public:
  /// `kinematicsLead`: windows by which the Kinematics run ahead of the Forces at a window boundary (predictive: 1,
  /// the FEM steps first; just-in-time: 0).
  explicit SequentialOrder(std::uint64_t kinematicsLead = 0) : lead_(kinematicsLead) {}
  bool forcesAllowed(std::uint64_t window, std::uint32_t iteration) const override;
  std::string expectedForces() const override;
  void forcesExchanged(std::uint64_t window, std::uint32_t iteration) override;
  bool kinematicsAllowed(std::uint64_t window) const override;
  std::string expectedKinematics() const override;
  void kinematicsExchanged(std::uint64_t window) override;
  bool checkpointAllowed(std::uint64_t window) const override;
  void resumeAt(std::uint64_t window) override;

private:
  std::uint64_t lead_;
};

} // namespace railcosim::cplscheme
