// Backend selection: Auto prefers the CUDA driver and falls back to the CPU.
#include "hdt/builder.hpp"

#include "hdt/error.hpp"

namespace hdt {

#if !defined(HDT_HAVE_CUDA)
bool cudaAvailable(std::string* why) {
  if (why) *why = "this build has no CUDA driver (configured with HDT_ENABLE_CUDA=OFF)";
  return false;
}
int cudaDeviceCount() { return 0; }
Volume buildCuda(const PreparedMesh&, const BuildOptions&) {
  throw Error(ErrorKind::InvalidArgument,
              "backend cuda requested but this build has no CUDA driver (HDT_ENABLE_CUDA=OFF)");
}
void prepareCuda(const BuildConfig&, const BuildOptions&) {}
#endif

Volume build(const PreparedMesh& mesh, const BuildOptions& options) {
  switch (options.backend) {
  case Backend::Cpu: return buildCpu(mesh, options);
  case Backend::Cuda: return buildCuda(mesh, options);
  case Backend::Auto: break;
  }
  std::string why;
  if (!cudaAvailable(&why)) {
    if (options.log) options.log("backend auto: using the CPU driver (" + why + ")");
    return buildCpu(mesh, options);
  }
  try {
    return buildCuda(mesh, options);
  } catch (const Error& e) {
    if (e.kind() == ErrorKind::Aborted) throw;
    if (options.log) options.log(std::string("backend auto: CUDA driver failed (") + e.what() +
                                 "); falling back to the CPU driver");
    return buildCpu(mesh, options);
  }
}

Volume voxelize(const TriangleMesh& mesh, const BuildConfig& config, const BuildOptions& options) {
  return build(prepareMesh(mesh, config), options);
}

} // namespace hdt
