// hdt_e2e_bench: one mesh file to one .hdt file, as hdt-voxelize does it, with
// every step timed: read, prepare, build (device phases, copy back), write,
// wall, and the process's peak host memory (so: one run per process).
//
// usage: hdt_e2e_bench MESH --res N [--mode surface|solid] [--backend cpu|cuda]
//                      [--subdivide K] [--hdt OUT.hdt] [--cold] [--warm-check]
//                      [--out runs.jsonl]
//   --cold        no hdt::prepareCuda on a thread while reading (the first
//                 build is then a cold one)
//   --warm-check  after the run, a second build (nothing copied back) whose
//                 device phase time is the warm reference for the first
//   --prepare-repeat K  after the run, K more preparations of the same mesh in
//                 this process (warm: threads up, memory reused): the best
//   --no-stream   the leaf blocks compressed by the writer after the build,
//                 not while the copy back brings them (HdtLeafEncoder)
//   --no-warm-host  no startHostThreads + reserveWarmPages beside the read (as
//                 hdt-voxelize does: 4x the file's bytes + 8 MiB, the file taken
//                 4^K times larger for --subdivide K)
//   --no-reserve  no warm pages for the leaf words (the memory estimate's,
//                 beside prepareCuda; not with --cold)
//   --no-release  no hdt::releaseCuda beside the write
//   --write-breakdown  after the run, the writer's parts: the same encoding
//                 into memory (checks + zstd blocks), the same as version 2's
//                 one zstd frame, and a file without compression
#include "hdt/builder.hpp"
#include "hdt/cuda_build.hpp"
#include "hdt/hdt_file.hpp"
#include "hdt/mesh.hpp"
#include "hdt/mesh_io.hpp"
#include "hdt/warm_pages.hpp"

#include "subdivide.hpp"

#include <sys/resource.h>
#include <sys/stat.h>

#include <atomic>
#include <chrono>
#include <cstdio>
#include <filesystem>
#include <future>
#include <ctime>
#include <fstream>
#include <iostream>
#include <sstream>
#include <string>
#include <thread>

namespace {

using namespace hdt;
using Clock = std::chrono::steady_clock;

struct Args {
  std::string mesh, hdt = "/tmp/hdt_e2e.hdt", out = "e2e-runs.jsonl";
  int res = 1024, subdivide = 0, prepareRepeat = 0;
  bool surfaceOnly = false, cuda = true, cold = false, warmCheck = false, writeBreakdown = false, stream = true;
  bool warmHost = true, reserve = true, release = true;
};

Args parse(int argc, char** argv) {
  Args a;
  for (int i = 1; i < argc; ++i) {
    const std::string k = argv[i];
    auto value = [&]() -> std::string {
      if (i + 1 >= argc) throw std::runtime_error("missing value after " + k);
      return argv[++i];
    };
    if (k == "--res") a.res = std::stoi(value());
    else if (k == "--mode") a.surfaceOnly = value() == "surface";
    else if (k == "--backend") a.cuda = value() == "cuda";
    else if (k == "--subdivide") a.subdivide = std::stoi(value());
    else if (k == "--hdt") a.hdt = value();
    else if (k == "--out") a.out = value();
    else if (k == "--cold") a.cold = true;
    else if (k == "--warm-check") a.warmCheck = true;
    else if (k == "--write-breakdown") a.writeBreakdown = true;
    else if (k == "--no-stream") a.stream = false;
    else if (k == "--no-warm-host") a.warmHost = false;
    else if (k == "--no-reserve") a.reserve = false;
    else if (k == "--no-release") a.release = false;
    else if (k == "--prepare-repeat") a.prepareRepeat = std::stoi(value());
    else if (!k.empty() && k[0] != '-' && a.mesh.empty()) a.mesh = k;
    else throw std::runtime_error("unknown argument " + k);
  }
  if (a.mesh.empty()) throw std::runtime_error("a mesh file is required");
  return a;
}

std::string num(double v);

std::string partsJson(const PrepareTimes& p) {
  return "{\"bounds\": " + num(p.bounds) + ", \"numbers\": " + num(p.numbers) +
         ", \"closed_and_duplicates\": " + num(p.closedAndDuplicates) + "}";
}

double msSince(Clock::time_point& t) {
  const Clock::time_point now = Clock::now();
  const double ms = std::chrono::duration<double, std::milli>(now - t).count();
  t = now;
  return ms;
}

uint64_t peakResidentBytes() {
  struct rusage usage {};
  return getrusage(RUSAGE_SELF, &usage) == 0 ? uint64_t(usage.ru_maxrss) * 1024 : 0;
}

std::string today() {
  const std::time_t t = std::time(nullptr);
  char b[32];
  std::strftime(b, sizeof b, "%Y-%m-%dT%H:%M:%SZ", std::gmtime(&t));
  return b;
}

std::string num(double x) {
  char b[64];
  std::snprintf(b, sizeof b, "%.3f", x);
  return b;
}

} // namespace

