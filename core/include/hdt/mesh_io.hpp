// Reading triangle meshes, and the built-in meshes of the demo and the tests.
#pragma once

#include "hdt/mesh.hpp"
#include "hdt/transfer.hpp"

#include <string>
#include <vector>

namespace hdt {

// Reads STL (binary, ASCII), OBJ and PLY (ASCII, binary little and big
// endian). Polygons are split into triangles; every mesh of the file's scene
// is collected with its node transform. Nothing is merged, reordered or
// dropped: degenerate triangles and duplicate points are the library's
// business (prepareMesh), so counts match the file.
//
// Binary STL and PLY have built-in readers in every build; ASCII STL and OBJ
// need assimp (see readsAllMeshFormats()).
//
// Throws Error(BadInput) "<path>: <what is wrong>" for an unreadable file,
// an unknown extension, corrupt or truncated content, or no triangles.
TriangleMesh readMesh(const std::string& path);

// Where part labels (TriangleMesh::triangleLabels, hdt/labels.hpp) come from.
//   PlyFaceProperty: an integer property of the PLY face element named
//     `property`, values 1..65535 (each polygon's triangles share its value);
//   ObjGroup: OBJ groups / objects, labels 1, 2, ... in order of first
//     appearance, named after them;
//   ObjMaterial: OBJ materials (usemtl), label = material index + 1, named
//     after them;
//   Components: connected components (triangles sharing a point, by index
//     or by exact position), 1, 2, ... in order of their first triangle; any
//     format.
struct MeshLabelSource {
  enum class Kind { None, PlyFaceProperty, ObjGroup, ObjMaterial, Components } kind = Kind::None;
  std::string property;
};

// readMesh, with labels from `labels` (Error(BadInput) when the file lacks them).
TriangleMesh readMesh(const std::string& path, const MeshLabelSource& labels);

// readMesh, with arrays to transfer (hdt/transfer.hpp) from a PLY file: each
// of `arrays` names a scalar property of the vertex element (a point array)
// or, failing that, of the face element (a cell array: each polygon's
// triangles share its value); the rest of each MeshArray is filled here.
// Error(BadInput) for another format or a property the file lacks.
TriangleMesh readMesh(const std::string& path, const MeshLabelSource& labels, std::vector<MeshArray>& arrays);

// Labels each triangle with its connected component (shared points: the same
// index or exactly the same coordinates),
// 1, 2, ... in order of the components' first triangles. Throws
// Error(BadInput) past 65535 components.
void labelConnectedComponents(TriangleMesh& mesh);

// True when this build has assimp and so reads every format above; without
// it only binary STL and PLY can be read.
bool readsAllMeshFormats();

// Procedural closed meshes (watertight, points shared by index, oriented
// outwards) for demos and tests, so that nothing needs a download:
//   "sphere"  icosphere, 20,480 triangles, radius 1
//   "torus"   ring radius 1, tube radius 0.4, 16,384 triangles
//   "knot"    a tube around the (2,3) torus knot (trefoil), 40,960 triangles;
//             the demo's mesh
// Throws Error(InvalidArgument) listing the names for an unknown name.
TriangleMesh builtinMesh(const std::string& name);
std::vector<std::string> builtinMeshNames();

} // namespace hdt
