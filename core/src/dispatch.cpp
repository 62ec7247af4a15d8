// Backend selection: Auto prefers the CUDA driver and falls back to the CPU.
#include "hdt/builder.hpp"
#include "hdt/device_pool.hpp"

#include "hdt/error.hpp"
#include "hdt/labels.hpp"
#include "hdt/mesh.hpp"
#include "hdt/root_ranges.hpp"
#include "hdt/winding_tree.hpp"

#include <memory>
#include <utility>

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
void prepareCuda(const BuildConfig&, const BuildOptions&, const std::function<bool()>&) {}
void releaseCuda(const BuildOptions&) {}
void setCudaPoolRetention(uint64_t) {}
bool buildLabelledCuda(const PreparedMesh&, const std::vector<PreparedMesh>&, const std::vector<Label>&,
                       const LabelOptions&, const BuildOptions&, Volume&, const std::function<void()>&) {
  return false;
}
std::unique_ptr<RootRangeBuild> makeCudaRangeBuild(const PreparedMesh&, const BuildOptions&, RootRange) {
  throw Error(ErrorKind::InvalidArgument,
              "backend cuda requested but this build has no CUDA driver (HDT_ENABLE_CUDA=OFF)");
}
double applyInsideTestCuda(const PreparedMesh&, Volume&, const BuildOptions&) {
  throw Error(ErrorKind::InvalidArgument,
              "backend cuda requested but this build has no CUDA driver (HDT_ENABLE_CUDA=OFF)");
}
#endif

double applyInsideTestAfterPhases(const PreparedMesh& mesh, Volume& volume, const BuildOptions& options) {
  // Only the winding-number pass has a device form.
  if (!windingPassFollows(mesh) || options.backend == Backend::Cpu)
    return applyInsideTestAfterCpuPhases(mesh, volume, options.progress);
  if (options.backend == Backend::Cuda) return applyInsideTestCuda(mesh, volume, options);
  // Auto. No fallback after the device pass has begun: it rewrites the volume
  // in place, so a device failure there is an error, as it is for Cuda.
  std::string why;
  if (cudaAvailable(&why)) return applyInsideTestCuda(mesh, volume, options);
  if (options.log) options.log("backend auto: the winding-number pass runs on the host (" + why + ")");
  return applyInsideTestAfterCpuPhases(mesh, volume, options.progress);
}

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
    options.warning(std::string("backend auto: CUDA driver failed (") + e.what() + "); falling back to the CPU driver");
    return buildCpu(mesh, options);
  }
}

namespace {

// Auto on a range: the CUDA driver, and the CPU driver from the start of the
// failed stage when it fails (both drivers give the same boundary parities,
// so the other ranges of the build never notice).
class FallbackRangeBuild final : public RootRangeBuild {
public:
  FallbackRangeBuild(const PreparedMesh& mesh, const BuildOptions& options, RootRange cells)
      : mesh_(mesh), options_(options), cells_(cells) {
    try {
      build_ = makeCudaRangeBuild(mesh, options, cells);
    } catch (const Error& e) {
      fallBack(e);
    }
  }
  const RangeBoundary& buildTree() override {
    try {
      return build_->buildTree();
    } catch (const Error& e) {
      if (!build_ || std::string(build_->backend()) == "cpu") throw;
      fallBack(e);
      return build_->buildTree();
    }
  }
  RangeTree finish(const RangeBoundary* beyond) override {
    try {
      return build_->finish(beyond);
    } catch (const Error& e) {
      if (std::string(build_->backend()) == "cpu") throw;
      fallBack(e);
      build_->buildTree();
      return build_->finish(beyond);
    }
  }
  const PhaseTimes& times() const override { return build_->times(); }
  const char* backend() const override { return build_->backend(); }
  int device() const override { return build_->device(); }

private:
  void fallBack(const Error& e) {
    if (e.kind() == ErrorKind::Aborted) throw e;
    options_.warning(std::string("backend auto: CUDA driver unavailable or failed (") + e.what() +
                     "); this range is built by the CPU driver");
    build_.reset(); // releases the device before the CPU build
    build_.reset(new CpuRangeBuild(mesh_, options_, cells_));
  }

  const PreparedMesh& mesh_;
  const BuildOptions options_;
  const RootRange cells_;
  std::unique_ptr<RootRangeBuild> build_;
};

} // namespace

std::unique_ptr<RootRangeBuild> makeRangeBuild(const PreparedMesh& mesh, const BuildOptions& options,
                                               RootRange cells) {
  switch (options.backend) {
  case Backend::Cpu: return std::unique_ptr<RootRangeBuild>(new CpuRangeBuild(mesh, options, cells));
  case Backend::Cuda: return makeCudaRangeBuild(mesh, options, cells);
  case Backend::Auto: break;
  }
  std::string why;
  if (!cudaAvailable(&why)) {
    if (options.log) options.log("backend auto: using the CPU driver for this range (" + why + ")");
    return std::unique_ptr<RootRangeBuild>(new CpuRangeBuild(mesh, options, cells));
  }
  return std::unique_ptr<RootRangeBuild>(new FallbackRangeBuild(mesh, options, cells));
}

BuildOptions insideTestOptionsAfterRangeBuild(const BuildOptions& rangeOptions, int device) {
  BuildOptions o = rangeOptions;
  if (device < 0) o.backend = Backend::Cpu;
  else o.device = device;
  return o;
}

Volume voxelize(const TriangleMesh& mesh, const BuildConfig& config, const BuildOptions& options) {
  return build(prepareMesh(mesh, config), options);
}

} // namespace hdt
