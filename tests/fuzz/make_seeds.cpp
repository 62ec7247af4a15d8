// Writes the seed corpora of the fuzz harnesses, from the tests' own shapes
// and volumes (no binary blobs in the tree), plus every regression input of
// issue 12 that the harnesses can take.
//   hdt_fuzz_seeds OUTDIR  ->  OUTDIR/{hdt_reader,mesh_reader,pipeline}/...
#include "hdt/builder.hpp"
#include "hdt/hdt_file.hpp"
#include "hdt/transfer.hpp"
#include "support/format_volumes.hpp"
#include "support/shapes.hpp"

#include <sys/stat.h>

#include <cstdint>
#include <cstdio>
#include <cstring>
#include <string>
#include <vector>

namespace {

void put(const std::string& path, const void* data, size_t size) {
  std::FILE* f = std::fopen(path.c_str(), "wb");
  if (!f || std::fwrite(data, 1, size, f) != size || std::fclose(f) != 0) {
    std::perror(path.c_str());
    std::exit(1);
  }
}
void put(const std::string& path, const std::vector<uint8_t>& b) { put(path, b.data(), b.size()); }
// Mesh seeds start with the extension selector of fuzz_mesh_reader.cpp.
enum : uint8_t { kStl = 0, kPly = 1, kObj = 2 };
void putMesh(const std::string& path, uint8_t ext, const std::string& text) {
  std::vector<uint8_t> b{ext};
  b.insert(b.end(), text.begin(), text.end());
  put(path, b);
}

std::string binaryStl(const hdt::TriangleMesh& m) {
  std::string s(80, '\0');
  const uint32_t n = uint32_t(m.triangleCount());
  s.append(reinterpret_cast<const char*>(&n), 4);
  for (size_t t = 0; t < m.triangleCount(); ++t) {
    float rec[12] = {};
    for (int j = 0; j < 3; ++j)
      for (int a = 0; a < 3; ++a) rec[3 + 3 * j + a] = float(m.points[3 * m.triangles[3 * t + j] + a]);
    s.append(reinterpret_cast<const char*>(rec), sizeof rec);
    s.append(2, '\0');
  }
  return s;
}

std::string asciiPly(const hdt::TriangleMesh& m, const char* type = "float") {
  std::string s = "ply\nformat ascii 1.0\nelement vertex " + std::to_string(m.pointCount()) +
                  "\nproperty " + type + " x\nproperty " + type + " y\nproperty " + type +
                  " z\nelement face " + std::to_string(m.triangleCount()) +
                  "\nproperty list uchar int vertex_indices\nend_header\n";
  for (size_t p = 0; p < m.pointCount(); ++p)
    s += std::to_string(m.points[3 * p]) + " " + std::to_string(m.points[3 * p + 1]) + " " +
         std::to_string(m.points[3 * p + 2]) + "\n";
  for (size_t t = 0; t < m.triangleCount(); ++t)
    s += "3 " + std::to_string(m.triangles[3 * t]) + " " + std::to_string(m.triangles[3 * t + 1]) + " " +
         std::to_string(m.triangles[3 * t + 2]) + "\n";
  return s;
}

std::string binaryPly(const hdt::TriangleMesh& m) {
  std::string s = "ply\nformat binary_little_endian 1.0\nelement vertex " + std::to_string(m.pointCount()) +
                  "\nproperty float x\nproperty float y\nproperty float z\nelement face " +
                  std::to_string(m.triangleCount()) + "\nproperty list uchar int vertex_indices\nend_header\n";
  for (double v : m.points) {
    const float f = float(v);
    s.append(reinterpret_cast<const char*>(&f), 4);
  }
  for (size_t t = 0; t < m.triangleCount(); ++t) {
    s += char(3);
    s.append(reinterpret_cast<const char*>(&m.triangles[3 * t]), 12);
  }
  return s;
}

std::string obj(const hdt::TriangleMesh& m) {
  std::string s;
  for (size_t p = 0; p < m.pointCount(); ++p)
    s += "v " + std::to_string(m.points[3 * p]) + " " + std::to_string(m.points[3 * p + 1]) + " " +
         std::to_string(m.points[3 * p + 2]) + "\n";
  for (size_t t = 0; t < m.triangleCount(); ++t)
    s += "f " + std::to_string(m.triangles[3 * t] + 1) + " " + std::to_string(m.triangles[3 * t + 1] + 1) + " " +
         std::to_string(m.triangles[3 * t + 2] + 1) + "\n";
  return s;
}

} // namespace

