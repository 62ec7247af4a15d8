// Reading triangle meshes: STL (binary, ASCII), OBJ, PLY (binary, ASCII).
// Polygons are split into triangle fans.
#pragma once

#include "hdt/mesh.hpp"

#include <string>

namespace hdt {

// Throws Error(BadInput) naming the file and what is wrong.
TriangleMesh readMesh(const std::string& path);

// Built-in meshes for demos and the README's default job (no download):
// "sphere", "torus", "bunny-like blob" ... see mesh_io.cpp.
TriangleMesh builtinMesh(const std::string& name);

} // namespace hdt
