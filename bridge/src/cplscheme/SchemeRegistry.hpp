// The registry of coupling schemes: one row per scheme, naming its factories (cplscheme/*Scheme.cpp).
#pragma once

#include "cplscheme/MessageOrder.hpp"
#include "railcosim/CouplingScheme.hpp"

#include <cstddef>
#include <memory>

namespace railcosim::cplscheme {

struct SchemeEntry {
  CouplingScheme scheme;
  std::unique_ptr<DemCouplingScheme> (*makeDem)(const SchemeSettings&, DemParticipant&, const InterfaceSetup&);
  std::unique_ptr<FemCouplingScheme> (*makeFem)(FemParticipant&, std::size_t nodeCount);
  std::unique_ptr<MessageOrder> (*makeOrder)();
};

/// The row of `scheme`; throws Error for a value no row lists.
const SchemeEntry& schemeEntry(CouplingScheme scheme);

// Factories, one trio per scheme file.
std::unique_ptr<DemCouplingScheme> makeJustInTimeDem(const SchemeSettings&, DemParticipant&, const InterfaceSetup&);
std::unique_ptr<FemCouplingScheme> makeJustInTimeFem(FemParticipant&, std::size_t nodeCount);
std::unique_ptr<MessageOrder> makeJustInTimeOrder();
std::unique_ptr<DemCouplingScheme> makePredictiveDem(const SchemeSettings&, DemParticipant&, const InterfaceSetup&);
std::unique_ptr<FemCouplingScheme> makePredictiveFem(FemParticipant&, std::size_t nodeCount);
std::unique_ptr<MessageOrder> makePredictiveOrder();
std::unique_ptr<DemCouplingScheme> makeImplicitDem(const SchemeSettings&, DemParticipant&, const InterfaceSetup&);
std::unique_ptr<FemCouplingScheme> makeImplicitFem(FemParticipant&, std::size_t nodeCount);
std::unique_ptr<MessageOrder> makeImplicitOrder();

} // namespace railcosim::cplscheme
