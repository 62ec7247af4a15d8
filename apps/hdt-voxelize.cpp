// hdt-voxelize: mesh file -> HDT volume (.hdt), optional dense NRRD, statistics.
//
//   readMesh / builtinMesh -> prepareMesh -> build -> writeHdt / writeNrrd -> report
//
// Statistics go to stdout (a table, or one JSON object with --json); progress,
// warnings, notes and errors go to stderr. Exit codes follow hdt::ErrorKind:
// 2 for a bad command line or option, 3 for a bad mesh file, 4 when memory or
// the device runs out, 5 when an output file cannot be written, 1 for anything
// unexpected. Outputs are checked before the build and written atomically.
#include "cli_mpi.hpp"
#include "cli_options.hpp"
#include "cli_report.hpp"
#include "joining_thread.hpp"

#include "hdt/atomic_file.hpp"
#include "hdt/builder.hpp"
#include "hdt/dense.hpp"
#include "hdt/device_pool.hpp"
#include "hdt/error.hpp"
#include "hdt/hdt_file.hpp"
#include "hdt/labels.hpp"
#include "hdt/host_memory.hpp"
#include "hdt/mesh_io.hpp"
#include "hdt/range_exchange.hpp"
#include "hdt/warm_pages.hpp"

#include <signal.h>
#include <unistd.h>

#include <algorithm>
#include <atomic>
#include <chrono>
#include <cmath>
#include <cstdio>
#include <filesystem>
#include <future>
#include <iostream>
#include <memory>
#include <new>
#include <thread>

namespace hdt::cli {
namespace {

using Clock = std::chrono::steady_clock;

// Progress on stderr. On a terminal one line that rewrites itself; on a pipe
// or file plain lines, and only once the build has taken a second, so that
// short runs in scripts and tests print nothing.
class ProgressLine {
public:
  explicit ProgressLine(bool enabled) : enabled_(enabled), tty_(::isatty(STDERR_FILENO) == 1) {}
  ~ProgressLine() { clear(); } // an error message then starts on a clean line
  ProgressLine(const ProgressLine&) = delete;
  ProgressLine& operator=(const ProgressLine&) = delete;

  bool update(double fraction, const char* phase) {
    if (!enabled_ || (!tty_ && Clock::now() - start_ < std::chrono::seconds(1))) return true;
    const int percent = int(std::lround(100 * std::clamp(fraction, 0.0, 1.0)));
    if (percent == percent_ && phase == phase_) return true;
    percent_ = percent;
    phase_ = phase;
    if (tty_) {
      std::fprintf(stderr, "\r\033[K%s %d%%", phase, percent);
      open_ = true;
    } else {
      std::fprintf(stderr, "%s %d%%\n", phase, percent);
    }
    std::fflush(stderr);
    return true; // never abort
  }

  // A note from the library (e.g. which backend Auto chose).
  void note(const std::string& text) {
    if (!enabled_) return;
    clear();
    std::fprintf(stderr, "hdt-voxelize: %s\n", text.c_str());
  }

