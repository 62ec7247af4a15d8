#include "cli_options.hpp"

#include <algorithm>
#include "hdt/winding_tree.hpp"

#include <cerrno>
#include <climits>
#include <cstdlib>

namespace hdt::cli {
namespace {

// A whole-string decimal integer in [lo, INT_MAX]; no silent truncation of "12x" or "1e3".
int parseInt(const std::string& flag, const std::string& text, int lo) {
  errno = 0;
  char* end = nullptr;
  const long v = std::strtol(text.c_str(), &end, 10);
  if (text.empty() || *end != '\0' || errno == ERANGE || v < INT_MIN || v > INT_MAX) {
    throw UsageError(flag + " expects an integer, got '" + text + "'");
  }
  if (v < lo) throw UsageError(flag + " must be at least " + std::to_string(lo) + ", got " + text);
  return int(v);
}

Backend parseBackend(const std::string& text) {
  if (text == "auto") return Backend::Auto;
  if (text == "cpu") return Backend::Cpu;
  if (text == "cuda") return Backend::Cuda;
  throw UsageError("--backend expects auto, cpu or cuda, got '" + text + "'");
}

InsideTest parseInsideTest(const std::string& text) {
  if (text == "auto") return InsideTest::Auto;
  if (text == "parity") return InsideTest::Parity;
  if (text == "winding") return InsideTest::WindingNumber;
  throw UsageError("--inside-test expects auto, parity or winding, got '" + text + "'");
}

} // namespace

std::string usageText() {
  const BuildConfig defaults;
  return "usage: hdt-voxelize MESH [options]\n"
         "\n"
         "Voxelizes a triangle mesh into an HDT (hybrid dynamic tree) sparse volume.\n"
         "MESH is an .stl, .obj or .ply file, or builtin:NAME (sphere, torus, knot).\n"
         "\n"
         "options:\n"
         "  --resolution N   voxels along the longest side; N = R * 2^h * L (default " +
         std::to_string(defaults.resolution) +
         ")\n"
         "  --root-grid R    root grid cells per axis (default " +
         std::to_string(defaults.rootGrid) +
         ")\n"
         "  --leaf-size L    leaf grid voxels per axis: 8, 16 or 32 (default " +
         std::to_string(defaults.leafSize) +
         ")\n"
         "  --backend B      auto, cpu or cuda (default auto: CUDA when a device is usable)\n"
         "  --device N       CUDA device ordinal (default 0)\n"
         "  --threads T      CPU threads, at most " + std::to_string(kMaxCpuThreads) +
         " (default 0: all cores)\n"
         "  --surface-only   mark surface voxels only; skip inside/outside classification\n"
         "  --inside-test T  auto, parity or winding (default " + std::string(insideTestName(defaults.insideTest)) +
         "): auto: ray parity\n"
         "                   for closed meshes (exact), the winding number for open ones;\n"
         "                   parity: ray parity always (open meshes: a heuristic); winding: the\n"
         "                   generalized winding number (inside where w >= 1/2, exact at every\n"
         "                   voxel centre) always\n"
         "  -o OUT.hdt       write the volume as an .hdt file (checked before the build,\n"
         "                   replaced atomically; never the input mesh)\n"
         "  --compression-level Z  zstd level of -o's leaf data, " + std::to_string(kMinCompressionLevel) + " (fastest) to " +
         std::to_string(kMaxCompressionLevel) + " (smallest)\n"
         "                   (default " + std::to_string(HdtWriteOptions{}.zstdLevel) +
         "); every level gives a file every reader reads\n"
         "  --dense OUT.nrrd write a dense N^3 uint8 NRRD (0 outside, 1 inside, 2 surface; N <= 1024)\n"
         "  --labels SOURCE  label the voxels by part: ply:PROPERTY (an integer face property),\n"
         "                   obj:group, obj:material, or components (connected components)\n"
         "  --overlap P      where parts claim one voxel: lowest (default), highest, or a\n"
         "                   priority list of labels, e.g. 3,1,2 (first wins; others lowest first)\n"
         "  --dense-labels OUT.nrrd  write the labels as a dense N^3 uint16 NRRD (N <= 1024)\n"
         "  --transfer NAME  carry the PLY vertex (or else face) property NAME onto the surface\n"
         "                   voxels (float32, in the .hdt file); repeatable\n"
         "  --json           print the statistics as one JSON object on stdout\n"
         "  --quiet          no progress, notes or warnings on stderr (errors still go there)\n"
         "  -h, --help       print this help and exit\n"
         "\n"
         "exit codes: 0 ok, 2 usage or invalid option, 3 bad input file or mesh,\n"
         "            4 out of memory or device resources, 5 cannot write an output file,\n"
         "            1 anything else\n";
}

MeshLabelSource parseLabelSource(const std::string& v) {
  using Kind = MeshLabelSource::Kind;
  if (v == "obj:group") return {Kind::ObjGroup, ""};
  if (v == "obj:material") return {Kind::ObjMaterial, ""};
  if (v == "components") return {Kind::Components, ""};
  if (v.rfind("ply:", 0) == 0 && v.size() > 4) return {Kind::PlyFaceProperty, v.substr(4)};
  throw UsageError("--labels expects ply:PROPERTY, obj:group, obj:material or components, got '" + v + "'");
}

LabelOptions parseOverlap(const std::string& v) {
  LabelOptions o;
  if (v == "lowest") return o;
  if (v == "highest") {
    o.overlap = OverlapPolicy::Highest;
    return o;
  }
  o.overlap = OverlapPolicy::Priority;
  size_t at = 0;
  while (at <= v.size()) {
    const size_t comma = std::min(v.find(',', at), v.size());
    const std::string item = v.substr(at, comma - at);
    char* end = nullptr;
    const long label = item.empty() ? -1 : std::strtol(item.c_str(), &end, 10);
    if (label < 1 || label > 65535 || *end != '\0')
      throw UsageError("--overlap expects lowest, highest or labels 1..65535 separated by commas, got '" + v + "'");
    o.priority.push_back(Label(label));
    at = comma + 1;
  }
  return o;
}

Options parseOptions(int argc, const char* const* argv) {
  Options o;
  for (int i = 1; i < argc; ++i) {
    std::string arg = argv[i];
    // "--flag=value" is the same as "--flag value".
    std::string inlineValue;
    bool hasInlineValue = false;
    if (arg.rfind("--", 0) == 0) {
      const size_t eq = arg.find('=');
      if (eq != std::string::npos) {
        inlineValue = arg.substr(eq + 1);
        arg.resize(eq);
        hasInlineValue = true;
      }
    }
    auto value = [&]() -> std::string {
      if (hasInlineValue) return inlineValue;
      if (i + 1 >= argc) throw UsageError(arg + " expects a value");
      return argv[++i];
    };
    auto set = [&](bool& flag) {
      if (hasInlineValue) throw UsageError(arg + " takes no value");
      flag = true;
    };

    if (arg == "-h" || arg == "--help") set(o.help);
    else if (arg == "--resolution") o.config.resolution = parseInt(arg, value(), 1);
    else if (arg == "--root-grid") o.config.rootGrid = parseInt(arg, value(), 1);
    else if (arg == "--leaf-size") o.config.leafSize = parseInt(arg, value(), 1);
    else if (arg == "--backend") o.build.backend = parseBackend(value());
    else if (arg == "--device") o.build.device = parseInt(arg, value(), 0);
    else if (arg == "--threads") {
      o.build.threads = parseInt(arg, value(), 0);
      if (o.build.threads > kMaxCpuThreads) {
        throw UsageError("--threads must be at most " + std::to_string(kMaxCpuThreads) + ", got " +
                         std::to_string(o.build.threads));
      }
    }
    else if (arg == "--surface-only") set(o.config.surfaceOnly);
    else if (arg == "--inside-test") o.config.insideTest = parseInsideTest(value());
    else if (arg == "-o" || arg == "--output") o.hdtPath = value();
    else if (arg == "--compression-level") {
      o.compressionLevel = parseInt(arg, value(), kMinCompressionLevel);
      if (o.compressionLevel > kMaxCompressionLevel) {
        throw UsageError("--compression-level must be at most " + std::to_string(kMaxCompressionLevel) + ", got " +
                         std::to_string(o.compressionLevel));
      }
    }
    else if (arg == "--dense") o.densePath = value();
    else if (arg == "--labels") o.labels = parseLabelSource(value());
    else if (arg == "--overlap") o.overlap = parseOverlap(value());
    else if (arg == "--dense-labels") o.denseLabelsPath = value();
    else if (arg == "--transfer") o.transfer.push_back(value());
    else if (arg == "--json") set(o.json);
    else if (arg == "--quiet") set(o.quiet);
    else if (arg.size() > 1 && arg[0] == '-') throw UsageError("unknown option '" + arg + "'");
    else if (o.mesh.empty()) o.mesh = arg;
    else throw UsageError("unexpected argument '" + arg + "' (only one MESH is accepted)");
  }
  if (!o.help && o.mesh.empty()) throw UsageError("missing MESH (a mesh file or builtin:NAME)");
  if (!o.hdtPath.empty() && o.hdtPath == o.densePath) throw UsageError("-o and --dense name the same file");
  const std::string outputs[] = {o.hdtPath, o.densePath};
  for (const std::string& p : outputs)
    if (!p.empty() && p == o.denseLabelsPath) throw UsageError("--dense-labels names the same file as another output");
  if (!o.denseLabelsPath.empty() && o.labels.kind == MeshLabelSource::Kind::None)
    throw UsageError("--dense-labels needs --labels");
  return o;
}

} // namespace hdt::cli
