// Mesh files -> TriangleMesh.
//
// Binary STL and PLY have built-in readers in every build: they are the
// formats of the machines without assimp (the GPU hosts), reading them
// ourselves gives the same triangles with and without assimp, and assimp 5.2's
// PLY loader trusts the header (a truncated file gives garbage or a crash).
// ASCII STL and OBJ go through assimp with aiProcess_Triangulate only: no
// vertex joining, no degenerate removal, no sorting by primitive type, so
// triangle counts match the file and the library sees the input as it is.
#include "hdt/mesh_io.hpp"

#include "hdt/error.hpp"

#include <sys/stat.h>

#include <algorithm>
#include <map>
#include <cctype>
#include <cerrno>
#include <cstdio>
#include <cmath>
#include <cstdlib>
#include <cstring>
#include <memory>
#include <sstream>
#include <string>
#include <vector>

#if defined(HDT_HAVE_ASSIMP)
#include <assimp/Importer.hpp>
#include <assimp/postprocess.h>
#include <assimp/scene.h>
#endif

namespace hdt {
namespace {

[[noreturn]] void fail(const std::string& path, const std::string& what) {
  throw Error(ErrorKind::BadInput, path + ": " + what);
}

std::string lowerExtension(const std::string& path) {
  const size_t slash = path.find_last_of('/');
  const size_t dot = path.find_last_of('.');
  if (dot == std::string::npos || (slash != std::string::npos && dot < slash)) return "";
  std::string ext = path.substr(dot);
  std::transform(ext.begin(), ext.end(), ext.begin(), [](unsigned char c) { return char(std::tolower(c)); });
  return ext;
}

struct CloseFile {
  void operator()(std::FILE* f) const { std::fclose(f); }
};
using File = std::unique_ptr<std::FILE, CloseFile>;

// Opens a regular file for reading and returns its size.
File openRegular(const std::string& path, uint64_t& size) {
  struct stat st {};
  if (::stat(path.c_str(), &st) != 0) fail(path, std::string("cannot open: ") + std::strerror(errno));
  if (!S_ISREG(st.st_mode)) fail(path, "not a regular file");
  File f(std::fopen(path.c_str(), "rb"));
  if (!f) fail(path, std::string("cannot open: ") + std::strerror(errno));
  size = uint64_t(st.st_size);
  return f;
}

// ---- binary STL -------------------------------------------------------------------
// 80-byte header, uint32 triangle count n, then n records of 50 bytes: normal
// (ignored: orientation comes from the vertex order), 3 vertices of 3 float32,
// 2 attribute bytes. All little endian.
constexpr uint64_t kStlHeader = 84;
constexpr uint64_t kStlRecord = 50;

uint32_t readLe32(const unsigned char* p) {
  return uint32_t(p[0]) | (uint32_t(p[1]) << 8) | (uint32_t(p[2]) << 16) | (uint32_t(p[3]) << 24);
}

float readLeFloat(const unsigned char* p) {
  const uint32_t bits = readLe32(p);
  float f;
  std::memcpy(&f, &bits, sizeof f);
  return f;
}

// The triangle count of a binary STL, or false when the file is not one: the
// size must be exactly 84 + 50 n. (An ASCII file starting with "solid" does
// not pass: bytes 80..83 of text give an n far beyond its size.)
bool binaryStlCount(std::FILE* f, uint64_t size, uint32_t& n) {
  unsigned char header[kStlHeader];
  if (size < kStlHeader || std::fread(header, 1, kStlHeader, f) != kStlHeader) return false;
  n = readLe32(header + 80);
  return size == kStlHeader + kStlRecord * uint64_t(n);
}

// ASCII STL begins with "solid" (after optional white space).
bool startsWithSolid(std::FILE* f) {
  std::rewind(f);
  int c;
  while ((c = std::fgetc(f)) != EOF && std::isspace(c)) {
  }
  char rest[5] = {char(c)};
  return c != EOF && std::fread(rest + 1, 1, 4, f) == 4 && std::strncmp(rest, "solid", 5) == 0;
}

// ASCII STL ends with "endsolid [name]"; look for it in the last line.
bool endsWithEndsolid(std::FILE* f, uint64_t size) {
  const uint64_t tail = std::min<uint64_t>(size, 512);
  std::string end(tail, '\0');
  if (std::fseek(f, long(size - tail), SEEK_SET) != 0 || std::fread(&end[0], 1, tail, f) != tail) return false;
  const size_t last = end.find_last_not_of(" \t\r\n");
  if (last == std::string::npos) return false;
  const size_t lineStart = end.find_last_of('\n', last);
  const size_t first = end.find_first_not_of(" \t", lineStart == std::string::npos ? 0 : lineStart + 1);
  return end.compare(first, 8, "endsolid") == 0;
}

// An .stl that is not a well-formed binary STL must be a complete ASCII STL:
// "solid" at the start and "endsolid" at the end (assimp stops quietly where
// a text file is cut off). Otherwise it is a damaged binary STL, whose header
// count `n` disagrees with its size.
void requireCompleteAsciiStl(const std::string& path, std::FILE* f, uint64_t size, uint32_t n) {
  if (!startsWithSolid(f)) {
    fail(path, size < kStlHeader
                   ? "too short for a binary STL (" + std::to_string(size) + " bytes) and not ASCII STL"
                   : "truncated or corrupt binary STL: the header says " + std::to_string(n) +
                         " triangles, which take " + std::to_string(kStlHeader + kStlRecord * uint64_t(n)) +
                         " bytes, but the file has " + std::to_string(size));
  }
  if (!endsWithEndsolid(f, size)) fail(path, "truncated ASCII STL: no 'endsolid' at the end");
}

TriangleMesh readBinaryStl(const std::string& path, std::FILE* f, uint32_t n) {
  if (n == 0) fail(path, "binary STL with no triangles");
  if (uint64_t(n) * 3 > UINT32_MAX) fail(path, "too many triangles for 32-bit indices");
  TriangleMesh mesh;
  mesh.points.resize(size_t(n) * 9);
  mesh.triangles.resize(size_t(n) * 3);
  constexpr uint32_t kChunk = 1 << 16; // triangles read at a time
  std::vector<unsigned char> buffer(size_t(kChunk) * kStlRecord);
  for (uint32_t first = 0; first < n; first += kChunk) {
    const uint32_t count = std::min(kChunk, n - first);
    if (std::fread(buffer.data(), kStlRecord, count, f) != count) fail(path, "read error in binary STL");
    for (uint32_t i = 0; i < count; ++i) {
      const unsigned char* record = buffer.data() + size_t(i) * kStlRecord + 12; // skip the normal
      double* out = mesh.points.data() + (size_t(first) + i) * 9;
      for (int k = 0; k < 9; ++k) out[k] = readLeFloat(record + 4 * k);
    }
  }
  for (size_t i = 0; i < mesh.triangles.size(); ++i) mesh.triangles[i] = uint32_t(i);
  return mesh;
}

// ---- PLY ----------------------------------------------------------------------------
// Built in because assimp 5.2's PLY loader trusts the header: a truncated
// binary file gives garbage triangles or a crash. This reader checks every
// count against the bytes that are there before it allocates or reads.
//
// Header: "ply", "format ascii|binary_little_endian|binary_big_endian 1.0",
// then elements, each with properties (scalar, or "list COUNT_TYPE ITEM_TYPE").
// We need element "vertex" with x, y, z and element "face" with the list
// "vertex_indices" (or "vertex_index"); everything else is skipped. Polygons
// are split into fans (0, i, i + 1).

bool hostIsLittleEndian() {
  const uint16_t one = 1;
  uint8_t first;
  std::memcpy(&first, &one, 1);
  return first == 1;
}

enum class PlyType { Int8, Uint8, Int16, Uint16, Int32, Uint32, Float32, Float64 };

bool plyTypeOf(const std::string& name, PlyType& type) {
  static const std::pair<const char*, PlyType> names[] = {
      {"char", PlyType::Int8},     {"int8", PlyType::Int8},       {"uchar", PlyType::Uint8},
      {"uint8", PlyType::Uint8},   {"short", PlyType::Int16},     {"int16", PlyType::Int16},
      {"ushort", PlyType::Uint16}, {"uint16", PlyType::Uint16},   {"int", PlyType::Int32},
      {"int32", PlyType::Int32},   {"uint", PlyType::Uint32},     {"uint32", PlyType::Uint32},
      {"float", PlyType::Float32}, {"float32", PlyType::Float32}, {"double", PlyType::Float64},
      {"float64", PlyType::Float64}};
  for (const auto& [n, t] : names) {
    if (name == n) {
      type = t;
      return true;
    }
  }
  return false;
}

size_t plySize(PlyType t) {
  switch (t) {
  case PlyType::Int8: case PlyType::Uint8: return 1;
  case PlyType::Int16: case PlyType::Uint16: return 2;
  case PlyType::Int32: case PlyType::Uint32: case PlyType::Float32: return 4;
  case PlyType::Float64: return 8;
  }
  return 0;
}

struct PlyProperty {
  std::string name;
  bool isList = false;
  PlyType countType = PlyType::Uint8; // lists only
  PlyType type = PlyType::Float32;    // the value, or the list items
};

struct PlyElement {
  std::string name;
  uint64_t count = 0;
  std::vector<PlyProperty> properties;
};

// Reads values from the body in one of the three encodings; every read is
// bounds-checked and failures name what was being read.
class PlyBody {
public:
  enum class Format { Ascii, LittleEndian, BigEndian };
  PlyBody(const std::string& path, const std::string& data, size_t pos, Format format)
      : path_(path), data_(data), pos_(pos), format_(format) {}

