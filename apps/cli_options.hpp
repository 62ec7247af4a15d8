// Command line of hdt-voxelize: what it accepts and the parsed result.
#pragma once

#include "hdt/builder.hpp"
#include "hdt/config.hpp"
#include "hdt/labels.hpp"
#include "hdt/mesh_io.hpp"

#include <stdexcept>
#include <string>
#include <vector>

namespace hdt::cli {

struct Options {
  std::string mesh;           // a file path or builtin:NAME
  BuildConfig config;         // resolution, root grid, leaf size, surface-only
  BuildOptions build;         // backend, device, threads
  std::string hdtPath;        // -o
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
