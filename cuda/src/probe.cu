// cudaAvailable's check that this library holds code the device can run
// (sm_80 and sm_90 machine code, compute_90 PTX for newer GPUs).
#include <cuda_runtime.h>

namespace hdt {
namespace cuda {
namespace {
__global__ void probeKernel() {}
} // namespace

cudaError_t probeKernelImage() {
  cudaFuncAttributes attributes;
  return cudaFuncGetAttributes(&attributes, probeKernel);
}

} // namespace cuda
} // namespace hdt
