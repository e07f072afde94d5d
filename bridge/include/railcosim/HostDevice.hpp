// Marks functions callable from both host C++ and CUDA device code (kernels, shared geometry).
#pragma once

#if defined(__CUDACC__)
#define RAILCOSIM_HOST_DEVICE __host__ __device__
#else
#define RAILCOSIM_HOST_DEVICE
#endif
