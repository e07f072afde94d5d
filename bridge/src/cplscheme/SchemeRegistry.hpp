// The registry of coupling schemes: each scheme file defines its entry (factories of both sides and its order).
#pragma once

#include "cplscheme/MessageOrder.hpp"
#include "railcosim/CouplingScheme.hpp"

#include <cstddef>
#include <memory>

namespace railcosim::cplscheme {

struct SchemeEntry {
  CouplingScheme scheme;
  /// `fresh`: false for a run resumed from a checkpoint (the scheme's state is read next; nothing is exchanged).
  std::unique_ptr<DemCouplingScheme> (*makeDem)(const SchemeSettings&, DemParticipant&, const InterfaceSetup&,
                                                bool fresh);
  std::unique_ptr<FemCouplingScheme> (*makeFem)(FemParticipant&, std::size_t nodeCount);
  std::unique_ptr<MessageOrder> (*makeOrder)();
};

/// The row of `scheme`; throws Error for a value no row lists.
const SchemeEntry& schemeEntry(CouplingScheme scheme);

} // namespace railcosim::cplscheme
