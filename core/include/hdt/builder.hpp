// Building an HDT from a prepared mesh: the driver interface.
//
// Both drivers (CPU here, CUDA in cuda/) follow the paper's phases and return
// the same Volume, byte for byte, for the same input.
#pragma once

#include "hdt/mesh.hpp"
#include "hdt/volume.hpp"

#include <atomic>
#include <functional>
#include <string>

namespace hdt {

enum class Backend { Auto, Cpu, Cuda };

// The most CPU threads a build may ask for: oneTBB caps its workers near
// max(256, 4 x cores) anyway, and far larger counts crash its arena set-up.
constexpr int kMaxCpuThreads = 256;

// Throws Error(InvalidArgument) unless 0 <= threads <= kMaxCpuThreads.
void validateThreads(int threads);

// A consumer of the leaf grids while a driver copies them into the volume:
// begin() once the volume's leaf array exists, then arrived(n) each time words
// [0, n) of it hold their final value (n grows; the last call has n = count).
// Calls come from the driver's threads, one at a time. When the build fails
// after begin(), abandon() comes before the words are freed: the sink stops
// reading them before it returns. The CUDA driver feeds it from its copy back
// for one-piece builds whose leaves nothing rewrites on the host (not the
// winding-number test); the CPU driver, labelled and chunked builds never
// call it. Used by the .hdt writer (HdtLeafEncoder).
class LeafArrivalSink {
public:
  virtual ~LeafArrivalSink() = default;
  virtual void begin(const uint32_t* words, size_t count) = 0;
  virtual void arrived(size_t count) = 0;
  virtual void abandon() = 0;
};

struct BuildOptions {
  Backend backend = Backend::Auto;
  int threads = 0;     // CPU threads, 0 to kMaxCpuThreads; 0 = what oneTBB sees (cores, affinity)
  int device = 0;      // CUDA device ordinal
  // Device memory budget in bytes for the CUDA driver (0 = what is free).
  // Smaller budgets make it build the root grid in chunks.
  uint64_t deviceMemoryBudget = 0;
  // Host memory the caller will need beside the volume (the VTK filter's
  // hyper tree grid): added to estimateHostBytes when the CPU driver checks
  // that the build fits.
  uint64_t extraHostBytes = 0;
  // Called between steps with a fraction in [0, 1] and the phase name, and
  // (CPU driver) about every 50 ms inside long phases; always on the thread
  // that called build().
  // Returning false aborts the build (Error with ErrorKind::Aborted).
  std::function<bool(double fraction, const char* phase)> progress;
  // Informational messages: the path a build took and its times.
  std::function<void(const std::string&)> log;
  // A fallback the caller should hear of (a device that failed and left the
  // build to the CPU driver); unset, these go to `log` too.
  std::function<void(const std::string&)> warn;
  void warning(const std::string& text) const {
    if (warn) warn(text);
    else if (log) log(text);
  }
  // Not owned; may be null. See LeafArrivalSink.
  LeafArrivalSink* leafSink = nullptr;
};

// CPU driver (oneTBB).
Volume buildCpu(const PreparedMesh& mesh, const BuildOptions& options);

// True when this build has the CUDA driver and a usable device is present;
// `why` receives the reason when not.
bool cudaAvailable(std::string* why = nullptr);

// CUDA devices this process sees (0 without the CUDA driver or a device):
// ranks of a distributed build pick device (local rank mod count).
int cudaDeviceCount();

// CUDA driver; throws Error(OutOfResources) on device failures.
Volume buildCuda(const PreparedMesh& mesh, const BuildOptions& options);

// Readies the CUDA driver for builds like `config` on options.device (the
// context, the kernels such builds launch, the memory pool and the pinned
// copy-back staging), so that the first build of a process is as fast as a
// warm one. Takes tens of milliseconds: call it early, e.g. on a thread while
// the mesh is read. Does nothing without a usable device; never throws.
// The open-mesh kernels are loaded after the closed-mesh ones, unless the
// build is surface-only (both run the same kernels) or meshKnownClosed, asked
// at that point, says true: a caller that has prepared its mesh by then
// (PreparedMesh::closed) spares the device's set-up that build.
void prepareCuda(const BuildConfig& config, const BuildOptions& options,
                 const std::function<bool()>& meshKnownClosed = {});

// Ends this process's use of the CUDA device options.device now: its memory
// pool, pinned staging and context (cudaDeviceReset), which the process's exit
// would otherwise tear down (tens of ms). For a process whose builds are done,
// e.g. on a thread while it writes its files (hdt-voxelize); nothing may use
// the device meanwhile, and a later build starts cold. Never throws; does
// nothing without the CUDA driver.
void releaseCuda(const BuildOptions& options);

// Dispatches on options.backend. Auto runs CUDA when available and the CPU
// driver otherwise (saying so once through options.log), and falls back to
// the CPU driver if the device fails.
Volume build(const PreparedMesh& mesh, const BuildOptions& options);

// The inside test of a volume whose driver phases ran without it: the ranks
// of a distributed build under the winding number build surfaces only, and
// the process that joins them classifies the whole (apps/cli_mpi.cpp,
// filters/vtkHDTDistributedBuild.cxx). Backend Cuda runs the CUDA driver's
// device passes on options.device (a pass the device has no room for runs on
// the host, as in buildCuda); Auto does so where cudaAvailable() and runs the
// host pass otherwise; Cpu runs the host pass. The same bytes either way.
// Reports to options.progress from kCpuPhasesShareBeforeWinding on, then
// "done". Returns the pass's milliseconds (0 when the mesh's test is not the
// winding number: nothing to do).
double applyInsideTestAfterPhases(const PreparedMesh& mesh, Volume& volume, const BuildOptions& options);

// Options for applyInsideTestAfterPhases on the process that joined a
// distributed build: the driver its own range build ended on (`device`:
// RootRangeBuild::device(), -1 for the CPU driver), so a process whose device
// failed in its build, or that had none, runs the pass on the host.
BuildOptions insideTestOptionsAfterRangeBuild(const BuildOptions& rangeOptions, int device);

// The CUDA part of applyInsideTestAfterPhases; throws Error like buildCuda
// (no device, a device failure).
double applyInsideTestCuda(const PreparedMesh& mesh, Volume& volume, const BuildOptions& options);

// Convenience: prepare + build.
Volume voxelize(const TriangleMesh& mesh, const BuildConfig& config, const BuildOptions& options);

// Host memory a CPU build and the .hdt write after it are expected to need at
// most (peak resident set), modelled part by part from the grid and the
// mesh's projected surface area (core/src/memory_estimate.cpp; measured
// against real peaks in bench/results/memory-estimate.md). Used to refuse
// builds that cannot fit before allocating.
struct HostMemoryEstimate {
  double leafGrids = 0;     // expected leaf grids
  double leafPairs = 0;     // expected (leaf, triangle) pairs
  uint64_t rootGrid = 0;    // R^3 cells: element words, coordinates, uniform list
  uint64_t tree = 0;        // octree levels below the root grid
  uint64_t leaves = 0;      // leaf states and the classification's per-leaf rows
  uint64_t pairs = 0;       // (element, triangle) pairs and their sort
  uint64_t triangles = 0;   // the prepared mesh
  uint64_t compression = 0; // writing the .hdt: zstd's output buffer
  uint64_t winding = 0;     // the winding-number test's tree and per-leaf row counts (0 under parity)
  uint64_t total = 0;       // the peak: reading, build and write buffer add up (freed memory stays resident)
};
HostMemoryEstimate estimateHostMemory(const PreparedMesh& mesh);
uint64_t estimateHostBytes(const PreparedMesh& mesh); // estimateHostMemory(mesh).total

} // namespace hdt
