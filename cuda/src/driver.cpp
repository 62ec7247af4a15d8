// buildCuda: sets up the device session, uploads the triangles, runs T1 and
// decides from its counts whether the build fits in one piece (the fast
// path: everything stays on the device until the final copy) or must be
// built in chunks of root cells (chunked.cpp).
#include "chunked.hpp"
#include "host_copy.hpp"
#include "pipeline.hpp"
#include "session.hpp"
#include "winding_device.hpp"

#include "hdt/cuda_build.hpp"
#include "hdt/error.hpp"
#include "hdt/host_memory.hpp"
#include "hdt/root_ranges.hpp" // checkElementLimit
#include "hdt/mesh.hpp"
#include "hdt/winding_tree.hpp"

#include <algorithm>
#include <chrono>
#include <functional>
#include <optional>
#include <string>
#include <thread>

namespace hdt {
namespace cuda {
cudaError_t probeKernelImage(); // probe.cu
} // namespace cuda

namespace {

using Clock = std::chrono::steady_clock;

uint64_t mib(uint64_t bytes) { return (bytes + (uint64_t(1) << 20) - 1) >> 20; }

// The inside test over the copied-back volume (applyInsideTest): for the
// winding number the same tree and per-leaf decision as the CPU driver
// (winding_tree.hpp, winding_leaf.hpp), with the leaves, the uniform elements
// and the children of refined elements decided on the device
// (winding_device.hpp); a leaf whose counts exceed 16 bits, and any pass the
// device has no room for, on the host. Logs where the time went.
//
// keptWords (a whole build's leaf words, left on the device by buildWhole):
// the leaf pass works on them in place (v.leafWords are unwritten until its
// result comes back); they are released after it, before refinement. When the
// pass cannot run they are copied back for the host pass.
double applyInsideTestOnDevice(cuda::Session& s, const PreparedMesh& mesh, Volume& v, const BuildOptions& options,
                               WindingTreeInBackground& tree, cuda::DeviceBuffer<uint32_t>& keptWords,
                               ProgressPoll& progress) {
  // Its arrays count against the build's budget and peak (s.memory).
  cuda::WindingDevicePass device(&s.memory);
  double uniformMs = 0;
  // Host time around the device passes: tree + walk before, then the rest.
  const auto windingStart = Clock::now();
  auto msSince = [](Clock::time_point t) { return std::chrono::duration<double, std::milli>(Clock::now() - t).count(); };
  double beforeDeviceMs = -1, uniformWallMs = 0, leavesWallMs = 0, freshMs = 0, freshWallMs = 0;
  uint64_t freshLeaves = 0, uniformBoxes = 0;
  // Called for the volume's elements, then for each level of refinement.
  const WindingUniformPass uniformPass = [&](const WindingTree& tree, const std::vector<WindingUniformJob>& jobs,
                                             std::vector<uint8_t>& verdicts) {
    if (beforeDeviceMs < 0) beforeDeviceMs = msSince(windingStart);
    const auto t0 = Clock::now();
    double ms = 0;
    const bool ran = device.uniform(tree, jobs, verdicts, &ms, &uniformBoxes);
    uniformMs += ms;
    uniformWallMs += msSince(t0);
    return ran;
  };
  const WindingFreshLeafPass freshPass = [&](const WindingTree& tree, int L,
                                             const std::vector<std::array<int, 3>>& origins, uint32_t* words,
                                             std::vector<uint32_t>& left) {
    const auto t0 = Clock::now();
    const bool ran = device.fresh(tree, L, origins, words, left, &freshMs);
    freshWallMs = msSince(t0);
    freshLeaves = origins.size() - left.size();
    return ran;
  };
  const WindingLeafPass leafPass = [&](const WindingTree& tree, Volume& vol,
                                       const std::vector<std::array<int, 3>>& origins, std::vector<uint32_t>& left) {
    cuda::WindingDeviceTimes t;
    const auto t0 = Clock::now();
    uint32_t* onDevice = keptWords.size() == vol.leafWords.size() ? keptWords.data() : nullptr;
    // The words' host pages, never written yet, faulted in while the device
    // counts and decides, not inside the copy back.
    std::thread touch;
    const auto joinTouch = [&touch] {
      if (touch.joinable()) touch.join();
    };
    const struct JoinOnExit {
      const std::function<void()> join;
      ~JoinOnExit() { join(); }
    } joinOnExit{joinTouch};
    if (onDevice)
      touch = std::thread([&vol] { cuda::touchHostParallel(vol.leafWords.data(), vol.leafWords.size() * sizeof(uint32_t)); });
    const bool ran = device.leaves(tree, vol, origins, left, &t, onDevice, joinTouch);
    joinTouch();
    if (!ran && onDevice) cuda::copyLeafWordsBack(s, vol, keptWords);
    keptWords.reset();
    leavesWallMs = msSince(t0);
    if (options.log) {
      options.log(ran ? "CUDA driver: winding pass on the device (ms): uniform " + std::to_string(uniformMs) +
                            ", leaves: upload " + std::to_string(t.upload) + ", crossings " +
                            std::to_string(t.crossings) + ", lines " + std::to_string(t.lines) + ", counts " +
                            std::to_string(t.counts) + ", decide " + std::to_string(t.decide) + " (" +
                            std::to_string(t.boxes) + " boxes; " + std::to_string(t.hardVoxels) +
                            " voxels on the host " + std::to_string(t.hardMs) + " ms), download " +
                            std::to_string(t.download) + "; " + std::to_string(left.size()) + " of " +
                            std::to_string(origins.size()) + " leaves left to the host"
                      : "CUDA driver: no device memory for the winding leaf pass; it runs on the host");
    }
    return ran;
  };
  const double windingMs = applyInsideTest(mesh, v, leafPass, uniformPass, freshPass, &tree, &progress);
  if (options.log && windingMs > 0)
    options.log("CUDA driver: winding pass " + std::to_string(msSince(windingStart)) + " ms, of which host tree (the rest of its build, started with the build) + walk " +
                std::to_string(beforeDeviceMs) + " ms, uniform passes " + std::to_string(uniformWallMs) +
                " ms (" + std::to_string(uniformBoxes) + " boxes), leaf pass " + std::to_string(leavesWallMs) + " ms, fresh leaves " + std::to_string(freshWallMs) +
                " ms (wall, allocations included; fresh kernels " + std::to_string(freshMs) + " ms, " +
                std::to_string(freshLeaves) + " leaves); " + std::to_string(v.stats.windingRefinedElements) +
                " elements refined; the device passes held at most " + std::to_string(device.peakBytes()) +
                " bytes at once");
  return windingMs;
}

Volume build(const PreparedMesh& mesh, const BuildOptions& options, CudaBuildReport& report, bool keepResult) {
  using namespace cuda;
  const auto wall0 = Clock::now();
  const GridSpec& g = mesh.grid;
  if (mesh.triangles.empty()) throw Error(ErrorKind::BadInput, "the mesh has no triangles");
  const uint64_t cells = uint64_t(g.rootGrid) * g.rootGrid * g.rootGrid;
  checkElementLimit(cells, 0, 0); // the root grid, before allocating it
  // The winding tree (a function of the triangles) built on the host while
  // the device builds the volume and copies it back.
  std::optional<WindingTreeInBackground> windingTree;
  if (keepResult) windingTree.emplace(mesh);

  Session s(mesh, options);
  // Under the winding number the device phases report into the first part
  // of the progress and the pass, many times as long, into the rest.
  constexpr double kDevicePhasesShareBeforeWinding = 0.2;
  const bool windingFollows = keepResult && windingPassFollows(mesh);
  if (windingFollows) s.progressShare = kDevicePhasesShareBeforeWinding;
  ProgressPoll windingProgress(options.progress, s.progressShare, 1.0);
  report.device = s.device;
  report.deviceName = s.deviceName;
  report.budgetBytes = s.memory.budget();
  s.progress(0.0, "mapping");

  uploadTriangles(s);

  Volume v;
  const SinkAbandonGuard abandonOnError(options.leafSink);
  bool whole = false;
  // A winding-number build's leaf words stay on the device for its leaf pass
  // (whole builds; chunked ones copy them back as they go). Holding them adds
  // nothing to that pass's peak: it would allocate as many for the upload.
  DeviceBuffer<uint32_t> keptWords;
  try {
    RootMapping root = mapTrianglesToRootCells(s.memory, s.scalars, s.deviceMesh, g, 0, cells, true);
    report.estimatedBytes = fixedBytes(mesh) + estimateBytes(mesh, root.area, root.pairs.count, cells);
    if (report.estimatedBytes <= s.memory.budget()) {
      v = buildWhole(s, std::move(root), keepResult, windingFollows ? &keptWords : nullptr);
      whole = true;
    }
  } catch (const DeviceMemoryExhausted&) {
    // Did not fit after all: everything it held is released; chunk it.
  }
  if (!whole) {
    s.sync();
    s.clock.collect(s.ms);
    try {
      v = buildChunked(s, report);
      if (options.log) {
        options.log("CUDA driver: built the root grid in " + std::to_string(report.chunks) +
                    " chunks (device memory budget " + std::to_string(mib(s.memory.budget())) +
                    " MiB, one-piece estimate " + std::to_string(mib(report.estimatedBytes)) + " MiB)");
      }
    } catch (const DeviceMemoryExhausted& e) { // the whole-mesh parts (T1) do not fit
      throw Error(ErrorKind::OutOfResources,
                  "resolution " + std::to_string(g.resolution) + " needs at least " +
                      std::to_string(mib(e.neededBytes() ? e.neededBytes() : s.memory.live())) +
                      " MiB of device memory, " + std::to_string(mib(s.memory.budget())) + " MiB available");
    }
  }

  const auto host0 = Clock::now();
  const double windingMs = keepResult ? applyInsideTestOnDevice(s, mesh, v, options, *windingTree, keptWords, windingProgress) : 0.0;
  // A whole build counted its voxels on the device (buildWhole) unless the
  // winding-number pass rewrote them on the host.
  if (!whole || (keepResult && mesh.insideTest == InsideTest::WindingNumber)) computeStructureStatistics(v);
  Statistics& st = v.stats;
  st.triangles = mesh.triangles.size();
  st.degenerateTriangles = mesh.degenerateTriangles;
  st.time.mapping = s.ms[kMapping];
  st.time.branching = s.ms[kBranching];
  st.time.leaf = s.ms[kLeaf];
  st.time.classify = s.ms[kClassify] + windingMs;
  st.time.total = st.time.mapping + st.time.branching + st.time.leaf + st.time.classify;
  st.backend = "cuda";
  st.threads = 0;
  st.peakDeviceBytes = s.memory.peak();
  st.peakHostBytes = peakResidentBytes();
  report.uploadMs = s.ms[kUpload];
  report.downloadMs = s.copyBackMs;
  report.downloadBytes = s.copyBackBytes;
  if (windingFollows) {
    windingProgress.report(1.0, "done");
  } else {
    s.progress(1.0, "done");
  }
  report.hostMs = std::chrono::duration<double, std::milli>(Clock::now() - host0).count();
  report.wallMs = std::chrono::duration<double, std::milli>(Clock::now() - wall0).count();
  return v;
}

} // namespace

bool cudaAvailable(std::string* why) {
  int count = 0;
  cudaError_t e = cudaGetDeviceCount(&count);
  if (e == cudaSuccess && count == 0) e = cudaErrorNoDevice;
  if (e == cudaSuccess) e = cuda::probeKernelImage(); // kernels built for this GPU?
  if (e != cudaSuccess) {
    cudaGetLastError();
    if (why) *why = std::string("no usable CUDA device: ") + cudaGetErrorString(e);
    return false;
  }
  return true;
}

int cudaDeviceCount() {
  int count = 0;
  if (cudaGetDeviceCount(&count) != cudaSuccess) {
    cudaGetLastError();
    return 0;
  }
  return count;
}

namespace {

// The user's error for a device allocation that did not fit; `where` names
// the step (" in ...") or is empty.
Error outOfDeviceMemory(const cuda::DeviceMemoryExhausted& e, const std::string& where) {
  return Error(ErrorKind::OutOfResources, "out of device memory" + where + " (needed at least " +
                                              std::to_string(mib(e.neededBytes())) + " MiB, " +
                                              std::to_string(mib(e.availableBytes())) + " MiB available)");
}

} // namespace

Volume buildCudaWithReport(const PreparedMesh& mesh, const BuildOptions& options, CudaBuildReport* report,
                           bool keepResult) {
  CudaBuildReport local;
  try {
    Volume v = build(mesh, options, report ? *report : local, keepResult);
    return v;
  } catch (const cuda::DeviceMemoryExhausted& e) { // never escapes: say what was missing
    throw outOfDeviceMemory(e, "");
  }
}

Volume buildCuda(const PreparedMesh& mesh, const BuildOptions& options) {
  return buildCudaWithReport(mesh, options, nullptr, true);
}

double applyInsideTestCuda(const PreparedMesh& mesh, Volume& volume, const BuildOptions& options) {
  if (!windingPassFollows(mesh)) return applyInsideTestAfterCpuPhases(mesh, volume, options.progress); // records the test
  WindingTreeInBackground tree(mesh);
  try {
    cuda::Session s(mesh, options);
    ProgressPoll progress(options.progress, kCpuPhasesShareBeforeWinding, 1.0);
    cuda::DeviceBuffer<uint32_t> noKeptWords; // the words come from the host volume
    const double ms = applyInsideTestOnDevice(s, mesh, volume, options, tree, noKeptWords, progress);
    progress.report(1.0, "done");
    return ms;
  } catch (const cuda::DeviceMemoryExhausted& e) {
    throw outOfDeviceMemory(e, " in the winding-number pass");
  }
}

namespace {

// A tetrahedron, closed or with one face missing (open meshes take the
// three-axis classification path).
TriangleMesh warmUpMesh(bool closed) {
  TriangleMesh m;
  m.points = {0, 0, 0, 1, 0, 0, 0, 1, 0, 0, 0, 1};
  m.triangles = {0, 2, 1, 0, 1, 3, 1, 2, 3};
  if (closed) m.triangles.insert(m.triangles.end(), {0, 3, 2});
  return m;
}

} // namespace

void prepareCuda(const BuildConfig& config, const BuildOptions& options,
                 const std::function<bool()>& meshKnownClosed) {
  try {
    if (!cudaAvailable(nullptr)) return;
    cuda::DeviceGuard guard(options.device);
    // Pinning the staging ring takes tens of ms of the driver's time, the
    // memory pool and the kernels' loading as much again: side by side.
    std::thread pinning([device = options.device] {
      try {
        cuda::DeviceGuard here(device);
        cuda::reserveCopyStaging();
      } catch (...) {
        cudaGetLastError(); // copyToHost pins (or falls back) itself
      }
    });
    struct Join {
      std::thread& t;
      ~Join() { t.join(); }
    } join{pinning};
    {
      cuda::Stream stream;
      const uint64_t free = cuda::DeviceMemory::obtainable(options.device);
      cuda::DeviceMemory::prefill(options.device, stream.get(), std::min<uint64_t>(uint64_t(1) << 30, free / 4));
    }
    // Builds of the same kind load the kernels they launch (lazy module
    // loading) and set up what a session does once.
    BuildConfig small = config;
    small.resolution = config.rootGrid * config.leafSize * 2;
    small.hasBounds = false;
    BuildOptions quiet;
    quiet.device = options.device;
    const auto warmUpBuild = [&](bool closed) {
      buildCudaWithReport(prepareMesh(warmUpMesh(closed), small), quiet, nullptr, true);
    };
    warmUpBuild(true);
    if (!config.surfaceOnly && !(meshKnownClosed && meshKnownClosed())) warmUpBuild(false);
  } catch (...) {
    cudaGetLastError(); // the real build reports what is wrong
  }
}

} // namespace hdt
