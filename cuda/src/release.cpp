// hdt::releaseCuda: the end of a process's CUDA work, done early.
#include "device_memory.hpp"
#include "host_copy.hpp"
#include "check.hpp"

#include "hdt/builder.hpp"

#include <cuda_runtime.h>

namespace hdt {

void releaseCuda(const BuildOptions& options) {
  try {
    int count = 0;
    if (cudaGetDeviceCount(&count) != cudaSuccess || options.device < 0 || options.device >= count) {
      cudaGetLastError();
      return;
    }
    // No guard that restores the previous device afterwards: since CUDA 12
    // cudaSetDevice makes the primary context, which would undo the reset.
    int current = -1;
    if (cudaGetDevice(&current) != cudaSuccess || current != options.device) HDT_CUDA_CHECK(cudaSetDevice(options.device));
    cuda::releaseCopyStaging();
    cuda::DeviceMemory::releasePool(options.device);
    cudaDeviceReset(); // the context, and what the process's exit would tear down with it
    cudaGetLastError();
  } catch (...) {
    cudaGetLastError(); // nothing to report: the exit frees what is left
  }
}

} // namespace hdt