  void clear() {
    if (!open_) return;
    std::fputs("\r\033[K", stderr);
    std::fflush(stderr);
    open_ = false;
  }

private:
  const bool enabled_, tty_;
  const Clock::time_point start_ = Clock::now();
  int percent_ = -1;
  std::string phase_;
  bool open_ = false;
};

// Runs f; an hdt::Error from it gets "<subject>: " in front, so that every
// message names the file (or builtin mesh) it is about.
template <class F>
auto about(const std::string& subject, F&& f) -> decltype(f()) {
  try {
    return f();
  } catch (const Error& e) {
    const std::string what = e.what();
    if (what.rfind(subject + ":", 0) == 0) throw; // already named
    throw Error(e.kind(), subject + ": " + what);
  }
}

TriangleMesh loadMesh(const std::string& spec, const MeshLabelSource& labels, std::vector<MeshArray>& arrays) {
  const std::string prefix = "builtin:";
  if (spec.rfind(prefix, 0) != 0) return readMesh(spec, labels, arrays);
  if (!arrays.empty()) throw Error(ErrorKind::InvalidArgument, "--transfer needs a PLY file");
  TriangleMesh mesh = builtinMesh(spec.substr(prefix.size()));
  if (labels.kind == MeshLabelSource::Kind::Components) labelConnectedComponents(mesh);
  else if (labels.kind != MeshLabelSource::Kind::None)
    throw Error(ErrorKind::InvalidArgument, "built-in meshes can be labelled by components only");
  return mesh;
}

// Before any work: every output can be created, and none is the input mesh.
// (A missing directory found after a long build wastes the build.)
void checkOutputs(const Options& options) {
  for (const std::string* path : {&options.hdtPath, &options.densePath, &options.denseLabelsPath}) {
    if (path->empty()) continue;
    if (sameExistingFile(*path, options.mesh)) {
      throw Error(ErrorKind::InvalidArgument, *path + ": is the input mesh; refusing to overwrite it");
    }
    checkOutputWritable(*path);
  }
}

HdtWriteOptions hdtWriteOptions(const Options& options) {
  HdtWriteOptions w;
  w.zstdLevel = options.compressionLevel;
  return w;
}

// Writes -o and --dense to temporary files and renames them into place only
// when both are complete: a failed --dense leaves no new -o file behind.
// `streamed`: the leaf blocks compressed during the build's copy back.
void writeOutputs(const Options& options, const Volume& volume, HdtLeafEncoder& streamed) {
  std::unique_ptr<AtomicFile> hdt, dense, labels;
  if (!options.hdtPath.empty()) {
    hdt = std::make_unique<AtomicFile>(options.hdtPath);
    about(options.hdtPath, [&] { writeHdt(volume, *hdt, hdtWriteOptions(options), &streamed); });
  }
  if (!options.densePath.empty()) {
    dense = std::make_unique<AtomicFile>(options.densePath);
    about(options.densePath, [&] { writeNrrd(volume, *dense); });
  }
  if (!options.denseLabelsPath.empty()) {
    labels = std::make_unique<AtomicFile>(options.denseLabelsPath);
    about(options.denseLabelsPath, [&] { writeLabelNrrd(volume, *labels); });
  }
  if (hdt) hdt->commit();
  if (dense) dense->commit();
  if (labels) labels->commit();
}

double msSince(Clock::time_point& t) {
  const Clock::time_point now = Clock::now();
  const double ms = std::chrono::duration<double, std::milli>(now - t).count();
  t = now;
  return ms;
}

// hdt::prepareCuda on a thread, for the CUDA and Auto backends.
// hasDevice() says soon (before the context exists) whether a device is
// there, so that work meant for device builds can start beside the set-up.
class WarmUp {
public:
  explicit WarmUp(const Options& o) : hasDevice_(deviceSeen_.get_future().share()) {
    if (o.build.backend == Backend::Cpu) {
      deviceSeen_.set_value(false);
      return;
    }
    thread_ = JoiningThread([this, &o] {
      deviceSeen_.set_value(cudaDeviceCount() > 0);
      prepareCuda(o.config, o.build, [this] { return meshClosed_.load(); });
    });
  }
  std::shared_future<bool> hasDevice() const { return hasDevice_; }
  // The prepared mesh is closed: the set-up, if it has not got there yet,
  // skips its open-mesh warm-up build (the device's set-up outlasts the read
  // and prepare, so this usually takes that build off the critical path).
  void meshIsClosed() { meshClosed_.store(true); }
  WarmUp(const WarmUp&) = delete; // the thread holds `this`
  WarmUp& operator=(const WarmUp&) = delete;
  void join() { thread_.join(); }

private:
  std::promise<bool> deviceSeen_;
  std::shared_future<bool> hasDevice_;
  std::atomic<bool> meshClosed_{false};
  JoiningThread thread_; // last: joined before the promise goes
};

// oneTBB's workers started and prepareMesh's memory faulted in on a thread
// while the mesh is read, so that prepareMesh runs as a warm call. The size
// comes from the file's: binary PLY takes at least 13 bytes a triangle and
// prepareMesh about 70 (points included), so 4x the file covers it; text
// formats take more bytes a triangle. Capped: a large file's slack is given
// back after prepareMesh (trimWarmPages).
JoiningThread startHostWarmUp(const std::string& meshPath) {
  std::error_code error;
  const uintmax_t fileBytes = meshPath.rfind("builtin:", 0) == 0 ? 0 : std::filesystem::file_size(meshPath, error);
  const uint64_t cap = std::min<uint64_t>(uint64_t(1) << 30, availableHostBytes() / 8);
  const uint64_t bytes = error ? 0 : std::min<uint64_t>(cap, 4 * uint64_t(fileBytes) + (uint64_t(8) << 20));
  return JoiningThread([bytes] {
    startHostThreads();
    reserveWarmPages(bytes);
    // Until prepareMesh. Not on a machine of few cores: there the spinning
    // workers take the cores the reader and CUDA's set-up need (a read on 2
    // cores took up to 4x as long, bench/results/end-to-end.md).
    if (std::thread::hardware_concurrency() >= 8) keepHostThreadsAwake(1000);
  });
}

// The leaf words' bytes of the memory estimate, reserved as warm pages while
// the device gets ready (the copy back then writes faulted-in memory), unless
// they are more than a few GiB (faulting them in would outlast the device's
// set-up) or an eighth of the memory left. A labelled build's leaf words
// are the same; its mixed leaves' voxel labels, copied back after them, are
// at most a quarter of their size (2 bits a voxel) but for wide leaves (few):
// a quarter more, taken only by arrays of a sixteenth or more (not the
// small ones allocated meanwhile).
void reserveLeafWords(const HostMemoryEstimate& e, const GridSpec& grid, bool labelled) {
  const double bytes = e.leafGrids * leafWordCount(grid.leafSize) * sizeof(uint32_t);
  const double cap = std::min(double(uint64_t(4) << 30), double(availableHostBytes()) / 8);
  if (bytes <= 0 || bytes > cap) return;
  if (labelled) reserveWarmPages(size_t(bytes * 1.25), size_t(bytes / 16));
  else reserveWarmPages(size_t(bytes));
}

double unixMs() {
  return std::chrono::duration<double, std::milli>(std::chrono::system_clock::now().time_since_epoch()).count();
}

int run(int argc, const char* const* argv, const MpiSession& session, Clock::time_point start, double unixAtStart) {
  const Options options = parseOptions(argc, argv);
  if (options.help) {
    std::cout << usageText();
    return 0;
  }
  // Refuse bad sizes before any work (the message lists the nearest valid resolutions).
  validateConfig(options.config);
  if ((!options.densePath.empty() || !options.denseLabelsPath.empty()) &&
      options.config.resolution > kMaxDenseResolution) {
    throw Error(ErrorKind::InvalidArgument, "--dense needs N^3 bytes and is limited to N <= " +
                                                std::to_string(kMaxDenseResolution) + " (got N = " +
                                                std::to_string(options.config.resolution) + ")");
  }
  checkOutputs(options);

  Report report;
  report.mesh = options.mesh;
  // The device's context, kernels and memory pool get ready while the mesh
  // is read, so that the build is not a cold one.
  WarmUp warmUp(options);
  JoiningThread hostWarmUp = startHostWarmUp(options.mesh);
  Clock::time_point t = Clock::now();
  std::vector<MeshArray> arrays;
  for (const std::string& name : options.transfer) arrays.push_back(MeshArray{name, ArraySource::Point, 0, {}});
  TriangleMesh mesh = about(options.mesh, [&] { return loadMesh(options.mesh, options.labels, arrays); });
  report.io.read = msSince(t);
  hostWarmUp.join(); // long done: the read takes longer
  PreparedMesh prepared = about(options.mesh, [&] { return prepareMesh(mesh, options.config); });
  const bool labelled = options.labels.kind != MeshLabelSource::Kind::None;
  // A labelled mesh of one part in one process: its plain build, labelled
  // afterwards (labelAsOnePart; `prepared` is on the grid voxelizeLabelled places).
  const Label onlyPart = labelled && session.size() == 1 ? onlyLabel(mesh) : kOutsideLabel;
  const bool onePart = onlyPart != kOutsideLabel;
  // Of several, the parts are prepared here, as the whole mesh is: the build
  // starts from prepared meshes, labelled or not.
  LabelledParts parts;
  if (labelled && !onePart) parts = about(options.mesh, [&] { return prepareLabelledParts(mesh, options.config); });
  trimWarmPages(); // what prepareMesh did not use
  if (prepared.closed && (!labelled || onePart)) warmUp.meshIsClosed(); // a labelled build's parts may be open
  if (!labelled && arrays.empty()) mesh = TriangleMesh(); // the lattice copy is all the build needs; labelled builds split the mesh
  report.io.prepare = msSince(t);
  // The report's memory estimate rasterises the mesh (tens to hundreds of ms
  // at 8192^3): it runs beside the device's set-up and the build, not after
  // the write. For a device build in one process its leaf words are reserved
  // as warm pages meanwhile, and the build waits for them (a labelled
  // build's too: the combined leaf words are those of the plain build).
  const bool reserve = options.build.backend != Backend::Cpu && session.size() == 1;
  // releaseCuda gives the device back beside the write (below): the build
  // keeps its pool rather than trimming it inside the timed build as it ends
  // (a labelled build's pool is large: bench/results/labels-gpu.md).
  if (reserve) setCudaPoolRetention(UINT64_MAX);
  // Auto builds on the device only when there is one (the count comes before the context).
  const bool deviceAsked = options.build.backend == Backend::Cuda;
  std::future<uint64_t> hostBytesEstimate; // rank 0 reports
  if (session.rank() == 0)
    hostBytesEstimate = std::async(std::launch::async, [&prepared, reserve, labelled, onePart, deviceAsked,
                                                        hasDevice = warmUp.hasDevice()] {
      const HostMemoryEstimate e = estimateHostMemory(prepared);
      if (reserve && (deviceAsked || hasDevice.get())) reserveLeafWords(e, prepared.grid, labelled && !onePart);
      return e.total;
    });
  t = Clock::now();
  warmUp.join();
  report.io.deviceWait = msSince(t);
  if (reserve && hostBytesEstimate.valid() && (deviceAsked || warmUp.hasDevice().get())) hostBytesEstimate.wait();
  report.io.reserveWait = msSince(t);

  ProgressLine progress(!options.quiet && session.rank() == 0);
  BuildOptions build = options.build;
  build.progress = [&](double fraction, const char* phase) { return progress.update(fraction, phase); };
  build.log = [&](const std::string& text) { progress.note(text); };
  // -o's leaf blocks are compressed while the CUDA driver copies them back.
  HdtLeafEncoder streamedLeaves(hdtWriteOptions(options));
  if (!options.hdtPath.empty() && !labelled && session.size() == 1) build.leafSink = &streamedLeaves;
  t = Clock::now();
  Volume volume = about(options.mesh, [&] {
    if (labelled && !onePart) // every rank builds it whole
      return voxelizeLabelled(prepared, parts, mesh.labelNames, build, options.overlap);
    if (onePart) {
      Volume v = hdt::build(prepared, build);
      labelAsOnePart(v, onlyPart, mesh.labelNames);
      return v;
    }
    return session.size() > 1 ? buildAcrossRanks(session, prepared, build, &report.ranks) : hdt::build(prepared, build);
  });
  // The streamed blocks' tasks read the volume: they end before it is freed,
  // on every path out of here (after the write they have ended already).
  struct StopStreaming {
    HdtLeafEncoder& leaves;
    ~StopStreaming() { leaves.abandon(); }
  } stopStreaming{streamedLeaves};
  progress.clear();
  report.io.build = msSince(t);
  trimWarmPages(); // the estimate's excess
  // The device's tear-down (tens of ms at the exit) beside the host's work.
  JoiningThread release;
  if (options.build.backend != Backend::Cpu && session.size() == 1)
    release = JoiningThread([&options] { releaseCuda(options.build); });
  if (session.rank() != 0) return 0; // rank 0 has the joined volume and writes
  t = Clock::now();
  about(options.mesh, [&] { transferArrays(mesh, arrays, volume); }); // a host pass after the build
  report.io.transfer = msSince(t);
  report.warnings = buildWarnings(prepared, volume);
  if (!options.quiet) {
    for (const std::string& w : report.warnings)
      std::fprintf(stderr, "hdt-voxelize: warning: %s: %s\n", options.mesh.c_str(), w.c_str());
  }

  t = Clock::now();
  writeOutputs(options, volume, streamedLeaves);
  report.hdtPath = options.hdtPath;
  report.densePath = options.densePath;
  report.denseLabelsPath = options.denseLabelsPath;
  report.labelled = labelled;
  if (labelled) {
    report.labels = labelStatistics(volume);
    report.labelBytes = labelFieldBytes(volume);
  }
  report.duplicateTriangles = prepared.duplicateTriangles;
  report.requestedInsideTest = prepared.requestedInsideTest;
  report.io.write = msSince(t);
  report.hostBytesEstimate = hostBytesEstimate.get();
  report.io.estimateWait = msSince(t);
  release.join();
  report.io.releaseWait = msSince(t);
  report.io.sinceStart = std::chrono::duration<double, std::milli>(t - start).count();
  report.io.unixAtMain = unixAtStart;
  report.io.unixAtReport = unixMs();

  report.volume = &volume;
  if (options.json) writeJson(std::cout, report);
  else writeTable(std::cout, report);
  std::cout.flush();
  return std::cout ? 0 : 1;
}

int exitCode(ErrorKind kind) {
  switch (kind) {
  case ErrorKind::InvalidArgument: return 2;
  case ErrorKind::BadInput: return 3;
  case ErrorKind::OutOfResources: return 4;
  case ErrorKind::Aborted: return 1;
  case ErrorKind::OutputFailed: return 5;
  }
  return 1;
}

} // namespace
} // namespace hdt::cli