  double read(PlyType t, const char* what) {
    if (format_ == Format::Ascii) return readText(what);
    const size_t n = plySize(t);
    if (data_.size() - pos_ < n) fail(path_, std::string("truncated: the file ends inside ") + what);
    unsigned char b[8];
    std::memcpy(b, data_.data() + pos_, n);
    pos_ += n;
    if ((format_ == Format::LittleEndian) != hostIsLittleEndian()) std::reverse(b, b + n);
    switch (t) {
    case PlyType::Int8: return double(int8_t(b[0]));
    case PlyType::Uint8: return double(b[0]);
    case PlyType::Int16: { int16_t v; std::memcpy(&v, b, 2); return v; }
    case PlyType::Uint16: { uint16_t v; std::memcpy(&v, b, 2); return v; }
    case PlyType::Int32: { int32_t v; std::memcpy(&v, b, 4); return v; }
    case PlyType::Uint32: { uint32_t v; std::memcpy(&v, b, 4); return v; }
    case PlyType::Float32: { float v; std::memcpy(&v, b, 4); return v; }
    case PlyType::Float64: { double v; std::memcpy(&v, b, 8); return v; }
    }
    return 0;
  }

  // The fewest bytes one value can take: 1 byte of text ("0" plus a separator
  // is 2, but the last value may end the file), or its binary size.
  size_t minBytes(PlyType t) const { return format_ == Format::Ascii ? 1 : plySize(t); }
  size_t remaining() const { return data_.size() - pos_; }

private:
  double readText(const char* what) {
    while (pos_ < data_.size() && std::isspace(static_cast<unsigned char>(data_[pos_]))) ++pos_;
    if (pos_ == data_.size()) fail(path_, std::string("truncated: the file ends inside ") + what);
    const char* begin = data_.c_str() + pos_;
    char* end = nullptr;
    const double v = std::strtod(begin, &end);
    if (end == begin || (*end != '\0' && !std::isspace(static_cast<unsigned char>(*end)))) {
      size_t token = 0;
      while (token < 32 && begin[token] != '\0' && !std::isspace(static_cast<unsigned char>(begin[token]))) ++token;
      fail(path_, std::string("not a number in ") + what + ": '" + std::string(begin, token) + "'");
    }
    pos_ += size_t(end - begin);
    return v;
  }