int main(int argc, char** argv) {
  if (argc != 2) {
    std::fprintf(stderr, "usage: hdt_fuzz_seeds OUTDIR\n");
    return 2;
  }
  const std::string out = argv[1];
  for (const char* d : {"", "/hdt_reader", "/mesh_reader", "/pipeline"}) ::mkdir((out + d).c_str(), 0777);

  // .hdt: random trees (raw and zstd) and a real build.
  using namespace hdt;
  HdtWriteOptions raw;
  raw.compressLeaves = false;
  HdtWriteOptions oneFrame; // version 2's one zstd frame (the default: version 3's blocks)
  oneFrame.leafBlocks = false;
  for (uint32_t seed = 1; seed <= 4; ++seed) {
    test::RandomVolumeSpec spec;
    spec.height = int(seed % 3);
    spec.surfaceOnly = seed == 4;
    const Volume v = test::randomVolume(seed, spec);
    put(out + "/hdt_reader/random" + std::to_string(seed) + ".hdt", serializeHdt(v, raw));
    put(out + "/hdt_reader/random" + std::to_string(seed) + "-zstd.hdt", serializeHdt(v));
    put(out + "/hdt_reader/random" + std::to_string(seed) + "-zstd-frame.hdt", serializeHdt(v, oneFrame));
  }
  // Labelled volumes: the optional label sections (16, 18, 21) to mutate too.
  for (uint32_t seed = 5; seed <= 6; ++seed) {
    test::RandomVolumeSpec spec;
    spec.height = 1;
    Volume v = test::randomVolume(seed, spec);
    test::labelRandomly(v, seed);
    put(out + "/hdt_reader/labelled" + std::to_string(seed) + ".hdt", serializeHdt(v, raw));
    put(out + "/hdt_reader/labelled" + std::to_string(seed) + "-zstd.hdt", serializeHdt(v));
  }
  BuildConfig c;
  c.resolution = 32;
  c.rootGrid = 2;
  c.leafSize = 8;
  BuildOptions o;
  o.backend = Backend::Cpu;
  put(out + "/hdt_reader/sphere32.hdt", serializeHdt(voxelize(test::icosphere(1, 1.0), c, o)));
  {
    // Transferred arrays: the optional array sections (19, 20) to mutate too.
    const TriangleMesh m = test::icosphere(1, 1.0);
    Volume v = voxelize(m, c, o);
    MeshArray x{"x", ArraySource::Point, 1, {}}, index{"triangle", ArraySource::Cell, 1, {}};
    for (size_t p = 0; p < m.pointCount(); ++p) x.values.push_back(m.points[3 * p]);
    for (size_t t = 0; t < m.triangleCount(); ++t) index.values.push_back(double(t));
    transferArrays(m, {x, index}, v);
    put(out + "/hdt_reader/sphere32-arrays.hdt", serializeHdt(v, raw));
  }

  // Meshes: every format the readers take, and the inputs.
  const TriangleMesh tetra = test::octahedron({0, 0, 0}, 1.0), sphere = test::icosphere(1, 1.0);
  putMesh(out + "/mesh_reader/sphere-binary.stl", kStl, binaryStl(sphere));
  putMesh(out + "/mesh_reader/octahedron.ply", kPly, asciiPly(tetra));
  putMesh(out + "/mesh_reader/octahedron-double.ply", kPly, asciiPly(tetra, "double"));
  putMesh(out + "/mesh_reader/sphere-binary.ply", kPly, binaryPly(sphere));
  putMesh(out + "/mesh_reader/octahedron.obj", kObj, obj(tetra));
  putMesh(out + "/mesh_reader/octahedron-ascii.stl", kStl,
          "solid t\nfacet normal 0 0 1\nouter loop\nvertex 0 0 0\nvertex 1 0 0\nvertex 0 1 0\nendloop\n"
          "endfacet\nendsolid t\n");
  putMesh(out + "/mesh_reader/issue12-junk-element.ply", kPly,
          "ply\nformat ascii 1.0\nelement junk 18446744073709551615\nend_header\n");
  putMesh(out + "/mesh_reader/issue12-1e308.ply", kPly,
          "ply\nformat ascii 1.0\nelement vertex 3\nproperty double x\nproperty double y\nproperty double z\n"
          "element face 1\nproperty list uchar int vertex_indices\nend_header\n-1e308 0 0\n1e308 0 0\n"
          "0 1e308 0\n3 0 1 2\n");

  // Pipeline inputs (see fuzz_pipeline.cpp): an octahedron, a doubled
  // tetrahedron (issue 12: closed with nothing inside), an open fan.
  const std::vector<uint8_t> octa = {0x08, 3, 100, 0, 0, 156, 0, 0, 0, 100, 0, 0, 156, 0, 0, 0, 100, 0, 0, 156,
                                     0, 2, 4, 2, 1, 4, 1, 3, 4, 3, 0, 4, 2, 0, 5, 1, 2, 5, 3, 1, 5, 0, 3, 5};
  put(out + "/pipeline/octahedron", octa);
  const std::vector<uint8_t> doubled = {0x01, 1, 0, 0, 0, 90, 0, 0, 0, 90, 0, 0, 0, 90,
                                        0, 2, 1, 0, 1, 3, 0, 3, 2, 1, 2, 3, 0, 2, 1, 0, 1, 3, 0, 3, 2, 1, 2, 3};
  put(out + "/pipeline/issue12-doubled-tetrahedron", doubled);
  const std::vector<uint8_t> fan = {0x1c, 2, 0, 0, 0, 120, 0, 10, 0, 120, 30, 60, 60, 127, 0, 1, 2, 0, 2, 3, 0, 3, 4};
  put(out + "/pipeline/open-fan", fan);
  return 0;
}
