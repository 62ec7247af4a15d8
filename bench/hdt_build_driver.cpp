// hdt_build_driver: a bare internal driver for hdt::buildCpu, printing the same
// JSON keys as `hdt-voxelize --json`. It exists for profiling (perf record) and
// for trying the benchmark before the CLI is there; the published tables come
// from the CLI (bench/run_cpu_bench.sh), and its lines are tagged
// "tool": "hdt-cpu-driver" so they are never mistaken for CLI runs.
//
//   hdt_build_driver MESH --resolution N [--surface-only] [--threads T] [--backend cpu] [--json]
#include "hdt/builder.hpp"
#include "hdt/error.hpp"
#include "hdt/mesh.hpp"
#include "hdt/mesh_io.hpp"

#include <sys/resource.h>

#include <cstdlib>
#include <iostream>
#include <sstream>
#include <string>

int main(int argc, char** argv) {
  std::string path;
  hdt::BuildConfig config;
  hdt::BuildOptions options;
  options.backend = hdt::Backend::Cpu;
  for (int i = 1; i < argc; ++i) {
    const std::string a = argv[i];
    if ((a == "--resolution" || a == "--threads") && i + 1 < argc) {
      (a == "--resolution" ? config.resolution : options.threads) = std::atoi(argv[++i]);
    } else if (a == "--surface-only") {
      config.surfaceOnly = true;
    } else if (a == "--json" || (a == "--backend" && i + 1 < argc && std::string(argv[++i]) == "cpu")) {
      // accepted for command-line compatibility with hdt-voxelize: always JSON, always CPU
    } else if (!a.empty() && a[0] != '-' && path.empty()) {
      path = a;
    } else {
      std::cerr << "usage: hdt_build_driver MESH --resolution N [--surface-only] [--threads T]\n";
      return 2;
    }
  }
  try {
    const hdt::TriangleMesh mesh = hdt::readMesh(path);
    const hdt::PreparedMesh prepared = hdt::prepareMesh(mesh, config);
    const hdt::Volume v = hdt::build(prepared, options);
    const hdt::Statistics& s = v.stats;
    struct rusage usage {};
    getrusage(RUSAGE_SELF, &usage);
    std::ostringstream o;
    o.precision(17);
    o << "{\"tool\": \"hdt-cpu-driver\", \"mesh\": \"" << path << "\", \"triangles\": " << prepared.inputTriangles
      << ", \"resolution\": " << v.grid.resolution << ", \"root_grid\": " << v.grid.rootGrid
      << ", \"leaf_size\": " << v.grid.leafSize << ", \"height\": " << v.grid.height << ", \"origin\": ["
      << v.grid.origin[0] << ", " << v.grid.origin[1] << ", " << v.grid.origin[2]
      << "], \"voxel_size\": " << v.grid.voxelSize << ", \"surface_only\": " << (v.surfaceOnly ? "true" : "false")
      << ", \"tree_elements\": " << s.treeElements << ", \"leaf_grids\": " << s.leafGrids
      << ", \"leaf_voxels\": " << s.leafVoxels << ", \"active_voxels\": " << s.activeVoxels
      << ", \"inside_voxels\": " << s.insideVoxels;
    o.precision(6);
    o << ", \"paper_bits_per_active_voxel\": " << s.paperBitsPerActiveVoxel << ", \"topology_bytes\": "
      << s.topologyBytes << ", \"leaf_bytes\": " << s.leafBytes << ", \"backend\": \"" << s.backend
      << "\", \"threads\": " << s.threads << ", \"time_ms\": {\"mapping\": " << s.time.mapping
      << ", \"branching\": " << s.time.branching << ", \"leaf\": " << s.time.leaf << ", \"classify\": "
      << s.time.classify << ", \"total\": " << s.time.total << "}, \"peak_host_bytes\": "
      << uint64_t(usage.ru_maxrss) * 1024 << ", \"degenerate_triangles\": " << s.degenerateTriangles
      << ", \"closed_mesh\": " << (v.closedMesh ? "true" : "false") << ", \"peak_device_bytes\": "
      << s.peakDeviceBytes << "}";
    std::cout << o.str() << std::endl;
    return 0;
  } catch (const hdt::Error& e) {
    std::cerr << "hdt_build_driver: " << e.what() << "\n";
    return e.kind() == hdt::ErrorKind::InvalidArgument ? 2 : e.kind() == hdt::ErrorKind::BadInput ? 3 : 4;
  } catch (const std::exception& e) {
    std::cerr << "hdt_build_driver: " << e.what() << "\n";
    return 1;
  }
}
