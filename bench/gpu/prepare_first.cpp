// prepareMesh's first call in a fresh process, set up as hdt-voxelize and hdt_e2e_bench do it:
// startHostThreads + reserveWarmPages on a thread while the mesh is read (and subdivided K
// times), then prepareMesh timed with its steps, the minor page faults and context switches of
// the call (getrusage), then the best of REPS more calls. CPU only (no CUDA), so one tree's
// binary can be built anywhere and timed on the GPU machine's cores (bench/gpu/prepare_first.sh).
//   prepare_first MESH.ply K REPS [cold]   cold: no warm-up thread (threads and pages at first use)
#include "hdt/mesh.hpp"
#include "hdt/mesh_io.hpp"
#include "hdt/warm_pages.hpp"
#include "subdivide.hpp"

#include <sys/resource.h>

#include <algorithm>
#include <chrono>
#include <cstdio>
#include <cstdlib>
#include <cstring>
#include <filesystem>
#include <thread>

using namespace hdt;
using Clock = std::chrono::steady_clock;

static double ms(Clock::time_point a, Clock::time_point b) { return std::chrono::duration<double, std::milli>(b - a).count(); }
static rusage usage() {
  rusage u{};
  getrusage(RUSAGE_SELF, &u);
  return u;
}
static void steps(const char* tag, double t, const PrepareTimes& p) {
  printf(" \"%s_ms\": %.3f, \"%s_steps\": [%.3f, %.3f, %.3f, %.3f, %.3f],", tag, t, tag, p.bounds, p.snap, p.numbers,
         p.kept, p.closedAndDuplicates);
}

int main(int argc, char** argv) {
  if (argc < 4) return 2;
  const int k = atoi(argv[2]), reps = atoi(argv[3]);
  const bool cold = argc > 4 && !strcmp(argv[4], "cold");
  const Clock::time_point start = Clock::now();
  std::thread warm;
  if (!cold) {
    const uint64_t fileBytes = uint64_t(std::filesystem::file_size(argv[1])) << (2 * k);
    const uint64_t bytes = std::min<uint64_t>(uint64_t(1) << 30, 4 * fileBytes + (uint64_t(8) << 20));
    warm = std::thread([bytes] {
      startHostThreads();
      reserveWarmPages(bytes);
    });
  }
  TriangleMesh m = readMesh(argv[1]);
  for (int i = 0; i < k; ++i) m = subdivide(m);
  const Clock::time_point read = Clock::now();
  if (warm.joinable()) warm.join();
  const Clock::time_point ready = Clock::now();
  BuildConfig c;
  c.resolution = 8192;
  PrepareTimes first;
  const rusage u0 = usage();
  const Clock::time_point t0 = Clock::now();
  PreparedMesh p = prepareMesh(m, c, &first);
  const Clock::time_point t1 = Clock::now();
  const rusage u1 = usage();
  trimWarmPages();
  printf("{\"mesh\": \"%s\", \"subdivide\": %d, \"triangles\": %zu, \"cold\": %d, \"read_ms\": %.2f, \"warm_wait_ms\": %.2f,",
         argv[1], k, m.triangleCount(), int(cold), ms(start, read), ms(read, ready));
  steps("first", ms(t0, t1), first);
  printf(" \"first_minflt\": %ld, \"first_nvcsw\": %ld, \"first_nivcsw\": %ld,", u1.ru_minflt - u0.ru_minflt,
         u1.ru_nvcsw - u0.ru_nvcsw, u1.ru_nivcsw - u0.ru_nivcsw);
  double best = 1e30;
  PrepareTimes bp;
  long bestFaults = 0;
  for (int r = 0; r < reps; ++r) {
    PrepareTimes pt;
    const rusage a = usage();
    const Clock::time_point t = Clock::now();
    PreparedMesh q = prepareMesh(m, c, &pt);
    const double e = ms(t, Clock::now());
    const rusage b = usage();
    if (e < best) best = e, bp = pt, bestFaults = b.ru_minflt - a.ru_minflt;
  }
  steps("best", best, bp);
  printf(" \"best_minflt\": %ld, \"kept\": %zu, \"closed\": %d, \"duplicates\": %zu}\n", bestFaults, p.triangles.size(),
         int(p.closed), p.duplicateTriangles);
}
