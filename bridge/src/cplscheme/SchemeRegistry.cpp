// The registry of coupling schemes and the names users write for them.
#include "cplscheme/SchemeRegistry.hpp"
#include "railcosim/Error.hpp"
#include "railcosim/Participant.hpp"

namespace railcosim {
namespace cplscheme {

extern const SchemeEntry justInTimeEntry; // JustInTimeScheme.cpp
extern const SchemeEntry predictiveEntry; // PredictiveScheme.cpp
extern const SchemeEntry implicitEntry;   // ImplicitScheme.cpp

namespace {

// Adding a scheme: its file in cplscheme/ (DEM side, FEM side, message order and its entry), one row here, its
// name in SchemeNames.cpp and its enum value.
const SchemeEntry* const registry[] = {&justInTimeEntry, &predictiveEntry, &implicitEntry};

} // namespace

const SchemeEntry& schemeEntry(CouplingScheme scheme) {
  for (const SchemeEntry* entry : registry) {
    if (entry->scheme == scheme) return *entry;
  }
  throw Error("coupling scheme #" + std::to_string(static_cast<int>(scheme)) + " has no registry row");
}

std::unique_ptr<MessageOrder> makeMessageOrder(CouplingScheme scheme) { return schemeEntry(scheme).makeOrder(); }

} // namespace cplscheme

std::unique_ptr<DemCouplingScheme> DemCouplingScheme::create(const SchemeSettings& settings,
                                                             DemParticipant& participant, const InterfaceSetup& setup) {
  settings.validate();
  return cplscheme::schemeEntry(settings.scheme).makeDem(settings, participant, setup, true);
}

std::unique_ptr<DemCouplingScheme> DemCouplingScheme::resume(const SchemeSettings& settings,
                                                             DemParticipant& participant, const InterfaceSetup& setup,
                                                             std::istream& state) {
  settings.validate();
  auto scheme = cplscheme::schemeEntry(settings.scheme).makeDem(settings, participant, setup, false);
  scheme->readState(state, setup);
  return scheme;
}

namespace {
CouplingScheme agreedScheme(const FemParticipant& participant) {
  const std::string agreed = participant.couplingScheme();
  return agreed.empty() ? CouplingScheme::JustInTime : parseCouplingScheme(agreed);
}
} // namespace

std::unique_ptr<FemCouplingScheme> FemCouplingScheme::create(FemParticipant& participant, std::size_t nodeCount) {
  return cplscheme::schemeEntry(agreedScheme(participant)).makeFem(participant, nodeCount);
}

std::unique_ptr<FemCouplingScheme> FemCouplingScheme::resume(FemParticipant& participant, std::size_t nodeCount,
                                                             std::istream& state) {
  auto scheme = cplscheme::schemeEntry(agreedScheme(participant)).makeFem(participant, nodeCount);
  scheme->readState(state);
  return scheme;
}

} // namespace railcosim
