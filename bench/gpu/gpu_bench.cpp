// hdt_gpu_bench: the CUDA driver's phase times per mesh and resolution.
//
// Per (mesh, resolution, mode): two warm-up builds, --runs timed builds
// (CUDA-event phase times, nothing copied back), the median of each phase
// and of the total; then one full build for the structure statistics, the
// copy-back time and the peak device memory. One JSON object per line (the
// CLI's --json keys plus gpu, date, peak_device_bytes and the extras below)
// goes to --out, a short table to stdout. A resolution that does not fit
// records its error and ends that mesh's series.
//
// usage: hdt_gpu_bench --meshes DIR [--mesh FILE]... [--res 1024,2048,...]
//                      [--modes surface,solid,winding] [--runs 5] [--subdivide K]
//                      [--root 16] [--leaf 16] [--out FILE]
#include "hdt/builder.hpp"
#include "hdt/cuda_build.hpp"
#include "hdt/error.hpp"
#include "hdt/mesh.hpp"
#include "hdt/mesh_io.hpp"

#include "subdivide.hpp"

#include <algorithm>
#include <chrono>
#include <cstdio>
#include <ctime>
#include <filesystem>
#include <fstream>
#include <iostream>
#include <map>
#include <sstream>
#include <string>
#include <vector>

namespace {

namespace fs = std::filesystem;
using namespace hdt;

enum BenchMode : int { kSurface = 0, kSolid = 1, kWinding = 2 };

struct Args {
  std::string meshes;
  std::vector<std::string> only;
  std::vector<int> res = {1024, 2048, 4096, 8192, 16384, 32768};
  std::vector<int> modes = {kSurface, kSolid}; // kSurface, kSolid (Parity), kWinding
  int runs = 5;
  int subdivide = 0;
  int root = 16, leaf = 16;
  std::string out = "gpu-runs.jsonl";
};

std::vector<std::string> split(const std::string& s, char sep) {
  std::vector<std::string> parts;
  std::stringstream ss(s);
  for (std::string p; std::getline(ss, p, sep);)
    if (!p.empty()) parts.push_back(p);
  return parts;
}

Args parse(int argc, char** argv) {
  Args a;
  for (int i = 1; i < argc; ++i) {
    const std::string k = argv[i];
    auto value = [&]() -> std::string {
      if (i + 1 >= argc) throw std::runtime_error("missing value after " + k);
      return argv[++i];
    };
    if (k == "--meshes") a.meshes = value();
    else if (k == "--mesh") a.only.push_back(value());
    else if (k == "--res") { a.res.clear(); for (auto& p : split(value(), ',')) a.res.push_back(std::stoi(p)); }
    else if (k == "--modes") {
      a.modes.clear();
      for (auto& p : split(value(), ','))
        a.modes.push_back(p == "surface" ? kSurface : p == "winding" ? kWinding : kSolid);
    }
    else if (k == "--runs") a.runs = std::stoi(value());
    else if (k == "--subdivide") a.subdivide = std::stoi(value());
    else if (k == "--root") a.root = std::stoi(value());
    else if (k == "--leaf") a.leaf = std::stoi(value());
    else if (k == "--out") a.out = value();
    else throw std::runtime_error("unknown argument " + k);
  }
  if (a.meshes.empty()) throw std::runtime_error("--meshes DIR is required");
  return a;
}

double median(std::vector<double> v) {
  std::sort(v.begin(), v.end());
  const size_t n = v.size();
  return n == 0 ? 0 : (n % 2 ? v[n / 2] : 0.5 * (v[n / 2 - 1] + v[n / 2]));
}

std::string num(double x, const char* fmt = "%.6g") {
  char b[64];
  std::snprintf(b, sizeof b, fmt, x);
  return b;
}

std::string today() {
  const std::time_t t = std::time(nullptr);
  char b[32];
  std::strftime(b, sizeof b, "%Y-%m-%dT%H:%M:%SZ", std::gmtime(&t));
  return b;
}

std::string quoted(const std::string& s) {
  std::string o = "\"";
  for (char c : s) {
    if (c == '"' || c == '\\') o += '\\';
    o += c;
  }
  return o + "\"";
}

struct Timed {
  PhaseTimes median;
  double minTotal = 0, maxTotal = 0, wall = 0, upload = 0;
};

}  // namespace

