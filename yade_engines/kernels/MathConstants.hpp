// Mathematical constants for the kernels (M_PI is not guaranteed by strict ISO C++ nor in device code).
#pragma once

namespace railcosim::kernels {

constexpr double pi = 3.14159265358979323846;

} // namespace railcosim::kernels