  const std::string& path_;
  const std::string& data_;
  size_t pos_;
  Format format_;
};

std::vector<MeshArray>& noArrays() {
  static thread_local std::vector<MeshArray> none;
  return none;
}

// labelProperty: the integer face property that labels the triangles, or "".
// arrays: when given, the scalar vertex or face properties named by their
// names are read into them (MeshArray::name set, the rest filled here).
TriangleMesh readPly(const std::string& path, std::FILE* f, uint64_t size, const std::string& labelProperty = "",
                     std::vector<MeshArray>* arrays = nullptr) {
  std::string data(size, '\0');
  if (std::fread(&data[0], 1, size, f) != size) fail(path, "read error");

  // ---- header
  size_t pos = 0;
  auto nextLine = [&]() -> std::string {
    const size_t end = data.find('\n', pos);
    if (end == std::string::npos) fail(path, "PLY header has no end_header line");
    std::string line = data.substr(pos, end - pos);
    if (!line.empty() && line.back() == '\r') line.pop_back();
    pos = end + 1;
    return line;
  };
  if (nextLine() != "ply") fail(path, "not a PLY file (the first line is not 'ply')");
  PlyBody::Format format = PlyBody::Format::Ascii;
  bool haveFormat = false;
  std::vector<PlyElement> elements;
  for (std::string line = nextLine(); line != "end_header"; line = nextLine()) {
    std::istringstream words(line);
    std::string keyword;
    words >> keyword;
    if (keyword == "format") {
      std::string name, version;
      words >> name >> version;
      if (name == "ascii") format = PlyBody::Format::Ascii;
      else if (name == "binary_little_endian") format = PlyBody::Format::LittleEndian;
      else if (name == "binary_big_endian") format = PlyBody::Format::BigEndian;
      else fail(path, "unknown PLY format '" + name + "'");
      haveFormat = true;
    } else if (keyword == "element") {
      PlyElement e;
      if (!(words >> e.name >> e.count)) fail(path, "malformed PLY line '" + line + "'");
      elements.push_back(e);
    } else if (keyword == "property") {
      if (elements.empty()) fail(path, "PLY property before any element");
      PlyProperty p;
      std::string type;
      words >> type;
      if (type == "list") {
        std::string countType;
        words >> countType >> type;
        p.isList = true;
        if (!plyTypeOf(countType, p.countType)) fail(path, "unknown PLY type '" + countType + "'");
      }
      if (!plyTypeOf(type, p.type) || !(words >> p.name)) fail(path, "malformed PLY line '" + line + "'");
      elements.back().properties.push_back(p);
    } else if (keyword != "comment" && keyword != "obj_info" && !keyword.empty()) {
      fail(path, "unknown PLY header line '" + line + "'");
    }
  }
  if (!haveFormat) fail(path, "PLY header has no format line");

  // ---- body
  PlyBody body(path, data, pos, format);
  TriangleMesh mesh;
  bool haveVertices = false, haveFaces = false;
  for (const PlyElement& e : elements) {
    // Refuse absurd counts before allocating or looping. Every entry takes at
    // least minBytes of the body; an element without properties takes none,
    // so its count is bounded by the file size instead (no real file declares
    // more entries than it has bytes) and its entries are not iterated.
    size_t minBytes = 0;
    for (const PlyProperty& p : e.properties) minBytes += body.minBytes(p.isList ? p.countType : p.type);
    const uint64_t room = minBytes > 0 ? body.remaining() / minBytes : uint64_t(data.size());
    if (e.count > room) {
      fail(path, "truncated: element '" + e.name + "' declares " + std::to_string(e.count) +
                     " entries but the file is too short for them");
    }
    const bool isVertex = e.name == "vertex", isFace = e.name == "face";
    int axis[3] = {-1, -1, -1}, indices = -1, labelIndex = -1;
    std::vector<std::pair<size_t, MeshArray*>> wanted; // property index -> array it fills
    for (size_t i = 0; i < e.properties.size(); ++i) {
      const PlyProperty& p = e.properties[i];
      for (MeshArray& a : arrays ? *arrays : noArrays()) {
        if ((isVertex || isFace) && !p.isList && p.name == a.name && a.values.empty() && a.components == 0) {
          a.source = isVertex ? ArraySource::Point : ArraySource::Cell;
          a.components = 1;
          wanted.emplace_back(i, &a);
        }
      }
      if (isFace && !p.isList && !labelProperty.empty() && p.name == labelProperty) {
        if (p.type == PlyType::Float32 || p.type == PlyType::Float64)
          fail(path, "PLY face property '" + labelProperty + "' is not an integer property");
        labelIndex = int(i);
      }
      if (isVertex && !p.isList && p.name.size() == 1 && p.name[0] >= 'x' && p.name[0] <= 'z') axis[p.name[0] - 'x'] = int(i);
      if (isFace && p.isList && (p.name == "vertex_indices" || p.name == "vertex_index")) indices = int(i);
    }
    if (isVertex && (axis[0] < 0 || axis[1] < 0 || axis[2] < 0)) fail(path, "PLY vertex element lacks x, y or z");
    if (isFace && indices < 0) fail(path, "PLY face element has no vertex_indices list");
    if (isFace && !labelProperty.empty() && labelIndex < 0)
      fail(path, "PLY face element has no property '" + labelProperty + "' to take labels from");
    if (e.properties.empty()) continue; // empty records: nothing to read
    if (isVertex) {
      haveVertices = true;
      mesh.points.reserve(size_t(e.count) * 3);
    }
    haveFaces |= isFace;

    std::vector<double> list;
    std::vector<double> picked(wanted.size());
    for (uint64_t n = 0; n < e.count; ++n) {
      double xyz[3] = {};
      double label = -1;
      const size_t trianglesBefore = mesh.triangleCount();
      for (size_t i = 0; i < e.properties.size(); ++i) {
        const PlyProperty& p = e.properties[i];
        if (!p.isList) {
          const double v = body.read(p.type, e.name.c_str());
          for (int a = 0; a < 3; ++a)
            if (axis[a] == int(i)) xyz[a] = v;
          if (int(i) == labelIndex) label = v;
          for (size_t k = 0; k < wanted.size(); ++k)
            if (wanted[k].first == i) picked[k] = v;
          continue;
        }
        const double count = body.read(p.countType, e.name.c_str());
        if (!(count >= 0) || count != std::floor(count)) fail(path, e.name + " " + std::to_string(n) + ": bad list length");
        if (count * double(body.minBytes(p.type)) > double(body.remaining())) {
          fail(path, "truncated: the file ends inside " + e.name + " " + std::to_string(n));
        }
        list.resize(size_t(count));
        for (double& v : list) v = body.read(p.type, e.name.c_str());
        if (int(i) != indices) continue;
        for (double v : list) {
          if (!(v >= 0) || v > double(UINT32_MAX) || v != std::floor(v)) {
            fail(path, "face " + std::to_string(n) + " has the vertex index " + std::to_string(v));
          }
        }
        for (size_t k = 1; k + 1 < list.size(); ++k) { // a fan; fewer than 3 corners give nothing
          if (mesh.triangles.size() + 3 > UINT32_MAX) fail(path, "too many triangles for 32-bit indices");
          mesh.triangles.insert(mesh.triangles.end(), {uint32_t(list[0]), uint32_t(list[k]), uint32_t(list[k + 1])});
        }
      }
      if (isVertex) mesh.points.insert(mesh.points.end(), {xyz[0], xyz[1], xyz[2]});
      // A vertex value once, a face value once per triangle of the face.
      const size_t copies = isVertex ? 1 : mesh.triangleCount() - trianglesBefore;
      for (size_t k = 0; k < wanted.size(); ++k) wanted[k].second->values.insert(wanted[k].second->values.end(), copies, picked[k]);
      if (isFace && labelIndex >= 0) {
        if (!(label >= 1 && label <= 65535)) {
          fail(path, "face " + std::to_string(n) + " has the label " + std::to_string(int64_t(label)) +
                         " in '" + labelProperty + "' (labels are 1 to 65535; 0 means outside)");
        }
        mesh.triangleLabels.resize(mesh.triangleCount(), Label(label));
      }
    }
  }
  for (const MeshArray& a : arrays ? *arrays : noArrays())
    if (a.components == 0) fail(path, "no scalar vertex or face property '" + a.name + "' to transfer");
  if (!haveVertices) fail(path, "PLY file has no vertex element");
  if (!haveFaces) fail(path, "PLY file has no face element");
  // Checked here, not per face: the vertex element may come after the faces.
  for (uint32_t index : mesh.triangles) {
    if (index >= mesh.pointCount()) {
      fail(path, "a face refers to vertex " + std::to_string(index) + " but the file has " +
                     std::to_string(mesh.pointCount()) + " vertices");
    }
  }
  return mesh;
}

// ---- ASCII STL and OBJ, through assimp ------------------------------------------------
#if defined(HDT_HAVE_ASSIMP)

// Labels by OBJ group (node) or material, while the scene is walked.
struct AssimpLabels {
  MeshLabelSource::Kind kind = MeshLabelSource::Kind::None;
  std::map<std::string, Label> groups; // node name -> label
  Label labelOf(const aiScene& scene, const aiNode& node, const aiMesh& mesh, TriangleMesh& out) {
    if (kind == MeshLabelSource::Kind::ObjMaterial) {
      if (mesh.mMaterialIndex >= 65535) throw Error(ErrorKind::BadInput, "more than 65535 materials");
      const Label label = Label(mesh.mMaterialIndex + 1);
      aiString name;
      if (mesh.mMaterialIndex < scene.mNumMaterials &&
          scene.mMaterials[mesh.mMaterialIndex]->Get(AI_MATKEY_NAME, name) == AI_SUCCESS)
        out.labelNames[label] = name.C_Str();
      return label;
    }
    const std::string name = node.mName.length ? node.mName.C_Str() : mesh.mName.C_Str();
    const auto it = groups.find(name);
    if (it != groups.end()) return it->second;
    if (groups.size() >= 65535) throw Error(ErrorKind::BadInput, "more than 65535 groups");
    const Label label = Label(groups.size() + 1);
    groups.emplace(name, label);
    out.labelNames[label] = name;
    return label;
  }
};

void appendNode(const aiScene& scene, const aiNode& node, const aiMatrix4x4& parent, TriangleMesh& out,
                AssimpLabels& labels) {
  const aiMatrix4x4 transform = parent * node.mTransformation;
  for (unsigned m = 0; m < node.mNumMeshes; ++m) {
    const aiMesh& mesh = *scene.mMeshes[node.mMeshes[m]];
    const Label label = labels.kind == MeshLabelSource::Kind::None ? 0 : labels.labelOf(scene, node, mesh, out);
    const size_t base = out.pointCount();
    if (base + mesh.mNumVertices > UINT32_MAX) throw Error(ErrorKind::BadInput, "too many points for 32-bit indices");
    for (unsigned v = 0; v < mesh.mNumVertices; ++v) {
      const aiVector3D p = transform * mesh.mVertices[v];
      out.points.insert(out.points.end(), {double(p.x), double(p.y), double(p.z)});
    }
    for (unsigned f = 0; f < mesh.mNumFaces; ++f) {
      const aiFace& face = mesh.mFaces[f];
      if (face.mNumIndices != 3) continue; // points and lines: no surface
      for (int k = 0; k < 3; ++k) out.triangles.push_back(uint32_t(base + face.mIndices[k]));
      if (labels.kind != MeshLabelSource::Kind::None) out.triangleLabels.push_back(label);
    }
  }
  for (unsigned c = 0; c < node.mNumChildren; ++c) appendNode(scene, *node.mChildren[c], transform, out, labels);
}

TriangleMesh readWithAssimp(const std::string& path, MeshLabelSource::Kind labelKind = MeshLabelSource::Kind::None) {
  Assimp::Importer importer;
  // Triangulate only: joining vertices, dropping degenerates or sorting by
  // primitive type would change what the file says.
  const aiScene* scene = importer.ReadFile(path, aiProcess_Triangulate);
  if (scene == nullptr) {
    const std::string why = importer.GetErrorString();
    fail(path, why.empty() ? "cannot parse the file" : why);
  }
  if (scene->mRootNode == nullptr) fail(path, "the file holds no geometry");
  TriangleMesh mesh;
  AssimpLabels labels;
  labels.kind = labelKind;
  try {
    appendNode(*scene, *scene->mRootNode, aiMatrix4x4(), mesh, labels);
  } catch (const Error& e) {
    fail(path, e.what());
  }
  return mesh;
}
#else
TriangleMesh readWithAssimp(const std::string& path, MeshLabelSource::Kind = MeshLabelSource::Kind::None) {
  fail(path, "this build reads only binary STL and PLY (it was built without assimp; install "
             "libassimp-dev and reconfigure to read ASCII STL and OBJ)");
}
#endif

} // namespace

bool readsAllMeshFormats() {
#if defined(HDT_HAVE_ASSIMP)
  return true;
#else
  return false;
#endif
}

TriangleMesh readMesh(const std::string& path) { return readMesh(path, MeshLabelSource{}); }

void labelConnectedComponents(TriangleMesh& mesh) {
  // Union-find over points; points at the same position (exactly) start
  // joined, so that triangle soups (STL) connect too. A component's label
  // follows its first triangle.
  const size_t np = mesh.pointCount();
  std::vector<uint32_t> parent(np);
  for (uint32_t i = 0; i < parent.size(); ++i) parent[i] = i;
  {
    std::vector<uint32_t> order(np);
    for (uint32_t i = 0; i < np; ++i) order[i] = i;
    const double* p = mesh.points.data();
    auto less = [p](uint32_t a, uint32_t b) {
      return std::lexicographical_compare(p + 3 * a, p + 3 * a + 3, p + 3 * b, p + 3 * b + 3);
    };
    std::sort(order.begin(), order.end(), [&](uint32_t a, uint32_t b) { return less(a, b) || (!less(b, a) && a < b); });
    for (size_t i = 1; i < np; ++i)
      if (!less(order[i - 1], order[i])) parent[order[i]] = order[i - 1]; // equal: ties sorted by index
  }
  auto find = [&](uint32_t x) {
    while (parent[x] != x) x = parent[x] = parent[parent[x]];
    return x;
  };
  for (size_t t = 0; t < mesh.triangleCount(); ++t) {
    const uint32_t a = find(mesh.triangles[3 * t]);
    for (int c = 1; c < 3; ++c) {
      const uint32_t b = find(mesh.triangles[3 * t + size_t(c)]);
      if (a != b) parent[std::max(a, b)] = std::min(a, b);
    }
  }
  std::map<uint32_t, Label> labelOfRoot;
  mesh.triangleLabels.resize(mesh.triangleCount());
  for (size_t t = 0; t < mesh.triangleCount(); ++t) {
    const uint32_t root = find(mesh.triangles[3 * t]);
    auto it = labelOfRoot.find(root);
    if (it == labelOfRoot.end()) {
      if (labelOfRoot.size() >= 65535) throw Error(ErrorKind::BadInput, "more than 65535 connected components");
      it = labelOfRoot.emplace(root, Label(labelOfRoot.size() + 1)).first;
    }
    mesh.triangleLabels[t] = it->second;
  }
}

TriangleMesh readMesh(const std::string& path, const MeshLabelSource& labels) {
  std::vector<MeshArray> none;
  return readMesh(path, labels, none);
}

TriangleMesh readMesh(const std::string& path, const MeshLabelSource& labels, std::vector<MeshArray>& arrays) {
  using Kind = MeshLabelSource::Kind;
  uint64_t size = 0;
  File f = openRegular(path, size);
  const std::string ext = lowerExtension(path);
  if (ext != ".stl" && ext != ".obj" && ext != ".ply") {
    fail(path, (ext.empty() ? std::string("no file extension") : "unknown extension '" + ext + "'") +
                   " (readable: .stl, .obj, .ply)");
  }
  if (size == 0) fail(path, "the file is empty");

  if (labels.kind == Kind::PlyFaceProperty && ext != ".ply")
    fail(path, "labels from a PLY face property need a .ply file");
  if (!arrays.empty() && ext != ".ply") fail(path, "arrays to transfer are read from PLY vertex and face properties only");
  if ((labels.kind == Kind::ObjGroup || labels.kind == Kind::ObjMaterial) && ext != ".obj")
    fail(path, "labels from OBJ groups or materials need an .obj file");
  TriangleMesh mesh;
  uint32_t n = 0;
  if (ext == ".ply") {
    for (MeshArray& a : arrays) {
      a.components = 0; // found by readPly
      a.values.clear();
    }
    mesh = readPly(path, f.get(), size, labels.kind == Kind::PlyFaceProperty ? labels.property : "",
                   arrays.empty() ? nullptr : &arrays);
  } else if (ext == ".stl" && binaryStlCount(f.get(), size, n)) {
    mesh = readBinaryStl(path, f.get(), n);
  } else {
    if (ext == ".stl") requireCompleteAsciiStl(path, f.get(), size, n);
    f.reset();
    mesh = readWithAssimp(path, labels.kind == Kind::ObjGroup || labels.kind == Kind::ObjMaterial ? labels.kind
                                                                                                  : Kind::None);
  }
  if (mesh.triangleCount() == 0) fail(path, "no triangles in the file");
  if (labels.kind == Kind::Components) {
    try {
      labelConnectedComponents(mesh);
    } catch (const Error& e) {
      fail(path, e.what());
    }
  }
  return mesh;
}

} // namespace hdt