int main(int argc, char** argv) {
  Args args;
  try {
    args = parse(argc, argv);
  } catch (const std::exception& e) {
    std::cerr << "hdt_gpu_bench: " << e.what() << "\n";
    return 2;
  }
  std::string why;
  if (!cudaAvailable(&why)) {
    std::cerr << "hdt_gpu_bench: " << why << "\n";
    return 3;
  }
  setCudaPoolRetention(UINT64_MAX); // warm runs reuse the pool, as a long-lived process would
  std::vector<std::string> files;
  for (const auto& e : fs::directory_iterator(args.meshes)) {
    const std::string ext = e.path().extension().string();
    if (ext != ".ply" && ext != ".stl" && ext != ".obj") continue;
    const std::string name = e.path().filename().string();
    if (!args.only.empty() && std::find(args.only.begin(), args.only.end(), name) == args.only.end()) continue;
    files.push_back(name);
  }
  std::sort(files.begin(), files.end());
  std::ofstream out(args.out, std::ios::app);
  const std::string date = today();
  std::printf("%-28s %6s %-7s %3s %9s %8s %7s %7s %7s %7s %7s %8s %8s\n", "mesh", "N", "mode", "h", "elements",
              "leaves", "T1", "T2", "T3", "class", "total", "upload", "peakMiB");

  for (const std::string& file : files) {
    TriangleMesh mesh;
    try {
      mesh = readMesh(args.meshes + "/" + file);
      for (int k = 0; k < args.subdivide; ++k) mesh = subdivide(mesh);
    } catch (const std::exception& e) {
      std::cerr << file << ": " << e.what() << "\n";
      continue;
    }
    const std::string label =
        args.subdivide ? file + " (subdivided x" + std::to_string(1 << (2 * args.subdivide)) + ")" : file;
    for (int mode : args.modes) {
      const bool surfaceOnly = mode == kSurface;
      const char* modeName = mode == kSurface ? "surface" : mode == kWinding ? "winding" : "solid";
      // The winding number runs on the host over the copied-back volume, so
      // its runs keep the result (wall time includes the copy back).
      const bool keep = mode == kWinding;
      for (int n : args.res) {
        BuildConfig config;
        config.resolution = n;
        config.rootGrid = args.root;
        config.leafSize = args.leaf;
        config.surfaceOnly = surfaceOnly;
        config.insideTest = mode == kWinding ? InsideTest::WindingNumber : InsideTest::Parity;
        BuildOptions options;
        options.backend = Backend::Cuda;
        std::vector<std::string> log;
        options.log = [&](const std::string& m) { log.push_back(m); };
        try {
          const PreparedMesh prepared = prepareMesh(mesh, config);
          CudaBuildReport report;
          for (int w = 0; w < 2; ++w) buildCudaWithReport(prepared, options, &report, keep); // warm-up
          std::vector<double> t1, t2, t3, tc, tt, wall, upload;
          for (int r = 0; r < args.runs; ++r) {
            const Volume v = buildCudaWithReport(prepared, options, &report, keep);
            t1.push_back(v.stats.time.mapping);
            t2.push_back(v.stats.time.branching);
            t3.push_back(v.stats.time.leaf);
            tc.push_back(v.stats.time.classify);
            tt.push_back(v.stats.time.total);
            wall.push_back(report.wallMs);
            upload.push_back(report.uploadMs);
          }
          const Volume v = buildCudaWithReport(prepared, options, &report, true);
          const Statistics& s = v.stats;
          const GridSpec& g = v.grid;
          std::ostringstream j;
          j << "{\"mesh\": " << quoted(label) << ", \"triangles\": " << s.triangles << ", \"resolution\": " << n
            << ", \"root_grid\": " << g.rootGrid << ", \"leaf_size\": " << g.leafSize << ", \"height\": " << g.height
            << ", \"origin\": [" << num(g.origin[0], "%.17g") << "," << num(g.origin[1], "%.17g") << ","
            << num(g.origin[2], "%.17g") << "], \"voxel_size\": " << num(g.voxelSize, "%.17g")
            << ", \"tree_elements\": " << s.treeElements << ", \"leaf_grids\": " << s.leafGrids
            << ", \"leaf_voxels\": " << s.leafVoxels << ", \"active_voxels\": " << s.activeVoxels
            << ", \"inside_voxels\": " << s.insideVoxels
            << ", \"paper_bits_per_active_voxel\": " << num(s.paperBitsPerActiveVoxel)
            << ", \"topology_bytes\": " << s.topologyBytes << ", \"leaf_bytes\": " << s.leafBytes
            << ", \"backend\": \"cuda\", \"threads\": " << s.threads << ", \"time_ms\": {\"mapping\": "
            << num(median(t1), "%.4f") << ", \"branching\": " << num(median(t2), "%.4f")
            << ", \"leaf\": " << num(median(t3), "%.4f") << ", \"classify\": " << num(median(tc), "%.4f")
            << ", \"total\": " << num(median(tt), "%.4f") << "}, \"peak_host_bytes\": " << s.peakHostBytes
            << ", \"gpu\": " << quoted(report.deviceName) << ", \"date\": " << quoted(date)
            << ", \"peak_device_bytes\": " << s.peakDeviceBytes
            << ", \"degenerate_triangles\": " << s.degenerateTriangles
            << ", \"closed_mesh\": " << (v.closedMesh ? "true" : "false")
            << ", \"surface_only\": " << (surfaceOnly ? "true" : "false") << ", \"mode\": " << quoted(modeName)
            << ", \"inside_test\": " << quoted(v.insideTest == InsideTest::WindingNumber ? "winding" : "parity")
            << ", \"winding_refined_elements\": " << s.windingRefinedElements << ", \"runs\": " << args.runs
            << ", \"total_ms_min\": " << num(*std::min_element(tt.begin(), tt.end()), "%.4f")
            << ", \"total_ms_max\": " << num(*std::max_element(tt.begin(), tt.end()), "%.4f")
            << ", \"upload_ms\": " << num(median(upload), "%.4f")
            << ", \"download_ms\": " << num(report.downloadMs, "%.4f")
            << ", \"wall_ms_no_copy_back\": " << num(median(wall), "%.4f")
            << ", \"wall_ms_full\": " << num(report.wallMs, "%.4f") << ", \"chunks\": " << report.chunks << "}";
          out << j.str() << "\n";
          out.flush();
          std::printf("%-28s %6d %-7s %3d %9llu %8llu %7.3f %7.3f %7.3f %7.3f %7.3f %8.3f %8.0f\n", label.c_str(), n,
                      modeName, g.height, (unsigned long long)s.treeElements,
                      (unsigned long long)s.leafGrids, median(t1), median(t2), median(t3), median(tc), median(tt),
                      median(upload), double(s.peakDeviceBytes) / (1 << 20));
          int shown = 0; // the last run's winding pass breakdown (two lines)
          for (auto m = log.rbegin(); m != log.rend() && shown < 2; ++m)
            if (m->find("winding") != std::string::npos) {
              std::printf("  # %s\n", m->c_str());
              ++shown;
            }
          std::fflush(stdout);
        } catch (const std::exception& e) {
          out << "{\"mesh\": " << quoted(label) << ", \"resolution\": " << n
              << ", \"surface_only\": " << (surfaceOnly ? "true" : "false") << ", \"gpu\": \"\", \"date\": "
              << quoted(date) << ", \"error\": " << quoted(e.what()) << "}\n";
          out.flush();
          std::printf("%-28s %6d %-7s  error: %s\n", label.c_str(), n, modeName, e.what());
          break; // larger resolutions will not fit either
        }
      }
    }
  }
  return 0;
}