int main(int argc, char** argv) {
  Args a;
  try {
    a = parse(argc, argv);
  } catch (const std::exception& e) {
    std::cerr << "hdt_e2e_bench: " << e.what() << "\n";
    return 2;
  }
  std::ostringstream j;
  const std::string name = a.mesh.substr(a.mesh.find_last_of('/') + 1) +
                           (a.subdivide ? " (subdivided x" + std::to_string(1 << (2 * a.subdivide)) + ")" : "");
  j << "{\"mesh\": \"" << name << "\", \"resolution\": " << a.res << ", \"surface_only\": "
    << (a.surfaceOnly ? "true" : "false") << ", \"backend\": \"" << (a.cuda ? "cuda" : "cpu")
    << "\", \"cold\": " << (a.cold ? "true" : "false") << ", \"streamed_write\": " << (a.stream ? "true" : "false")
    << ", \"warm_host\": " << (a.warmHost ? "true" : "false") << ", \"reserve\": " << (a.reserve && a.cuda && !a.cold ? "true" : "false")
    << ", \"release\": " << (a.release && a.cuda ? "true" : "false")
    << ", \"date\": \"" << today()
    << "\", \"host_threads\": " << std::thread::hardware_concurrency();
  try {
    BuildConfig config;
    config.resolution = a.res;
    config.surfaceOnly = a.surfaceOnly;
    config.insideTest = InsideTest::Parity; // comparable with the earlier runs (Auto is the default since)
    BuildOptions options;
    options.backend = a.cuda ? Backend::Cuda : Backend::Cpu;
    if (a.cuda) setCudaPoolRetention(UINT64_MAX); // the warm check reuses the pool
    const Clock::time_point start = Clock::now();
    Clock::time_point t = start;
    std::thread warmUp;
    std::atomic<bool> meshClosed{false}; // as hdt-voxelize: no open-mesh warm-up once known closed
    if (a.cuda && !a.cold) warmUp = std::thread([&] { prepareCuda(config, options, [&] { return meshClosed.load(); }); });
    std::thread hostWarmUp;
    if (a.warmHost) {
      std::error_code error;
      const uint64_t fileBytes = uint64_t(std::filesystem::file_size(a.mesh, error)) << (2 * a.subdivide);
      const uint64_t bytes = error ? 0 : std::min<uint64_t>(uint64_t(1) << 30, 4 * fileBytes + (uint64_t(8) << 20));
      hostWarmUp = std::thread([bytes] {
        startHostThreads();
        reserveWarmPages(bytes);
        keepHostThreadsAwake(1000); // until prepareMesh
      });
    }
    TriangleMesh mesh = readMesh(a.mesh);
    for (int k = 0; k < a.subdivide; ++k) mesh = subdivide(mesh);
    const double readMs = msSince(t);
    if (hostWarmUp.joinable()) hostWarmUp.join();
    const double hostWarmUpWaitMs = msSince(t);
    const WarmPagesState warmBefore = warmPagesState();
    PrepareTimes prepareParts;
    const PreparedMesh prepared = prepareMesh(mesh, config, &prepareParts);
    if (prepared.closed) meshClosed.store(true);
    const double prepareOnlyMs = msSince(t);
    trimWarmPages();
    TriangleMesh kept = a.prepareRepeat > 0 ? std::move(mesh) : TriangleMesh();
    mesh = TriangleMesh();
    const double prepareMs = prepareOnlyMs + msSince(t);
    // As hdt-voxelize: the memory estimate beside the device's set-up, its
    // leaf words reserved as warm pages; the build waits for them.
    const bool reserve = a.reserve && a.cuda && !a.cold;
    std::future<double> estimate;
    if (reserve)
      estimate = std::async(std::launch::async, [&prepared] {
        const double bytes = estimateHostMemory(prepared).leafGrids * leafWordCount(prepared.grid.leafSize) * 4.0;
        if (bytes > 0 && bytes <= double(uint64_t(4) << 30)) reserveWarmPages(size_t(bytes));
        return bytes;
      });
    if (warmUp.joinable()) warmUp.join();
    const double warmUpWaitMs = msSince(t);
    const double leafEstimateBytes = reserve ? estimate.get() : 0;
    const double reserveWaitMs = msSince(t);
    const WarmPagesState warmAtBuild = warmPagesState();
    CudaBuildReport report;
    HdtLeafEncoder streamed;
    if (a.stream) options.leafSink = &streamed;
    const Volume v = a.cuda ? buildCudaWithReport(prepared, options, &report, true) : build(prepared, options);
    struct StopStreaming { // the blocks' tasks read v: they end before it is freed
      HdtLeafEncoder& leaves;
      ~StopStreaming() { leaves.abandon(); }
    } stopStreaming{streamed};
    const double buildWallMs = msSince(t);
    trimWarmPages();
    std::thread release;
    if (a.release && a.cuda && !a.warmCheck) release = std::thread([&] { releaseCuda(options); });
    writeHdt(v, a.hdt, HdtWriteOptions{}, &streamed);
    options.leafSink = nullptr;
    const double writeMs = msSince(t);
    if (release.joinable()) release.join();
    const double releaseWaitMs = msSince(t);
    const double wallMs = std::chrono::duration<double, std::milli>(Clock::now() - start).count();
    struct stat st {};
    stat(a.hdt.c_str(), &st);
    const Statistics& s = v.stats;
    j << ", \"gpu\": \"" << report.deviceName << "\", \"triangles\": " << s.triangles
      << ", \"leaf_grids\": " << s.leafGrids << ", \"leaf_bytes\": " << s.leafBytes << ", \"read_ms\": " << num(readMs)
      << ", \"prepare_ms\": " << num(prepareMs) << ", \"warm_up_wait_ms\": " << num(warmUpWaitMs)
      << ", \"build_phases_ms\": " << num(s.time.total) << ", \"build_wall_ms\": " << num(buildWallMs)
      << ", \"copy_back_ms\": " << num(report.downloadMs) << ", \"copy_back_bytes\": " << report.downloadBytes
      << ", \"copy_back_gb_per_s\": " << num(report.downloadMs > 0 ? report.downloadBytes / report.downloadMs / 1e6 : 0)
      << ", \"chunks\": " << report.chunks << ", \"write_ms\": " << num(writeMs) << ", \"file_bytes\": " << st.st_size
      << ", \"wall_ms\": " << num(wallMs) << ", \"peak_host_bytes\": " << peakResidentBytes()
      << ", \"peak_device_bytes\": " << s.peakDeviceBytes << ", \"prepare_parts_ms\": " << partsJson(prepareParts)
      << ", \"prepare_only_ms\": " << num(prepareOnlyMs) << ", \"host_warm_up_wait_ms\": " << num(hostWarmUpWaitMs)
      << ", \"warm_bytes_at_prepare\": " << warmBefore.reserved << ", \"leaf_estimate_bytes\": " << num(leafEstimateBytes)
      << ", \"warm_bytes_at_build\": " << warmAtBuild.reserved << ", \"reserve_wait_ms\": " << num(reserveWaitMs)
      << ", \"release_wait_ms\": " << num(releaseWaitMs);
    if (a.prepareRepeat > 0) { // the same preparation again in this process: the best of K
      PrepareTimes best;
      double bestMs = 1e300;
      for (int k = 0; k < a.prepareRepeat; ++k) {
        Clock::time_point p = Clock::now();
        PrepareTimes parts;
        prepareMesh(kept, config, &parts);
        const double ms = msSince(p);
        if (ms < bestMs) bestMs = ms, best = parts;
      }
      j << ", \"prepare_repeat\": " << a.prepareRepeat << ", \"prepare_best_ms\": " << num(bestMs)
        << ", \"prepare_best_parts_ms\": " << partsJson(best);
    }
    if (a.writeBreakdown) {
      Clock::time_point w = Clock::now();
      const size_t bytes = serializeHdt(v).size();
      j << ", \"serialize_ms\": " << num(msSince(w)) << ", \"serialize_bytes\": " << bytes;
      HdtWriteOptions oneFrame; // version 2's one zstd frame (multi-threaded zstd), for comparison
      oneFrame.leafBlocks = false;
      const size_t oneFrameBytes = serializeHdt(v, oneFrame).size();
      j << ", \"serialize_one_frame_ms\": " << num(msSince(w)) << ", \"serialize_one_frame_bytes\": " << oneFrameBytes;
      HdtWriteOptions level1; // the fastest level, for comparison with the default
      level1.zstdLevel = 1;
      const size_t level1Bytes = serializeHdt(v, level1).size();
      j << ", \"serialize_level1_ms\": " << num(msSince(w)) << ", \"serialize_level1_bytes\": " << level1Bytes;
      HdtWriteOptions raw;
      raw.compressLeaves = false;
      writeHdt(v, a.hdt, raw);
      j << ", \"write_raw_ms\": " << num(msSince(w));
      std::remove(a.hdt.c_str());
    }
    if (a.warmCheck && a.cuda) {
      const Volume warm = buildCudaWithReport(prepared, options, &report, false);
      j << ", \"warm_build_phases_ms\": " << num(warm.stats.time.total);
    }
  } catch (const std::exception& e) {
    std::string what = e.what();
    for (char& c : what)
      if (c == '"' || c == '\\') c = '\'';
    j << ", \"error\": \"" << what << "\"";
  }
  j << "}";
  std::ofstream(a.out, std::ios::app) << j.str() << "\n";
  std::cout << j.str() << std::endl;
  return 0;
}
