// libFuzzer harness: the mesh readers (binary STL and PLY built in, ASCII STL
// and OBJ through assimp). The first byte picks the extension, the rest is the
// file. Refusals must be hdt::Error (BadInput); a mesh that is accepted must
// have in-range indices.
#include "hdt/error.hpp"
#include "hdt/mesh_io.hpp"

#include <unistd.h>

#include <cstdint>
#include <cstdio>
#include <cstdlib>
#include <string>

extern "C" int LLVMFuzzerTestOneInput(const uint8_t* data, size_t size) {
  if (size < 1) return 0;
  static const char* const kExtensions[] = {".stl", ".ply", ".obj", ".ply"};
  static const std::string base = "/tmp/hdt-fuzz-mesh-" + std::to_string(::getpid());
  const std::string path = base + kExtensions[data[0] % 4];
  std::FILE* f = std::fopen(path.c_str(), "wb");
  if (!f) std::abort();
  std::fwrite(data + 1, 1, size - 1, f);
  std::fclose(f);
  try {
    const hdt::TriangleMesh mesh = hdt::readMesh(path);
    for (uint32_t i : mesh.triangles)
      if (i >= mesh.pointCount()) std::abort();
  } catch (const hdt::Error& e) {
    if (e.kind() != hdt::ErrorKind::BadInput) std::abort();
  }
  std::remove(path.c_str());
  return 0;
}
