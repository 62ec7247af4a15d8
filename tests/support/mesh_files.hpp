// The mesh files of an optional folder (the shared scans and CAD parts), for
// suites that run over whatever is there and skip when nothing is.
#pragma once

#include <string>
#include <vector>

namespace hdt {
namespace test {

// Names (not paths) of the .stl/.obj/.ply files in `dir`, sorted. When there
// are none (or `dir` is empty or missing) the list holds one empty name, so a
// parameterised suite still has one case, which skips with the reason.
std::vector<std::string> meshFilesIn(const std::string& dir);

// A test-name-safe form of a name from meshFilesIn ("none" for the empty one):
// every character that is not a letter or digit becomes '_'.
std::string meshCaseName(const std::string& file);

// The folder of the shared meshes: $HDT_MESHES_DIR when set (the GPU machine's
// binary PLY copies), else the folder beside the checkout that the build
// names (HDT_SHARED_MESHES_DIR), else "".
std::string sharedMeshesDir();

// The path of `name` in sharedMeshesDir(), or "" when a test must skip, with
// the reason in `why`: the file is absent, or this build cannot read its
// format (OBJ and ASCII STL need assimp: hdt::readsAllMeshFormats()).
std::string sharedMeshPath(const std::string& name, std::string* why);

} // namespace test
} // namespace hdt
