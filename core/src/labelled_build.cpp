// The labelled build (hdt/labels.hpp): each part built alone by the
// dispatched driver on the whole mesh's grid, then combined.
#include "hdt/labels.hpp"

#include "hdt/error.hpp"
#include "hdt/mesh.hpp"

#include <chrono>
#include <map>
#include <string>
#include <utility>

namespace hdt {

namespace {

// The triangles of each label as a mesh of their own (points renumbered),
// ascending by label.
std::vector<std::pair<Label, TriangleMesh>> splitByLabel(const TriangleMesh& mesh) {
  const size_t n = mesh.triangleCount();
  if (mesh.triangleLabels.size() != n) {
    throw Error(ErrorKind::BadInput, "labelled build: " + std::to_string(mesh.triangleLabels.size()) +
                                         " triangle labels for " + std::to_string(n) + " triangles");
  }
  std::map<Label, TriangleMesh> parts;
  std::map<Label, std::vector<uint32_t>> pointMaps;
  for (size_t t = 0; t < n; ++t) {
    const Label label = mesh.triangleLabels[t];
    if (label == kOutsideLabel)
      throw Error(ErrorKind::BadInput, "labelled build: triangle " + std::to_string(t) +
                                           " has label 0, which is reserved for outside");
    TriangleMesh& part = parts[label];
    std::vector<uint32_t>& map = pointMaps[label];
    if (map.empty()) map.assign(mesh.pointCount(), ~0u);
    for (int c = 0; c < 3; ++c) {
      const uint32_t p = mesh.triangles[3 * t + size_t(c)];
      if (p >= mesh.pointCount())
        throw Error(ErrorKind::BadInput, "triangle " + std::to_string(t) + " has a point index out of range");
      if (map[p] == ~0u) {
        map[p] = uint32_t(part.pointCount());
        part.points.insert(part.points.end(), mesh.points.begin() + 3 * p, mesh.points.begin() + 3 * p + 3);
      }
      part.triangles.push_back(map[p]);
    }
  }
  std::vector<std::pair<Label, TriangleMesh>> out;
  for (auto& [label, part] : parts) out.emplace_back(label, std::move(part));
  return out;
}

} // namespace

namespace {

// The CUDA driver's labelled build where the backend asks for it (Auto: a
// usable device); false where the per-part path must run. Auto falls back
// on a device failure as build() does; Cuda reports it.
bool buildOnDevice(const TriangleMesh& mesh, const BuildConfig& placed, const std::vector<PreparedMesh>& parts,
                   const std::vector<Label>& partLabels, const LabelOptions& labels, const BuildOptions& options,
                   Volume& out) {
  if (options.backend == Backend::Cpu || (options.backend == Backend::Auto && !cudaAvailable(nullptr))) return false;
  BuildConfig surface = placed;
  surface.surfaceOnly = true; // the whole mesh gives the tree and the surface, the parts the inside
  try {
    return buildLabelledCuda(prepareMesh(mesh, surface), parts, partLabels, labels, options, out);
  } catch (const Error& e) {
    if (e.kind() == ErrorKind::Aborted || options.backend == Backend::Cuda) throw;
    if (options.log)
      options.log(std::string("backend auto: CUDA labelled build failed (") + e.what() + "); per-part builds follow");
    return false;
  }
}

} // namespace

Volume voxelizeLabelled(const TriangleMesh& mesh, const BuildConfig& config, const BuildOptions& options,
                        const LabelOptions& labels) {
  // One placement for all parts: the whole mesh's (or the caller's) box.
  BuildConfig placed = config;
  if (!placed.hasBounds) {
    meshBounds(mesh, placed.boundsMin, placed.boundsMax);
    placed.hasBounds = true;
  }
  const auto t0 = std::chrono::steady_clock::now();
  std::vector<std::pair<Label, TriangleMesh>> split = splitByLabel(mesh);
  std::vector<PreparedMesh> prepared;
  std::vector<Label> partLabels;
  prepared.reserve(split.size());
  for (auto& [label, part] : split) {
    prepared.push_back(prepareMesh(part, placed));
    part = TriangleMesh{}; // the part's points are no longer needed
    partLabels.push_back(label);
  }
  if (options.log) {
    options.log("labelled build: " + std::to_string(prepared.size()) + " parts split and prepared in " +
                std::to_string(int(std::chrono::duration<double, std::milli>(std::chrono::steady_clock::now() - t0).count())) +
                " ms");
  }
  Volume v;
  if (!buildOnDevice(mesh, placed, prepared, partLabels, labels, options, v)) {
    std::vector<Volume> parts;
    parts.reserve(prepared.size());
    for (size_t i = 0; i < prepared.size(); ++i) {
      BuildOptions partOptions = options;
      if (options.progress) {
        const double n = double(prepared.size());
        partOptions.progress = [&, i, n](double f, const char* phase) {
          return options.progress((double(i) + f) / n, phase);
        };
      }
      parts.push_back(build(prepared[i], partOptions));
    }
    v = combineLabelledParts(parts, partLabels, labels);
  }
  for (const auto& [label, name] : mesh.labelNames)
    if (label != kOutsideLabel) v.labels.names[label] = name;
  return v;
}

} // namespace hdt
