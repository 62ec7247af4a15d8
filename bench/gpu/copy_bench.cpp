// hdt_copy_bench: what bounds the copy back of a volume from the device to
// fresh pageable host memory (issue 18). Times variants of the copy on the
// same device buffer, interleaved over repetitions, each into a fresh
// destination (malloc: new pages, as a Volume's leaf grids), and prints one
// JSON line a run:
//   pinned       one DMA into a pinned buffer (the link's speed; no host copy)
//   pageable     the driver's own pageable path (cudaMemcpy)
//   touch        host only: first touch of the fresh destination (parallel memset)
//   hostcopy     host only: parallel memcpy from a pinned buffer into the fresh destination
//   ring         the staging ring: S slots of P MiB, the copy out on T threads (0: all);
//                +prefault: the destination faulted in (parallel) before the copy, counted
//   (registering the destination, whole or piece by piece ahead of its DMA, was
//   measured at 2-13 GB/s on 2026-11-24 and dropped: bench/results/end-to-end.md)
//
// usage: hdt_copy_bench [--mb 400,3600] [--reps 3] [--out copy-runs.jsonl]
//        hdt_copy_bench --probe WHAT   a process that makes a context and WHAT (ctx: nothing
//        more; none: no CUDA at all; reset: the context torn down by cudaDeviceReset, timed;
//        pin: 64 MiB pinned; dev: 1 GiB cudaMalloc; pool: 1 GiB through the stream-ordered
//        pool, kept; all: pin and pool), prints the ms from main() to ready and to the end of
//        main(); the caller times the process (the rest: start and exit, context tear-down)
//   ring_new_SxP  host_copy.cpp's copy (copyThroughRing) through S slots of P MiB; copyToHost:
//                 the process-wide ring as the driver uses it
#include "host_copy.hpp"

#include <cuda_runtime.h>

#include <tbb/global_control.h>
#include <tbb/parallel_for.h>
#include <tbb/task_arena.h>

#include <sys/mman.h>
#include <unistd.h>

#include <algorithm>
#include <chrono>
#include <cstdint>
#include <cstdio>
#include <cstdlib>
#include <cstring>
#include <fstream>
#include <functional>
#include <iostream>
#include <sstream>
#include <string>
#include <thread>
#include <vector>

namespace {

using Clock = std::chrono::steady_clock;

void check(cudaError_t e, const char* what) {
  if (e != cudaSuccess) {
    std::fprintf(stderr, "%s: %s\n", what, cudaGetErrorString(e));
    std::exit(1);
  }
}

double msSince(Clock::time_point t0) {
  return std::chrono::duration<double, std::milli>(Clock::now() - t0).count();
}

void advise(void* p, size_t bytes) {
  const size_t huge = size_t(2) << 20;
  const uintptr_t b = (reinterpret_cast<uintptr_t>(p) + huge - 1) & ~uintptr_t(huge - 1);
  const uintptr_t e = (reinterpret_cast<uintptr_t>(p) + bytes) & ~uintptr_t(huge - 1);
  if (e > b) madvise(reinterpret_cast<void*>(b), e - b, MADV_HUGEPAGE);
}

void prefault(void* p, size_t bytes) {
#if defined(MADV_POPULATE_WRITE)
  const uintptr_t page = 4096, piece = uintptr_t(1) << 20;
  const uintptr_t b = (reinterpret_cast<uintptr_t>(p) + page - 1) & ~(page - 1);
  const uintptr_t e = (reinterpret_cast<uintptr_t>(p) + bytes) & ~(page - 1);
  tbb::parallel_for(b, e, piece, [&](uintptr_t q) {
    madvise(reinterpret_cast<void*>(q), std::min(piece, e - q), MADV_POPULATE_WRITE);
  });
#else
  (void)p;
  (void)bytes;
#endif
}

void parallelCopy(uint8_t* dst, const uint8_t* src, size_t bytes, size_t task) {
  tbb::parallel_for(size_t(0), (bytes + task - 1) / task, [&](size_t i) {
    const size_t b = i * task, e = std::min(bytes, b + task);
    std::memcpy(dst + b, src + b, e - b);
  });
}

struct Ring {
  int slots;
  size_t piece;
  std::vector<uint8_t*> buf;
  std::vector<cudaEvent_t> ev;
  Ring(int s, size_t p) : slots(s), piece(p), buf(s), ev(s) {
    for (int i = 0; i < s; ++i) {
      check(cudaMallocHost(reinterpret_cast<void**>(&buf[i]), p), "cudaMallocHost ring");
      check(cudaEventCreateWithFlags(&ev[i], cudaEventDisableTiming), "event");
    }
  }
};

// The staging ring of host_copy.cpp, parameterised.
void ringCopy(Ring& r, cudaStream_t st, uint8_t* dst, const uint8_t* src, size_t bytes, size_t task) {
  const size_t pieces = (bytes + r.piece - 1) / r.piece;
  auto pb = [&](size_t k) { return std::min(r.piece, bytes - k * r.piece); };
  auto enqueue = [&](size_t k) {
    const int i = int(k % r.slots);
    check(cudaMemcpyAsync(r.buf[i], src + k * r.piece, pb(k), cudaMemcpyDeviceToHost, st), "ring dma");
    check(cudaEventRecord(r.ev[i], st), "record");
  };
  for (size_t k = 0; k < std::min<size_t>(pieces, r.slots); ++k) enqueue(k);
  for (size_t k = 0; k < pieces; ++k) {
    const int i = int(k % r.slots);
    check(cudaEventSynchronize(r.ev[i]), "sync");
    parallelCopy(dst + k * r.piece, r.buf[i], pb(k), task);
    if (k + r.slots < pieces) enqueue(k + r.slots);
  }
}

std::string fileText(const char* path) {
  std::ifstream f(path);
  std::string s;
  std::getline(f, s);
  return s;
}

} // namespace

