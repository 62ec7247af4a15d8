// hdt_mesh_to_ply IN OUT.ply: hdt::readMesh(IN) written as binary
// little-endian PLY, double coordinates and uint32 indices, so a build
// without assimp (the GPU machines) reads the very same TriangleMesh.
#include "hdt/error.hpp"
#include "hdt/mesh_io.hpp"

#include <cstdio>
#include <fstream>
#include <iostream>

int main(int argc, char** argv) {
  if (argc != 3) {
    std::cerr << "usage: hdt_mesh_to_ply IN OUT.ply\n";
    return 2;
  }
  try {
    const hdt::TriangleMesh m = hdt::readMesh(argv[1]);
    std::ofstream out(argv[2], std::ios::binary);
    out << "ply\nformat binary_little_endian 1.0\ncomment converted by hdt_mesh_to_ply from " << argv[1]
        << "\nelement vertex " << m.pointCount()
        << "\nproperty double x\nproperty double y\nproperty double z\nelement face " << m.triangleCount()
        << "\nproperty list uchar uint vertex_indices\nend_header\n";
    out.write(reinterpret_cast<const char*>(m.points.data()), std::streamsize(m.points.size() * sizeof(double)));
    for (size_t t = 0; t < m.triangleCount(); ++t) {
      const unsigned char three = 3;
      out.write(reinterpret_cast<const char*>(&three), 1);
      out.write(reinterpret_cast<const char*>(&m.triangles[3 * t]), 3 * sizeof(uint32_t));
    }
    if (!out) throw hdt::Error(hdt::ErrorKind::BadInput, std::string("cannot write ") + argv[2]);
    std::cout << argv[1] << ": " << m.triangleCount() << " triangles -> " << argv[2] << "\n";
  } catch (const std::exception& e) {
    std::cerr << e.what() << "\n";
    return 1;
  }
  return 0;
}
