// Times the winding tree's host build (buildWindingTree, buildWindingEdges)
// on meshes, with a hash of the whole tree (nodes, triangles, lattice, edges,
// groups) to check that two builds of it agree bit for bit.
//
//   hdt_winding_tree_bench [--res N] [--runs K] [--threads T] [--label L] mesh.ply...
//
// One JSON line per mesh and run on stdout: buildWindingTree's wall and
// process CPU time (the edges built beside the nodes), then a second call of
// buildWindingEdges alone, and the hash. With --runs 1 a process times one
// cold build (fresh memory, as one hdt-voxelize run); later runs of a process
// may reuse memory that malloc kept. Compiled against two core libraries it is an A/B of two trees
// (bench/results/winding.md, "The winding tree's host build").
#include "hdt/mesh.hpp"
#include "hdt/mesh_io.hpp"
#include "hdt/winding_tree.hpp"

#include <tbb/global_control.h>

#include <chrono>
#include <cstdint>
#include <cstdio>
#include <cstdlib>
#include <cstring>
#include <ctime>
#include <memory>
#include <string>
#include <vector>

namespace {

double msSince(std::chrono::steady_clock::time_point t) {
  return std::chrono::duration<double, std::milli>(std::chrono::steady_clock::now() - t).count();
}

// CPU time of the whole process (all threads): on a machine shared with other
// work, less noisy than the wall time, and the sum of the threads' work.
double cpuMs() {
  timespec ts;
  clock_gettime(CLOCK_PROCESS_CPUTIME_ID, &ts);
  return ts.tv_sec * 1e3 + ts.tv_nsec * 1e-6;
}

} // namespace

int main(int argc, char** argv) {
  int res = 8192, runs = 5, threads = 0;
  std::string label = "x";
  std::vector<std::string> meshes;
  for (int i = 1; i < argc; ++i) {
    const std::string a = argv[i];
    if (a == "--res" && i + 1 < argc) res = std::atoi(argv[++i]);
    else if (a == "--runs" && i + 1 < argc) runs = std::atoi(argv[++i]);
    else if (a == "--threads" && i + 1 < argc) threads = std::atoi(argv[++i]);
    else if (a == "--label" && i + 1 < argc) label = argv[++i];
    else meshes.push_back(a);
  }
  std::unique_ptr<tbb::global_control> limit;
  if (threads > 0) limit = std::make_unique<tbb::global_control>(tbb::global_control::max_allowed_parallelism, threads);
  for (const std::string& path : meshes) {
    hdt::BuildConfig c;
    c.resolution = res;
    c.rootGrid = 8;
    c.leafSize = 8;
    c.insideTest = hdt::InsideTest::WindingNumber;
    const hdt::PreparedMesh m = hdt::prepareMesh(hdt::readMesh(path), c);
    const std::string name = path.substr(path.find_last_of('/') + 1);
    for (int r = 0; r < runs; ++r) {
      auto t0 = std::chrono::steady_clock::now();
      double c0 = cpuMs();
      const hdt::WindingTree tree = hdt::buildWindingTree(m.triangles);
      const double treeMs = msSince(t0), treeCpu = cpuMs() - c0;
      hdt::WindingTree edgesOnly;
      t0 = std::chrono::steady_clock::now();
      c0 = cpuMs();
      hdt::buildWindingEdges(m.triangles, edgesOnly);
      const double edgesMs = msSince(t0), edgesCpu = cpuMs() - c0;
      std::printf("{\"label\": \"%s\", \"mesh\": \"%s\", \"triangles\": %zu, \"res\": %d, \"threads\": %d, \"run\": %d, "
                  "\"tree_ms\": %.3f, \"edges_ms\": %.3f, \"tree_cpu_ms\": %.3f, \"edges_cpu_ms\": %.3f, \"nodes\": %zu, \"edges\": %zu, \"hash\": \"%016llx\"}\n",
                  label.c_str(), name.c_str(), m.triangles.size(), res, threads, r, treeMs, edgesMs, treeCpu, edgesCpu, tree.nodes.size(),
                  tree.edges.size(), static_cast<unsigned long long>(hdt::windingTreeDigest(tree)));
      std::fflush(stdout);
    }
  }
}
