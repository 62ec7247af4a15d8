#include "check.hpp"

#include <string>

namespace hdt {
namespace cuda {

void throwCudaError(cudaError_t e, const char* call, const char* file, int line) {
  if (e == cudaErrorMemoryAllocation) {
    cudaGetLastError(); // not sticky: clear it so the context stays usable
    throw DeviceMemoryExhausted(0, 0);
  }
  std::string where = file;
  const size_t slash = where.find_last_of('/');
  if (slash != std::string::npos) where = where.substr(slash + 1);
  throw Error(ErrorKind::OutOfResources, std::string("CUDA error ") + cudaGetErrorName(e) + " (" +
                                             cudaGetErrorString(e) + ") in " + call + " at " + where + ":" +
                                             std::to_string(line));
}

} // namespace cuda
} // namespace hdt
