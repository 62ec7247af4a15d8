#include "support/mesh_files.hpp"

#include "hdt/mesh_io.hpp"

#include <algorithm>
#include <cctype>
#include <cstdlib>
#include <filesystem>

namespace hdt {
namespace test {

std::vector<std::string> meshFilesIn(const std::string& dir) {
  namespace fs = std::filesystem;
  std::vector<std::string> files;
  std::error_code ec;
  if (!dir.empty() && fs::is_directory(dir, ec)) {
    for (const fs::directory_entry& e : fs::directory_iterator(dir, ec)) {
      std::string ext = e.path().extension().string();
      std::transform(ext.begin(), ext.end(), ext.begin(), [](unsigned char c) { return char(std::tolower(c)); });
      if (e.is_regular_file() && (ext == ".stl" || ext == ".obj" || ext == ".ply"))
        files.push_back(e.path().filename().string());
    }
  }
  std::sort(files.begin(), files.end());
  if (files.empty()) files.push_back("");
  return files;
}

std::string meshCaseName(const std::string& file) {
  if (file.empty()) return "none";
  std::string name = file;
  for (char& ch : name)
    if (!std::isalnum(static_cast<unsigned char>(ch))) ch = '_';
  return name;
}

std::string sharedMeshesDir() {
  const char* env = std::getenv("HDT_MESHES_DIR");
  if (env && *env) return env;
#if defined(HDT_SHARED_MESHES_DIR)
  return HDT_SHARED_MESHES_DIR;
#else
  return "";
#endif
}

std::string sharedMeshPath(const std::string& name, std::string* why) {
  namespace fs = std::filesystem;
  const std::string dir = sharedMeshesDir();
  const std::string path = dir + "/" + name;
  std::error_code ec;
  if (dir.empty() || !fs::is_regular_file(path, ec)) {
    if (why) *why = name + " is not in the shared meshes folder \"" + dir + "\" (optional)";
    return "";
  }
  std::string ext = fs::path(name).extension().string();
  std::transform(ext.begin(), ext.end(), ext.begin(), [](unsigned char c) { return char(std::tolower(c)); });
  if (ext == ".obj" && !readsAllMeshFormats()) {
    if (why) *why = name + ": this build reads no OBJ (built without assimp)";
    return "";
  }
  return path;
}

} // namespace test
} // namespace hdt
