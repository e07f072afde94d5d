// The names users write for the coupling schemes (also what the protocol admits in a Hello).
#include "railcosim/CouplingScheme.hpp"
#include "railcosim/Error.hpp"

#include <cctype>
#include <utility>

namespace railcosim {
namespace {

const std::pair<CouplingScheme, const char*> names[] = {
    {CouplingScheme::JustInTime, "justInTime"},
    {CouplingScheme::Predictive, "predictive"},
    {CouplingScheme::Implicit, "implicit"},
};

/// Spelling-insensitive key: case, '-' and '_' do not matter ("Just-In-Time" = "justInTime").
std::string key(const std::string& name) {
  std::string result;
  for (unsigned char c : name) {
    if (c != '-' && c != '_') result += static_cast<char>(std::tolower(c));
  }
  return result;
}

} // namespace

CouplingScheme parseCouplingScheme(const std::string& name) {
  const std::string wanted = key(name);
  std::string known;
  for (const auto& [scheme, canonical] : names) {
    if (key(canonical) == wanted) return scheme;
    known += std::string(known.empty() ? "" : ", ") + "\"" + canonical + "\"";
  }
  throw Error("coupling scheme '" + name + "' is unknown; use " + known);
}

std::string toString(CouplingScheme scheme) {
  for (const auto& [value, canonical] : names) {
    if (value == scheme) return canonical;
  }
  throw Error("coupling scheme #" + std::to_string(static_cast<int>(scheme)) + " has no name");
}

std::string knownCouplingSchemes() {
  std::string known;
  for (const auto& entry : names) known += std::string(known.empty() ? "" : ", ") + entry.second;
  return known;
}

} // namespace railcosim