int main(int argc, char** argv) {
  std::vector<size_t> mbs = {400, 3600};
  int reps = 3;
  std::string out = "copy-runs.jsonl";
  for (int i = 1; i + 1 < argc; i += 2) {
    const std::string k = argv[i], v = argv[i + 1];
    if (k == "--mb") {
      mbs.clear();
      std::stringstream ss(v);
      std::string x;
      while (std::getline(ss, x, ',')) mbs.push_back(std::stoul(x));
    } else if (k == "--reps") reps = std::stoi(v);
    else if (k == "--out") out = v;
  }
  if (argc == 3 && std::string(argv[1]) == "--probe") {
    const auto t0 = Clock::now();
    const std::string what = argv[2];
    if (what == "none") { // the process without CUDA
      std::printf("probe none\n");
      return 0;
    }
    check(cudaFree(nullptr), "probe context");
    const double contextMs = msSince(t0);
    void* h = nullptr;
    void* d = nullptr;
    if (what == "pin" || what == "all") check(cudaMallocHost(&h, size_t(64) << 20), "probe pinned");
    if (what == "dev") check(cudaMalloc(&d, size_t(1) << 30), "probe device");
    if (what == "pool" || what == "all") {
      cudaMemPool_t pool;
      check(cudaDeviceGetDefaultMemPool(&pool, 0), "pool");
      uint64_t keep = UINT64_MAX;
      check(cudaMemPoolSetAttribute(pool, cudaMemPoolAttrReleaseThreshold, &keep), "pool attr");
      cudaStream_t st;
      check(cudaStreamCreate(&st), "probe stream");
      check(cudaMallocAsync(&d, size_t(1) << 30, st), "probe pool");
      check(cudaFreeAsync(d, st), "probe pool free");
      check(cudaStreamSynchronize(st), "probe sync");
    }
    check(cudaDeviceSynchronize(), "probe sync");
    const double readyMs = msSince(t0);
    double resetMs = 0;
    if (what == "reset") { // the context's tear-down, in the process
      const auto r0 = Clock::now();
      check(cudaDeviceReset(), "probe reset");
      resetMs = msSince(r0);
    }
    std::printf("probe %s: context %.1f ms, ready %.1f ms, reset %.1f ms\n", what.c_str(), contextMs, readyMs, resetMs);
    std::fflush(stdout);
    return 0;
  }
  const size_t maxBytes = *std::max_element(mbs.begin(), mbs.end()) * 1000000;
  cudaDeviceProp prop{};
  check(cudaGetDeviceProperties(&prop, 0), "props");
  uint8_t* dev = nullptr;
  check(cudaMalloc(reinterpret_cast<void**>(&dev), maxBytes), "cudaMalloc");
  check(cudaMemset(dev, 0x5a, maxBytes), "memset");
  uint8_t* pinned = nullptr;
  check(cudaMallocHost(reinterpret_cast<void**>(&pinned), maxBytes), "pinned");
  std::memset(pinned, 1, maxBytes);
  cudaStream_t st;
  check(cudaStreamCreateWithFlags(&st, cudaStreamNonBlocking), "stream");
  const size_t MiB = size_t(1) << 20;
  for (size_t mib : {64, 128}) { // what pinning the ring costs (prepareCuda does it at start)
    const auto t0 = Clock::now();
    void* p = nullptr;
    check(cudaMallocHost(&p, mib * MiB), "pin");
    std::printf("pin %zu MiB: %.1f ms\n", mib, msSince(t0));
    cudaFreeHost(p);
  }
  Ring r4x16(4, 16 * MiB), r8x16(8, 16 * MiB), r4x64(4, 64 * MiB), r8x32(8, 32 * MiB),
      r3x4(3, 4 * MiB);
  check(cudaDeviceSynchronize(), "sync");

  struct Variant {
    std::string name;
    std::function<void(uint8_t*, size_t)> run;
    bool hostOnly = false;
  };
  auto ringV = [&](Ring& r, size_t task, bool pre, int threads) -> std::function<void(uint8_t*, size_t)> {
    return [&r, task, pre, threads, st, dev](uint8_t* dst, size_t bytes) {
      advise(dst, bytes);
      auto go = [&] {
        if (pre) prefault(dst, bytes);
        ringCopy(r, st, dst, dev, bytes, task);
      };
      if (threads > 0) {
        tbb::task_arena arena(threads);
        arena.execute(go);
      } else {
        go();
      }
    };
  };
  auto newRing = [&](Ring& r, int threads = 0) -> std::function<void(uint8_t*, size_t)> {
    return [&r, threads, st, dev](uint8_t* dst, size_t bytes) {
      const hdt::cuda::StagingRing ring{r.slots, r.piece, r.buf.data(), r.ev.data()};
      auto go = [&] { hdt::cuda::copyThroughRing(ring, st, dst, dev, bytes); };
      if (threads > 0) {
        tbb::task_arena arena(threads);
        arena.execute(go);
      } else {
        go();
      }
    };
  };
  std::vector<Variant> variants = {
      {"pinned", [&](uint8_t*, size_t bytes) {
         check(cudaMemcpyAsync(pinned, dev, bytes, cudaMemcpyDeviceToHost, st), "pinned");
         check(cudaStreamSynchronize(st), "s");
       }},
      {"pinned_16MiB_calls", [&](uint8_t*, size_t bytes) {
         for (size_t o = 0; o < bytes; o += 16 * MiB)
           check(cudaMemcpyAsync(pinned + o, dev + o, std::min(16 * MiB, bytes - o), cudaMemcpyDeviceToHost, st), "p16");
         check(cudaStreamSynchronize(st), "s");
       }},
      {"touch", [&](uint8_t* dst, size_t bytes) {
         advise(dst, bytes);
         tbb::parallel_for(size_t(0), (bytes + MiB - 1) / MiB, [&](size_t i) {
           std::memset(dst + i * MiB, 0, std::min(MiB, bytes - i * MiB));
         });
       }, true},
      {"prefault_madvise", [&](uint8_t* dst, size_t bytes) { advise(dst, bytes); prefault(dst, bytes); }, true},
      {"hostcopy", [&](uint8_t* dst, size_t bytes) { advise(dst, bytes); parallelCopy(dst, pinned, bytes, MiB); }, true},
      {"hostcopy_new", [&](uint8_t* dst, size_t bytes) { hdt::cuda::copyHostParallel(dst, pinned, bytes); }, true},
      {"ring_4x16_t1M", ringV(r4x16, MiB, false, 0)},
      {"ring_4x64_t2M", ringV(r4x64, 2 * MiB, false, 0)},
      {"ring_4x16_t1M_prefault", ringV(r4x16, MiB, true, 0)},
      {"ring_new_4x16", newRing(r4x16)},
      {"ring_new_8x16", newRing(r8x16)},
      {"ring_new_8x32", newRing(r8x32)},
      {"ring_new_4x64", newRing(r4x64)},
      {"ring_new_3x4", newRing(r3x4)},
      {"ring_new_4x16_8thr", newRing(r4x16, 8)},
      {"copyToHost", [&](uint8_t* dst, size_t bytes) { hdt::cuda::copyToHost(st, dst, dev, bytes); }},
  };
  // warm the thread pool and the driver's paths once
  {
    uint8_t* d = static_cast<uint8_t*>(std::malloc(64 * MiB));
    for (auto& v : variants) v.run(d, 64 * MiB);
    std::free(d);
  }
  const std::string thp = fileText("/sys/kernel/mm/transparent_hugepage/enabled");
  std::ofstream jl(out, std::ios::app);
  for (int rep = 0; rep < reps; ++rep) {
    for (size_t mb : mbs) {
      const size_t bytes = mb * 1000000;
      for (auto& v : variants) {
        uint8_t* dst = static_cast<uint8_t*>(std::malloc(bytes)); // fresh pages (mmap)
        const auto t0 = Clock::now();
        v.run(dst, bytes);
        const double ms = msSince(t0);
        bool ok = true;
        if (!v.hostOnly && v.name.rfind("pinned", 0) != 0)
          for (size_t o = 0; o < bytes; o += 4093 * 17) ok = ok && dst[o] == 0x5a;
        std::free(dst);
        std::ostringstream j;
        j << "{\"variant\": \"" << v.name << "\", \"bytes\": " << bytes << ", \"rep\": " << rep << ", \"ms\": " << ms
          << ", \"gb_per_s\": " << bytes / ms / 1e6 << ", \"ok\": " << (ok ? "true" : "false") << ", \"gpu\": \""
          << prop.name << "\", \"threads\": " << std::thread::hardware_concurrency() << ", \"thp\": \"" << thp
          << "\"}";
        jl << j.str() << "\n";
        std::printf("%-26s %6zu MB rep %d %8.1f ms %6.2f GB/s%s\n", v.name.c_str(), mb, rep, ms, bytes / ms / 1e6,
                    ok ? "" : " WRONG");
      }
    }
  }
  return 0;
}
