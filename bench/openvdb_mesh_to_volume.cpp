// openvdb_mesh_to_volume: the OpenVDB side of the CPU benchmark.
//
// Reads a mesh with hdt::readMesh, places the HDT grid for resolution N with
// hdt::prepareMesh (voxel size = longest extent / (N - 2), mesh centred) and
// times openvdb::tools::meshToUnsignedDistanceField at exactly that voxel size
// and voxel placement: OpenVDB voxel (i, j, k) has the same centre as HDT voxel
// (i, j, k). The narrow band half-width defaults to sqrt(3)/2 voxel, the
// smallest band that keeps every voxel whose cube meets the surface (a cube
// touching a triangle has its centre within half a diagonal of it), so the
// active voxels are comparable with the HDT's surface voxels.
//
// Prints one JSON line. Run one measurement per process: peak_host_bytes is
// this process's ru_maxrss (mesh, points and grid included).
//
//   openvdb_mesh_to_volume MESH --resolution N [--threads T] [--band W]
//                          [--root-grid R] [--leaf-size L] [--check-hdt]
//
// --check-hdt additionally builds the HDT surface with the CPU driver and
// counts HDT surface voxels that are not active in the OpenVDB grid (should be
// 0 up to float rounding); it shows the two grids line up. Not for timing.
#include "hdt/builder.hpp"
#include "hdt/error.hpp"
#include "hdt/host_memory.hpp"
#include "hdt/mesh.hpp"
#include "hdt/mesh_io.hpp"

#include <openvdb/openvdb.h>
#include <openvdb/tools/MeshToVolume.h>
#include <tbb/global_control.h>
#include <tbb/info.h>

#include <chrono>
#include <cmath>
#include <cstdio>
#include <cstdlib>
#include <cstring>
#include <iostream>
#include <memory>
#include <sstream>
#include <string>
#include <vector>

namespace {

std::string jsonString(const std::string& s) {
  std::string out = "\"";
  for (char c : s) {
    if (c == '"' || c == '\\') {
      out += '\\';
      out += c;
    } else if (static_cast<unsigned char>(c) < 0x20) {
      char buf[8];
      std::snprintf(buf, sizeof buf, "\\u%04x", c);
      out += buf;
    } else {
      out += c;
    }
  }
  return out + "\"";
}

[[noreturn]] void usage(const char* why) {
  std::cerr << "openvdb_mesh_to_volume: " << why << "\n"
            << "usage: openvdb_mesh_to_volume MESH --resolution N [--threads T] [--band W]\n"
            << "       [--root-grid R] [--leaf-size L] [--check-hdt]\n";
  std::exit(2);
}

int intArg(int& i, int argc, char** argv) {
  if (i + 1 >= argc) usage((std::string(argv[i]) + " needs a value").c_str());
  char* end = nullptr;
  const long v = std::strtol(argv[++i], &end, 10);
  if (*end != '\0') usage((std::string("not an integer: ") + argv[i]).c_str());
  return int(v);
}

struct CheckResult {
  uint64_t hdtSurface = 0;
  uint64_t missing = 0;
};

// Walks the HDT (level order, see types.hpp) and looks up every surface voxel
// in the OpenVDB grid.
CheckResult checkAgainstHdt(const hdt::PreparedMesh& prepared, const openvdb::FloatGrid& grid) {
  hdt::BuildOptions options;
  options.backend = hdt::Backend::Cpu;
  hdt::PreparedMesh surface = prepared;
  surface.surfaceOnly = true;
  const hdt::Volume v = hdt::buildCpu(surface, options);
  const int R = v.grid.rootGrid, L = v.grid.leafSize;
  auto acc = grid.getConstAccessor();
  CheckResult result;
  struct Item {
    uint64_t index;
    int64_t x, y, z;
  };
  std::vector<Item> stack;
  for (int z = 0; z < R; ++z)
    for (int y = 0; y < R; ++y)
      for (int x = 0; x < R; ++x) stack.push_back({uint64_t(x + R * (y + R * z)), x, y, z});
  while (!stack.empty()) {
    const Item it = stack.back();
    stack.pop_back();
    const hdt::ElementWord w = v.elements[it.index];
    if (hdt::elementState(w) == hdt::ElementState::Branch) {
      for (int c = 0; c < 8; ++c)
        stack.push_back({hdt::elementPayload(w) + uint64_t(c), 2 * it.x + (c & 1), 2 * it.y + ((c >> 1) & 1),
                         2 * it.z + ((c >> 2) & 1)});
    } else if (hdt::elementState(w) == hdt::ElementState::Boundary) {
      const uint32_t* words = v.leaf(hdt::elementPayload(w));
      for (int z = 0; z < L; ++z)
        for (int y = 0; y < L; ++y)
          for (int x = 0; x < L; ++x) {
            if (hdt::leafVoxel(words, L, x, y, z) != hdt::VoxelState::Surface) continue;
            ++result.hdtSurface;
            const openvdb::Coord ijk(int(it.x * L + x), int(it.y * L + y), int(it.z * L + z));
            if (!acc.isValueOn(ijk)) ++result.missing;
          }
    }
  }
  return result;
}

} // namespace

