// Stand-in for the CUDA backend factory when the library is built without CUDA (RAILCOSIM_WITH_CUDA=OFF).
#include "polyhedra/PolyhedraBackend.hpp"

namespace railcosim::polyhedra {

std::unique_ptr<PolyhedraBackend> makeCudaBackend(std::string& reason) {
  reason = "built without CUDA (configure with -DRAILCOSIM_WITH_CUDA=ON)";
  return nullptr;
}

} // namespace railcosim::polyhedra