int main(int argc, char** argv) {
  using namespace hdt::cli;
  const auto start = std::chrono::steady_clock::now();
  const double unixAtStart = unixMs();
  // Past a file-size limit (ulimit -f) a write fails with EFBIG instead of
  // killing the process, so the error is reported and the temporary removed.
  ::signal(SIGXFSZ, SIG_IGN);
  MpiSession session(argc, argv); // one rank unless built with HDT_WITH_MPI and run by mpiexec
  // Across ranks an error on one rank ends them all (the others would wait forever).
  auto failed = [&](int code) { return session.size() > 1 ? (session.abort(code), code) : code; };
  try {
    return run(argc, argv, session, start, unixAtStart);
  } catch (const UsageError& e) {
    std::fprintf(stderr, "hdt-voxelize: %s\nTry 'hdt-voxelize --help'.\n", e.what());
    return failed(2);
  } catch (const hdt::Error& e) {
    std::fprintf(stderr, "hdt-voxelize: error: %s\n", e.what());
    return failed(exitCode(e.kind()));
  } catch (const std::bad_alloc&) {
    std::fprintf(stderr, "hdt-voxelize: error: out of memory\n");
    return failed(4);
  } catch (const std::exception& e) {
    std::fprintf(stderr, "hdt-voxelize: internal error: %s\n", e.what());
    return failed(1);
  }
}