int main(int argc, char** argv) {
  std::string path;
  hdt::BuildConfig config;
  config.resolution = 0;
  config.surfaceOnly = true; // placement does not depend on it
  int threads = 0;
  double band = std::sqrt(3.0) / 2.0;
  bool check = false;
  for (int i = 1; i < argc; ++i) {
    const std::string a = argv[i];
    if (a == "--resolution" || a == "-r") config.resolution = intArg(i, argc, argv);
    else if (a == "--threads") threads = intArg(i, argc, argv);
    else if (a == "--root-grid") config.rootGrid = intArg(i, argc, argv);
    else if (a == "--leaf-size") config.leafSize = intArg(i, argc, argv);
    else if (a == "--band") {
      if (i + 1 >= argc) usage("--band needs a value");
      band = std::atof(argv[++i]);
      if (!(band > 0)) usage("--band must be positive");
    } else if (a == "--check-hdt") check = true;
    else if (a == "-h" || a == "--help") usage("help");
    else if (!a.empty() && a[0] == '-') usage(("unknown option " + a).c_str());
    else if (path.empty()) path = a;
    else usage("more than one mesh given");
  }
  if (path.empty()) usage("no mesh given");
  if (config.resolution <= 0) usage("--resolution N is required");

  // Limit TBB (OpenVDB's parallelism) before anything spawns its arena.
  std::unique_ptr<tbb::global_control> limit;
  if (threads > 0) {
    limit = std::make_unique<tbb::global_control>(tbb::global_control::max_allowed_parallelism, size_t(threads));
  } else {
    threads = tbb::info::default_concurrency();
  }

  try {
    openvdb::initialize();
    const hdt::TriangleMesh mesh = hdt::readMesh(path);
    const hdt::PreparedMesh prepared = hdt::prepareMesh(mesh, config);
    const hdt::GridSpec& g = prepared.grid;
    const double s = g.voxelSize;

    // Points in HDT voxel units relative to the grid origin, (p - origin) / s,
    // computed in double, then float: float precision does not depend on where
    // the mesh sits in world space, and the transform is a unit scale (OpenVDB
    // refuses scales whose determinant is near zero, e.g. s ~ 1e-5 on the
    // millimetre-sized CAD parts at 8192). Index space is the HDT's: voxel i
    // centred at i + 1/2. The grid keeps this voxel-unit transform (origin and
    // voxel size are in the JSON line); distances are in voxels.
    std::vector<openvdb::Vec3s> points(mesh.pointCount());
    for (size_t p = 0; p < points.size(); ++p)
      points[p] = openvdb::Vec3s(float((mesh.points[3 * p] - g.origin[0]) / s),
                                 float((mesh.points[3 * p + 1] - g.origin[1]) / s),
                                 float((mesh.points[3 * p + 2] - g.origin[2]) / s));
    std::vector<openvdb::Vec3I> triangles(mesh.triangleCount());
    for (size_t t = 0; t < triangles.size(); ++t)
      triangles[t] = openvdb::Vec3I(mesh.triangles[3 * t], mesh.triangles[3 * t + 1], mesh.triangles[3 * t + 2]);
    const std::vector<openvdb::Vec4I> quads;
    openvdb::math::Transform::Ptr local = openvdb::math::Transform::createLinearTransform(1.0);
    local->postTranslate(openvdb::Vec3d(0.5, 0.5, 0.5));

    const auto t0 = std::chrono::steady_clock::now();
    openvdb::FloatGrid::Ptr grid =
        openvdb::tools::meshToUnsignedDistanceField<openvdb::FloatGrid>(*local, points, triangles, quads, float(band));
    const double ms = std::chrono::duration<double, std::milli>(std::chrono::steady_clock::now() - t0).count();
    const uint64_t peak = hdt::peakResidentBytes(); // before the optional check allocates more

    std::ostringstream out;
    out.precision(17);
    out << "{\"tool\": \"openvdb\", \"mesh\": " << jsonString(path) << ", \"triangles\": " << mesh.triangleCount()
        << ", \"resolution\": " << g.resolution << ", \"origin\": [" << g.origin[0] << ", " << g.origin[1] << ", "
        << g.origin[2] << "], \"voxel_size\": " << s << ", \"band_voxels\": " << band
        << ", \"active_voxels\": " << grid->activeVoxelCount() << ", \"leaf_nodes\": " << grid->tree().leafCount()
        << ", \"grid_bytes\": " << grid->memUsage();
    out.precision(6);
    out << ", \"time_ms\": " << ms << ", \"peak_host_bytes\": " << peak << ", \"threads\": " << threads
        << ", \"openvdb_version\": \"" << openvdb::getLibraryAbiVersionString() << "\"";
    if (check) {
      const CheckResult c = checkAgainstHdt(prepared, *grid);
      out << ", \"check\": {\"hdt_surface_voxels\": " << c.hdtSurface << ", \"missing_in_openvdb\": " << c.missing
          << "}";
    }
    out << "}";
    std::cout << out.str() << std::endl;
    return 0;
  } catch (const hdt::Error& e) {
    std::cerr << "openvdb_mesh_to_volume: " << e.what() << "\n";
    switch (e.kind()) {
    case hdt::ErrorKind::InvalidArgument: return 2;
    case hdt::ErrorKind::BadInput: return 3;
    default: return 4;
    }
  } catch (const std::bad_alloc&) {
    std::cerr << "openvdb_mesh_to_volume: out of memory\n";
    return 4;
  } catch (const std::exception& e) {
    std::cerr << "openvdb_mesh_to_volume: " << e.what() << "\n";
    return 1;
  }
}
