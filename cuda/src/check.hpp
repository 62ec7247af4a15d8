// Every CUDA runtime call of the driver goes through HDT_CUDA_CHECK.
//
// Two kinds of failure are told apart:
//   * the device (or the caller's budget) has no room for an allocation:
//     DeviceMemoryExhausted, which the driver catches to build the root grid
//     in smaller chunks (it never escapes buildCuda);
//   * anything else (no device, launch failure, a fault in a kernel):
//     hdt::Error(OutOfResources) naming the call, so that Backend::Auto falls
//     back to the CPU driver.
#pragma once

#include "hdt/error.hpp"

#include <cuda_runtime.h>

#include <cstdint>
#include <exception>

namespace hdt {
namespace cuda {

class DeviceMemoryExhausted : public std::exception {
public:
  DeviceMemoryExhausted(uint64_t needed, uint64_t available) : needed_(needed), available_(available) {}
  const char* what() const noexcept override { return "device memory exhausted"; }
  uint64_t neededBytes() const { return needed_; }       // live + requested at the failure
  uint64_t availableBytes() const { return available_; } // the budget at the time

private:
  uint64_t needed_, available_;
};

[[noreturn]] void throwCudaError(cudaError_t e, const char* call, const char* file, int line);

inline void checkCuda(cudaError_t e, const char* call, const char* file, int line) {
  if (e != cudaSuccess) throwCudaError(e, call, file, line);
}

} // namespace cuda
} // namespace hdt

#define HDT_CUDA_CHECK(call) ::hdt::cuda::checkCuda((call), #call, __FILE__, __LINE__)
// After a launch: configuration errors show here, faults at the next sync.
#define HDT_CUDA_CHECK_LAUNCH(name) ::hdt::cuda::checkCuda(cudaGetLastError(), name, __FILE__, __LINE__)
