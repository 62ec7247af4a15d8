// prepareMesh's first call in a fresh process, set up as hdt-voxelize and hdt_e2e_bench do it:
// startHostThreads + reserveWarmPages on a thread while the mesh is read (and subdivided K
// times), then prepareMesh timed with its steps, the minor page faults and context switches of
// the call (getrusage), then the best of REPS more calls. CPU only (no CUDA), so one tree's
// binary can be built anywhere and timed on the GPU machine's cores (bench/gpu/prepare_first.sh).
//   prepare_first MESH.ply K REPS [cold|warm|sleep|wake] [TRIANGLES]
// warm: as hdt-voxelize (keepHostThreadsAwake after the pages, until prepareMesh or 1 s);
// rehearse: as warm, and a small grid mesh prepared on the warm-up thread before the workers are
// kept awake (untimed, beside the read); retouch: as warm, and the warm pages prepareMesh takes written once more just before it, untimed;
// sleep: as warm without keepHostThreadsAwake (the workers fall asleep during the read);
// cold: no warm-up thread (threads and pages at first use); wake: as sleep, and startHostThreads
// again just before the first call, untimed (how much of that call is waking the threads up:
// after the read they have slept for its length); TRIANGLES: only the first TRIANGLES
// triangles of the subdivided mesh and the points they use (in their order), e.g. exactly 350 K.
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
// The first `count` triangles of m and the points they refer to, in the points' order.
static TriangleMesh firstTriangles(const TriangleMesh& m, size_t count) {
  if (count >= m.triangleCount()) return m;
  std::vector<uint32_t> index(m.pointCount(), UINT32_MAX);
  for (size_t i = 0; i < 3 * count; ++i) index[m.triangles[i]] = 0;
  TriangleMesh out;
  for (size_t p = 0; p < m.pointCount(); ++p) {
    if (index[p] == UINT32_MAX) continue;
    index[p] = uint32_t(out.pointCount());
    out.points.insert(out.points.end(), m.points.begin() + ptrdiff_t(3 * p), m.points.begin() + ptrdiff_t(3 * p + 3));
  }
  for (size_t i = 0; i < 3 * count; ++i) out.triangles.push_back(index[m.triangles[i]]);
  return out;
}

static void steps(const char* tag, double t, const PrepareTimes& p) {
  printf(" \"%s_ms\": %.3f, \"%s_steps\": [%.3f, %.3f, %.3f],", tag, t, tag, p.bounds, p.numbers,
         p.closedAndDuplicates);
}

int main(int argc, char** argv) {
  if (argc < 4) return 2;
  const int k = atoi(argv[2]), reps = atoi(argv[3]);
  const bool cold = argc > 4 && !strcmp(argv[4], "cold"), wake = argc > 4 && !strcmp(argv[4], "wake");
  const bool sleep = wake || (argc > 4 && !strcmp(argv[4], "sleep"));
  const bool retouch = argc > 4 && !strcmp(argv[4], "retouch");
  const bool rehearse = argc > 4 && !strcmp(argv[4], "rehearse");
  const size_t cut = argc > 5 ? size_t(atoll(argv[5])) : SIZE_MAX;
  const Clock::time_point start = Clock::now();
  std::thread warm;
  if (!cold) {
    const uint64_t fileBytes = uint64_t(std::filesystem::file_size(argv[1])) << (2 * k);
    const uint64_t bytes = std::min<uint64_t>(uint64_t(1) << 30, 4 * fileBytes + (uint64_t(8) << 20));
    warm = std::thread([bytes, sleep, rehearse] {
      startHostThreads();
      reserveWarmPages(bytes);
      if (rehearse) { // a grid of 2 x 200^2 triangles prepared once beside the read (is the first call's code cold?)
        TriangleMesh g;
        const uint32_t n = 200;
        for (uint32_t i = 0; i <= n; ++i)
          for (uint32_t j = 0; j <= n; ++j) g.points.insert(g.points.end(), {double(i), double(j), double((i * j) % 7)});
        for (uint32_t i = 0; i < n; ++i)
          for (uint32_t j = 0; j < n; ++j) {
            const uint32_t a = i * (n + 1) + j;
            g.triangles.insert(g.triangles.end(), {a, a + 1, a + n + 1, a + 1, a + n + 2, a + n + 1});
          }
        BuildConfig small;
        small.resolution = 1024;
        prepareMesh(g, small);
      }
      if (!sleep) keepHostThreadsAwake(1000);
    });
  }
  TriangleMesh m = readMesh(argv[1]);
  for (int i = 0; i < k; ++i) m = subdivide(m);
  m = firstTriangles(m, cut);
  const Clock::time_point read = Clock::now();
  if (warm.joinable()) warm.join();
  const Clock::time_point ready = Clock::now();
  BuildConfig c;
  c.resolution = 8192;
  PrepareTimes first;
  if (wake) startHostThreads();
  if (retouch) { // the warm pages prepareMesh will take written again, untimed (are they cold in cache?)
    std::vector<uint8_t, HugePageScratchAllocator<uint8_t>> pages(prepareMeshWarmBytes(m.triangleCount(), m.pointCount()));
    memset(pages.data(), 1, pages.size());
  }
  const rusage u0 = usage();
  const Clock::time_point t0 = Clock::now();
  PreparedMesh p = prepareMesh(m, c, &first);
  const Clock::time_point t1 = Clock::now();
  const rusage u1 = usage();
  trimWarmPages();
  printf("{\"mesh\": \"%s\", \"subdivide\": %d, \"triangles\": %zu, \"points\": %zu, \"cold\": %d, \"sleep\": %d, \"wake\": %d, \"read_ms\": %.2f, \"warm_wait_ms\": %.2f,",
         argv[1], k, m.triangleCount(), m.pointCount(), int(cold), int(sleep), int(wake), ms(start, read), ms(read, ready));
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
