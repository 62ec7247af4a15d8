// Command line of hdt-voxelize: what it accepts and the parsed result.
#pragma once

#include "hdt/builder.hpp"
#include "hdt/config.hpp"
#include "hdt/hdt_file.hpp"
#include "hdt/labels.hpp"
#include "hdt/mesh_io.hpp"

#include <stdexcept>
#include <string>
#include <vector>

namespace hdt::cli {

// --compression-level: zstd's levels without its "ultra" ones (20-22 need far
// more memory) and without the negative ones (on leaf data they save little
// time for much larger files: bench/results/end-to-end.md), as ParaView's writer.
constexpr int kMinCompressionLevel = 1, kMaxCompressionLevel = 19;

struct Options {
  std::string mesh;           // a file path or builtin:NAME
  BuildConfig config;         // resolution, root grid, leaf size, surface-only
  BuildOptions build;         // backend, device, threads
  std::string hdtPath;        // -o
  int compressionLevel = HdtWriteOptions{}.zstdLevel; // --compression-level: -o's zstd level
  std::string densePath;      // --dense
  MeshLabelSource labels;     // --labels
  LabelOptions overlap;       // --overlap
  std::string denseLabelsPath; // --dense-labels
  std::vector<std::string> transfer; // --transfer (repeatable): PLY properties onto surface voxels
  bool json = false;
  bool quiet = false;
  bool help = false;
};

// A malformed command line (CLI exit code 2).
class UsageError : public std::runtime_error {
public:
  using std::runtime_error::runtime_error;
};

// Parses argv. Throws UsageError for an unknown option, a missing or
// malformed value, or a missing / extra MESH. Values are checked only for
// syntax and sign here; hdt::validateConfig judges the sizes.
Options parseOptions(int argc, const char* const* argv);

std::string usageText();

} // namespace hdt::cli
