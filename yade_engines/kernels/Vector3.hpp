// The kernels' 3-vector: the shared railcosim::Vec3 (railcosim/Vector3.hpp, also used by the bridge's mapping).
#pragma once

#include "railcosim/Vector3.hpp"

namespace railcosim::kernels {
using railcosim::cross;
using railcosim::dot;
using railcosim::norm;
using railcosim::squaredNorm;
using railcosim::tangentialPart;
using railcosim::Vec3;
} // namespace railcosim::kernels
