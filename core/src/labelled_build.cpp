// The labelled build (hdt/labels.hpp): each part built alone by the
// dispatched driver on the whole mesh's grid, then combined.
#include "hdt/labels.hpp"

#include "hdt/error.hpp"
#include "hdt/huge_pages.hpp"
#include "hdt/mesh.hpp"

#include <tbb/blocked_range.h>
#include <tbb/parallel_for.h>

#include <algorithm>
#include <chrono>
#include <functional>
#include <future>
#include <map>
#include <string>
#include <utility>

namespace hdt {

namespace {

// The triangles of each label as a mesh of their own (points renumbered in
// order of first use by the part's triangles, in input order), ascending by
// label. Linear: triangles grouped by label first; then one pass, label by
// label, numbers each part's points with one point map stamped with the part
// that wrote it (a map per label would cost labels x points); then the
// parts are copied side by side into arrays of their final size. (A point
// map per thread, and parts grown point by point, fault in more pages.)
std::vector<std::pair<Label, TriangleMesh>> splitByLabel(const TriangleMesh& mesh) {
  const size_t n = mesh.triangleCount();
  if (mesh.triangleLabels.size() != n) {
    throw Error(ErrorKind::BadInput, "labelled build: " + std::to_string(mesh.triangleLabels.size()) +
                                         " triangle labels for " + std::to_string(n) + " triangles");
  }
  std::vector<uint32_t> first(65537, 0); // per label: its first triangle in `byLabel`
  for (size_t t = 0; t < n; ++t) {
    const Label label = mesh.triangleLabels[t];
    if (label == kOutsideLabel)
      throw Error(ErrorKind::BadInput, "labelled build: triangle " + std::to_string(t) +
                                           " has label 0, which is reserved for outside");
    for (int c = 0; c < 3; ++c)
      if (mesh.triangles[3 * t + size_t(c)] >= mesh.pointCount())
        throw Error(ErrorKind::BadInput, "triangle " + std::to_string(t) + " has a point index out of range");
    ++first[size_t(label) + 1];
  }
  for (size_t l = 1; l < first.size(); ++l) first[l] += first[l - 1];
  std::vector<uint32_t> byLabel(n), next(first.begin(), first.end() - 1);
  for (size_t t = 0; t < n; ++t) byLabel[next[mesh.triangleLabels[t]]++] = uint32_t(t);

  std::vector<Label> labels;
  for (uint32_t label = 1; label < 65536; ++label)
    if (first[label] != first[label + 1]) labels.push_back(Label(label));
  // Part k's points (mesh indices) are partPoint[pointStart[k], pointStart[k + 1]);
  // corner[3 i + c]: corner c of triangle byLabel[i], part-local. One
  // scratch array for all four, large enough for huge pages.
  const size_t points = mesh.pointCount();
  std::vector<uint32_t, HugePageScratchAllocator<uint32_t>> scratch(2 * points + 6 * n);
  uint32_t* const stamp = scratch.data();
  uint32_t* const local = stamp + points;
  uint32_t* const corner = local + points;
  uint32_t* const partPoint = corner + 3 * n;
  std::fill_n(stamp, points, 0u);
  std::vector<size_t> pointStart(labels.size() + 1, 0);
  size_t used = 0; // in partPoint
  for (size_t k = 0; k < labels.size(); ++k) {
    const uint32_t label = labels[k], mark = uint32_t(k + 1);
    pointStart[k] = used;
    for (uint32_t i = first[label]; i < first[label + 1]; ++i) {
      const size_t t = byLabel[i];
      for (int c = 0; c < 3; ++c) {
        const uint32_t p = mesh.triangles[3 * t + size_t(c)];
        if (stamp[p] != mark) {
          stamp[p] = mark;
          local[p] = uint32_t(used - pointStart[k]);
          partPoint[used++] = p;
        }
        corner[3 * size_t(i) + size_t(c)] = local[p];
      }
    }
  }
  pointStart[labels.size()] = used;
  std::vector<std::pair<Label, TriangleMesh>> out(labels.size());
  tbb::parallel_for(size_t(0), labels.size(), [&](size_t k) {
    const uint32_t label = labels[k];
    TriangleMesh part;
    part.points.resize(3 * (pointStart[k + 1] - pointStart[k]));
    for (size_t j = pointStart[k]; j < pointStart[k + 1]; ++j)
      std::copy_n(mesh.points.begin() + 3 * size_t(partPoint[j]), 3, part.points.begin() + 3 * (j - pointStart[k]));
    part.triangles.assign(corner + 3 * size_t(first[label]), corner + 3 * size_t(first[label + 1]));
    out[k] = {Label(label), std::move(part)};
  });
  return out;
}

} // namespace

namespace {

bool deviceAsked(const BuildOptions& options) {
  return options.backend == Backend::Cuda || (options.backend == Backend::Auto && cudaAvailable(nullptr));
}

// The CUDA driver's labelled build (where deviceAsked) of `whole()` (the
// whole mesh prepared on the parts' grid, made inside the guard); false where
// the per-part path must run. Auto falls back on a device failure as build()
// does; Cuda reports it. partsReady: as buildLabelledCuda's.
template <class Whole>
bool buildOnDevice(const Whole& whole, const std::vector<PreparedMesh>& parts, const std::vector<Label>& partLabels,
                   const LabelOptions& labels, const BuildOptions& options, Volume& out,
                   const std::function<void()>& partsReady) {
  try {
    return buildLabelledCuda(whole(), parts, partLabels, labels, options, out, partsReady);
  } catch (const Error& e) {
    if (e.kind() == ErrorKind::Aborted || options.backend == Backend::Cuda) throw;
    options.warning(std::string("backend auto: CUDA labelled build failed (") + e.what() + "); per-part builds follow");
    return false;
  }
}

// The config with the placement all parts share: the caller's bounds, else the whole mesh's.
BuildConfig placedConfig(const TriangleMesh& mesh, const BuildConfig& config) {
  BuildConfig placed = config;
  if (!placed.hasBounds) {
    meshBounds(mesh, placed.boundsMin, placed.boundsMax);
    placed.hasBounds = true;
  }
  return placed;
}

LabelledParts prepareParts(const TriangleMesh& mesh, const BuildConfig& placed) {
  const auto t0 = std::chrono::steady_clock::now();
  std::vector<std::pair<Label, TriangleMesh>> split = splitByLabel(mesh);
  const auto t1 = std::chrono::steady_clock::now();
  // The parts are prepared side by side: many are small, too small to fill
  // the host's threads one after another.
  LabelledParts out;
  out.meshes.resize(split.size());
  out.labels.resize(split.size());
  tbb::parallel_for(size_t(0), split.size(), [&](size_t i) {
    out.meshes[i] = prepareMesh(split[i].second, placed);
    split[i].second = TriangleMesh{}; // the part's points are no longer needed
    out.labels[i] = split[i].first;
  });
  const auto ms = [](std::chrono::steady_clock::time_point a, std::chrono::steady_clock::time_point b) {
    return std::to_string(int(std::chrono::duration<double, std::milli>(b - a).count()));
  };
  out.log = "labelled build: " + std::to_string(out.meshes.size()) + " parts split in " + ms(t0, t1) +
            " ms, prepared in " + ms(t1, std::chrono::steady_clock::now()) + " ms";
  return out;
}

// Every part built alone (by the dispatched driver), combined on the host.
Volume buildPartsAndCombine(const LabelledParts& parts, const BuildOptions& options, const LabelOptions& labels) {
  const std::vector<PreparedMesh>& prepared = parts.meshes;
  std::vector<Volume> partVolumes;
  partVolumes.reserve(prepared.size());
  for (size_t i = 0; i < prepared.size(); ++i) {
    BuildOptions partOptions = options;
    if (options.progress) {
      const double n = double(prepared.size());
      partOptions.progress = [&, i, n](double f, const char* phase) {
        return options.progress((double(i) + f) / n, phase);
      };
    }
    partVolumes.push_back(build(prepared[i], partOptions));
  }
  return combineLabelledParts(partVolumes, parts.labels, labels);
}

void copyNames(const std::map<Label, std::string>& names, LabelField& f) {
  for (const auto& [label, name] : names)
    if (label != kOutsideLabel) f.names[label] = name;
}

} // namespace

Label onlyLabel(const TriangleMesh& mesh) {
  const std::vector<Label>& labels = mesh.triangleLabels;
  if (labels.empty() || labels.size() != mesh.triangleCount() || labels[0] == kOutsideLabel) return kOutsideLabel;
  const Label first = labels[0];
  for (const Label l : labels)
    if (l != first) return kOutsideLabel;
  return first;
}

void labelAsOnePart(Volume& v, Label label, const std::map<Label, std::string>& names) {
  if (label == kOutsideLabel) throw Error(ErrorKind::InvalidArgument, "labelAsOnePart: label 0 is outside");
  // combineLabelledParts of one part: each element is claimed by that part
  // alone, so a Full element and a leaf (even one without a non-Outside
  // voxel) take its label, Empty and Branch elements 0, and no leaf is mixed.
  LabelField& f = v.labels;
  f = LabelField{};
  f.elementLabels.resize(v.elements.size());
  tbb::parallel_for(tbb::blocked_range<size_t>(0, v.elements.size(), size_t(1) << 16),
                    [&](const tbb::blocked_range<size_t>& r) {
                      for (size_t i = r.begin(); i != r.end(); ++i) {
                        const ElementState s = elementState(v.elements[i]);
                        const bool claimed = s == ElementState::Full || s == ElementState::Boundary;
                        f.elementLabels[i] = claimed ? label : kOutsideLabel;
                      }
                    });
  indexMixedLeaves(v);
  copyNames(names, f);
}

LabelledParts prepareLabelledParts(const TriangleMesh& mesh, const BuildConfig& config) {
  return prepareParts(mesh, placedConfig(mesh, config));
}

Volume voxelizeLabelled(const PreparedMesh& whole, const LabelledParts& parts,
                        const std::map<Label, std::string>& names, const BuildOptions& options,
                        const LabelOptions& labels) {
  if (options.log) options.log(parts.log);
  Volume v;
  if (parts.meshes.size() == 1) { // one part: the whole mesh
    v = build(parts.meshes[0], options);
    labelAsOnePart(v, parts.labels[0], names);
    return v;
  }
  const auto prepared = [&whole]() -> const PreparedMesh& { return whole; };
  if (!deviceAsked(options) || !buildOnDevice(prepared, parts.meshes, parts.labels, labels, options, v, {}))
    v = buildPartsAndCombine(parts, options, labels);
  copyNames(names, v.labels);
  return v;
}

Volume voxelizeLabelled(const TriangleMesh& mesh, const BuildConfig& config, const BuildOptions& options,
                        const LabelOptions& labels) {
  // One placement for all parts: the whole mesh's (or the caller's) box.
  const BuildConfig placed = placedConfig(mesh, config);
  if (const Label only = onlyLabel(mesh); only != kOutsideLabel) { // one part: the whole mesh
    Volume v = build(prepareMesh(mesh, placed), options);
    labelAsOnePart(v, only, mesh.labelNames);
    return v;
  }
  LabelledParts parts;
  bool logged = false;
  const auto logParts = [&] {
    if (options.log && !logged) options.log(parts.log);
    logged = true;
  };
  Volume v;
  bool built = false;
  if (deviceAsked(options)) {
    // The parts are split and prepared on the host while the device builds
    // the whole mesh's tree (and the host prepares the whole mesh before).
    std::shared_future<void> partsDone =
        std::async(std::launch::async, [&] { parts = prepareParts(mesh, placed); }).share();
    const auto partsReady = [&] {
      partsDone.get();
      logParts();
    };
    BuildConfig surface = placed;
    surface.surfaceOnly = true; // the whole mesh gives the tree and the surface, the parts the inside
    const auto whole = [&] { return prepareMesh(mesh, surface); };
    built = buildOnDevice(whole, parts.meshes, parts.labels, labels, options, v, partsReady);
    partsReady(); // its errors (a label 0, say) are the build's
  } else {
    parts = prepareParts(mesh, placed);
    logParts();
  }
  if (!built) v = buildPartsAndCombine(parts, options, labels);
  copyNames(mesh.labelNames, v.labels);
  return v;
}

} // namespace hdt
