// prepare A/B driver (bench/gpu/prepare_ab.sh): on one mesh (subdivided K times), prepareMesh
// once and then REPS times more in this process; wall ms of the first call and the best, with
// the steps (bounds/numbers/closed+duplicates; "-" where the tree has no numbering step).
#include "hdt/mesh.hpp"
#include "hdt/mesh_io.hpp"
#include "subdivide.hpp"
#include <chrono>
#include <cstdio>
#include <cstdlib>
using namespace hdt;
static void print(const char* tag, double ms, const PrepareTimes& p) {
#ifdef HAS_NUMBERS
  printf(" %s %.2f (%.2f/%.2f/%.2f)", tag, ms, p.bounds, p.numbers, p.closedAndDuplicates);
#else // a tree from before the point numbering
  printf(" %s %.2f (%.2f/-/%.2f)", tag, ms, p.bounds, p.closedAndDuplicates);
#endif
}
int main(int argc, char** argv) {
  TriangleMesh m = readMesh(argv[1]);
  const int k = atoi(argv[2]), reps = atoi(argv[3]);
  for (int i = 0; i < k; ++i) m = subdivide(m);
  BuildConfig c;
  c.resolution = 1024;
  double best = 1e30;
  PrepareTimes bp;
  size_t dup = 0, kept = 0; bool closed = false;
  for (int r = 0; r <= reps; ++r) {
    PrepareTimes pt;
    auto t = std::chrono::steady_clock::now();
    PreparedMesh p = prepareMesh(m, c, &pt);
    const double ms = std::chrono::duration<double, std::milli>(std::chrono::steady_clock::now() - t).count();
    if (r == 0) { printf("%s x%d %zu tris:", argv[1], 1 << (2 * k), m.triangleCount()); print("first", ms, pt); dup = p.duplicateTriangles; kept = p.triangles.size(); closed = p.closed; }
    else if (ms < best) best = ms, bp = pt;
  }
  print("best", best, bp);
  printf(" | kept %zu closed %d dup %zu\n", kept, int(closed), dup);
}
