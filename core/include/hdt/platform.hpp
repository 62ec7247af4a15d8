// Compiler glue shared by the CPU and CUDA drivers.
//
// Every per-element function in core/ is marked HDT_HD so that one definition
// serves both drivers: the CPU builder calls it from oneTBB tasks, the CUDA
// driver calls it from kernels. There is exactly one copy of the geometry.
#pragma once

#if defined(__CUDACC__)
#define HDT_HD __host__ __device__ __forceinline__
#else
#define HDT_HD inline
#endif

#include <cstdint>

namespace hdt {

// 128-bit signed integer for the few exact products that exceed 64 bits
// (plane tests). Supported by GCC, Clang and nvcc (device code since CUDA 11.5).
__extension__ typedef __int128 int128_t;

} // namespace hdt
