// buildLabelledCuda (hdt/labels.hpp): a labelled build that never leaves the
// device until its one copy back.
//
// 1. The whole mesh's tree and surface (T1..T3, surface only): the union of
//    the parts' trees, since an element is refined where any triangle meets it.
// 2. Each part, built on the device with its own triangles and inside test,
//    is mapped onto that tree level by level (its elements are a subset of
//    the union's, in the same order) and folded in: its Full elements as
//    claims, its leaf words ORed into the union's leaves, its claim counted.
//    Parts whose cells are disjoint share one build (partBuilds, which says
//    why at most one may be open, and why its cells are whole root cells;
//    a closed part's cells: the elements of the ownership level,
//    kOwnershipLevel below the root cells, that meet its box): a part's
//    triangles meet only its cells, and a closed part's parity is even on
//    every line, so outside its box it adds nothing to another's inside test
//    (nor decides an open part's: partBuilds), and it is constant on an
//    element its triangles do not meet. On an element within one part's
//    cells the shared build is that part's own build; outside all parts'
//    cells it is Empty, as each part's own build (outside its box, a part is
//    neither met nor inside); an element that spans several parts' cells is
//    either Empty or a Branch (uniform and inside a part, it would lie
//    within that part's cells), and no part claims it. So each element is
//    claimed for its owner (ownerOfElement): the parts' own claims, as if
//    built one by one.
// 3. Full claims go down the union's tree; the leaf words are finished
//    (inside where not surface); leaves of two claims or more get a rank per
//    voxel, the best claim in the voxel's state (second pass over the parts,
//    which stay on the device); leaf labels, mixed leaves' voxel labels and
//    the element words and labels follow.
// It is combineLabelledParts (labels.cpp) of the same part builds, so the
// bytes are the CPU's; a part tree that is not a subset of the union's or a
// surface that differs (which cannot happen with one lattice) makes the
// caller fall back to the per-part path rather than return a wrong volume.
#include "label_combine.hpp"
#include "host_copy.hpp"
#include "pipeline.hpp"
#include "session.hpp"
#include "voxel_counts.hpp"

#include "hdt/build_steps.hpp"
#include "hdt/error.hpp"
#include "hdt/host_memory.hpp"
#include "hdt/labels.hpp"
#include "hdt/mesh.hpp"
#include "hdt/warm_pages.hpp"

#include <algorithm>
#include <chrono>
#include <functional>
#include <future>
#include <numeric>
#include <stdexcept>
#include <string>
#include <vector>

namespace hdt {
namespace {

using namespace cuda;
using Clock = std::chrono::steady_clock;

// A part's tree or surface that does not fit the union's (see the top).
struct Mismatch : std::runtime_error {
  using std::runtime_error::runtime_error;
};

// What a part build keeps on the device for the second pass.
struct PartOnDevice {
  uint32_t leaves = 0;
  DeviceBuffer<uint32_t> words;    // its leaf words
  DeviceBuffer<uint32_t> leafMap;  // its leaf -> union leaf
  DeviceBuffer<uint16_t> leafRank; // its leaf's part's rank
};

// Parts share builds on the cells of this level below the root cells (or
// the leaf level, if higher): finer cells than the root cells separate more
// small parts that lie close together (bench/results/labels-gpu.md).
constexpr int kOwnershipLevel = 3;
// At most this many parts share one build (each element looks through them).
constexpr size_t kPartsPerBuild = 64;

int ownershipLevel(const GridSpec& g) { return std::min(kOwnershipLevel, g.height); }

// The cells [first, last] (per axis, of the ownership level) that a part's
// triangles can meet: those of its lattice box (cellRange, as T1 and T2 find
// a triangle's elements); with `wholeRootCells`, all cells of the root cells
// that meet its box.
PartCells cellsOf(const PreparedMesh& part, uint16_t rank, bool wholeRootCells) {
  const GridSpec& g = part.grid;
  const int level = ownershipLevel(g);
  int64_t lo[3] = {INT64_MAX, INT64_MAX, INT64_MAX}, hi[3] = {INT64_MIN, INT64_MIN, INT64_MIN};
  for (const LatticeTriangle& t : part.triangles) {
    int64_t a[3], b[3];
    triangleBounds(t, a, b);
    for (int k = 0; k < 3; ++k) {
      lo[k] = std::min(lo[k], a[k]);
      hi[k] = std::max(hi[k], b[k]);
    }
  }
  PartCells c;
  for (int k = 0; k < 3; ++k) {
    int64_t first = 0, last = 0;
    if (wholeRootCells) {
      cellRange(lo[k], hi[k], latticeOfVoxel(g.rootCellVoxels()), g.rootGrid, first, last);
      first <<= level;
      last = ((last + 1) << level) - 1;
    } else {
      cellRange(lo[k], hi[k], latticeOfVoxel(g.elementVoxels(level)), int64_t(g.rootGrid) << level, first, last);
    }
    c.first[k] = int32_t(first);
    c.last[k] = int32_t(last);
  }
  c.rank = rank;
  return c;
}

bool cellsMeet(const PartCells& a, const PartCells& b) {
  for (int k = 0; k < 3; ++k)
    if (a.last[k] < b.first[k] || b.last[k] < a.first[k]) return false;
  return true;
}

// The part builds: the parts, first fit in input order, grouped so that the
// parts of a group have disjoint cells, and at most one of them is open in a
// solid build. An open part's parity may be odd outside its box, but there
// on one ray axis at most (a point in the shadows of a box along two axes
// lies in the box); a build with an open part takes the majority of three
// axes, on which each closed part's parities agree, so one flipped axis
// changes nothing (two open parts could flip two). A uniform element of an
// open part's own build, classified at one corner, may reach outside its
// box, but not outside the root cells that meet its box (its parent meets
// the part, or it is a root cell whose corner lies in the box): an open
// part's cells are those whole root cells, which no element spans.
struct PartBuild {
  std::vector<uint32_t> parts;
  std::vector<PartCells> cells;
  bool open = false; // has an open part (solid builds)
};
std::vector<PartBuild> partBuilds(const std::vector<PreparedMesh>& parts, const std::vector<uint16_t>& rank) {
  std::vector<PartBuild> builds;
  // Shared builds need kMixedOwners free: ranks stay below it.
  const bool share = parts.size() < size_t(kMixedOwners);
  for (uint32_t i = 0; i < parts.size(); ++i) {
    const bool open = !parts[i].surfaceOnly && !parts[i].closed;
    const PartCells cells = cellsOf(parts[i], rank[i], open);
    PartBuild* into = nullptr;
    for (PartBuild& b : builds) {
      if (!share || (open && b.open) || b.parts.size() >= kPartsPerBuild) continue;
      if (std::none_of(b.cells.begin(), b.cells.end(), [&](const PartCells& c) { return cellsMeet(c, cells); })) {
        into = &b;
        break;
      }
    }
    if (!into) {
      builds.emplace_back();
      into = &builds.back();
    }
    into->open = into->open || open;
    into->parts.push_back(i);
    into->cells.push_back(cells);
  }
  return builds;
}

template <class T>
void fill(Session& s, DeviceBuffer<T>& b, int byte) {
  if (b.size()) HDT_CUDA_CHECK(cudaMemsetAsync(b.data(), byte, b.bytes(), s.stream.get()));
}

template <class T>
void download(Session& s, T* host, const T* device, size_t count) {
  if (count == 0) return;
  s.sync();
  const auto t0 = Clock::now();
  copyToHost(s.stream.get(), host, device, count * sizeof(T));
  s.copyBackMs += std::chrono::duration<double, std::milli>(Clock::now() - t0).count();
  s.copyBackBytes += count * sizeof(T);
}

std::vector<uint64_t> levelStarts(const Tree& t) {
  std::vector<uint64_t> start{0};
  for (const Level& lv : t.levels) start.push_back(start.back() + lv.count);
  return start;
}

// Part i's rank: its place in the overlap policy's order (0 wins).
std::vector<uint16_t> ranksOf(const std::vector<Label>& partLabels, const LabelOptions& labels,
                              std::vector<uint16_t>& labelOfRank) {
  const LabelRanking ranking(labels);
  std::vector<uint32_t> order(partLabels.size());
  std::iota(order.begin(), order.end(), 0u);
  std::sort(order.begin(), order.end(),
            [&](uint32_t a, uint32_t b) { return ranking.rank(partLabels[a]) < ranking.rank(partLabels[b]); });
  std::vector<uint16_t> rank(partLabels.size());
  labelOfRank.resize(partLabels.size());
  for (size_t r = 0; r < order.size(); ++r) {
    rank[order[r]] = uint16_t(r);
    labelOfRank[r] = partLabels[order[r]];
  }
  return rank;
}

struct UnionState {
  DeviceVolume tree; // the whole mesh's, surface only
  std::vector<uint64_t> start;
  DeviceBuffer<uint16_t> fullRank;      // per element
  DeviceBuffer<uint32_t> acc;           // combined leaf words
  DeviceBuffer<uint32_t> claimCount;    // per leaf
  DeviceBuffer<uint16_t> claimRank;     // per leaf: one of its claims (the only one when count is 1)
  DeviceBuffer<uint16_t> leafInherited; // per leaf: best inherited Full claim
  DeviceBuffer<uint32_t> error;
};

// Step 2 for one part build: build, map onto the union, fold in.
PartOnDevice foldPart(Session& s, UnionState& u, const std::vector<PreparedMesh>& parts, const PartBuild& b) {
  const GridSpec& g = s.grid;
  const uint64_t cells = uint64_t(g.rootGrid) * g.rootGrid * g.rootGrid;
  size_t count = 0;
  bool closed = true;
  for (uint32_t i : b.parts) {
    count += parts[i].triangles.size();
    closed = closed && parts[i].closed;
  }
  DeviceBuffer<LatticeTriangle> tris(s.memory, count);
  size_t at = 0;
  for (uint32_t i : b.parts) {
    const PreparedMesh& p = parts[i];
    HDT_CUDA_CHECK(cudaMemcpyAsync(tris.data() + at, p.triangles.data(), p.triangles.size() * sizeof(LatticeTriangle),
                                   cudaMemcpyHostToDevice, s.stream.get()));
    at += p.triangles.size();
  }
  PartOwners owners;
  DeviceBuffer<PartCells> ownerCells;
  if (b.parts.size() == 1) {
    owners.rank = b.cells[0].rank;
  } else {
    ownerCells = DeviceBuffer<PartCells>(s.memory, b.cells.size());
    HDT_CUDA_CHECK(cudaMemcpyAsync(ownerCells.data(), b.cells.data(), ownerCells.bytes(), cudaMemcpyHostToDevice,
                                   s.stream.get()));
    owners.parts = ownerCells.data();
    owners.count = uint32_t(b.cells.size());
    owners.level = ownershipLevel(g);
  }
  const DeviceMesh mesh{tris.data(), uint32_t(count)};
  RootMapping root = mapTrianglesToRootCells(s.memory, s.scalars, mesh, g, 0, cells, false);
  DeviceVolume pv = buildOnDevice(s, mesh, closed, !parts[b.parts[0]].surfaceOnly, std::move(root));
  const std::vector<uint64_t> start = levelStarts(pv.tree);
  const size_t h = size_t(g.height);
  if (pv.tree.levels.size() != h + 1 || pv.tree.levels[0].count != u.tree.tree.levels[0].count)
    throw Mismatch("a part's levels differ from the whole mesh's");
  PartOnDevice out;
  out.leaves = pv.tree.leaves.count;
  out.leafMap = DeviceBuffer<uint32_t>(s.memory, out.leaves);
  out.leafRank = DeviceBuffer<uint16_t>(s.memory, out.leaves);
  const CombineError e{u.error.data()};
  DeviceBuffer<uint32_t> map;
  for (size_t k = 0; k <= h; ++k) {
    DeviceBuffer<uint32_t> next;
    if (k < h) next = DeviceBuffer<uint32_t>(s.memory, pv.tree.levels[k + 1].count);
    const Level& lv = pv.tree.levels[k];
    mapPartLevel(s.stream.get(), lv.words.data(), lv.coords.data(), lv.count, int(k), start[k + 1],
                 k == 0 ? nullptr : map.data(), u.tree.tree.levels[k].words.data(), u.start[k], u.start[k + 1],
                 k < h ? next.data() : nullptr, k == h ? out.leafMap.data() : nullptr,
                 k == h ? out.leafRank.data() : nullptr, owners, u.fullRank.data(), e);
    map = std::move(next);
  }
  orPartLeaves(s.stream.get(), pv.words.data(), out.leaves, leafWordCount(g.leafSize), out.leafMap.data(),
               out.leafRank.data(), u.acc.data(), u.claimCount.data(), u.claimRank.data());
  out.words = std::move(pv.words);
  s.sync(); // the part's tree and triangles go back to the pool now (b.cells is read by then)
  return out;
}

// The mixed leaves' voxel labels in LabelField's layout, on the device.
struct MixedOnDevice {
  DeviceBuffer<LeafPalette> palettes;   // per mixed leaf, leaf order
  DeviceBuffer<uint32_t> paletteIndices; // per palette leaf
  DeviceBuffer<uint16_t> wideLabels;     // per wide leaf
  DeviceBuffer<uint32_t> mixedIndex;     // per leaf (LabelField::mixedIndex)
  DeviceBuffer<uint32_t> mixedBlock;     // per mixed leaf (LabelField::mixedBlock)
};

// From the multi-claim leaves' voxel ranks and palettes (leafPalettes): the
// mixed leaves (label 0), split into palette and wide leaves, each numbered
// in leaf order by a scan.
MixedOnDevice compactMixedLeaves(Session& s, uint32_t leaves, uint32_t multi, const DeviceBuffer<uint32_t>& claimCount,
                                 const DeviceBuffer<uint32_t>& multiIndex, const DeviceBuffer<uint16_t>& leafLabel,
                                 const DeviceBuffer<LeafPalette>& multiPalette, const DeviceBuffer<uint16_t>& voxelRanks,
                                 const DeviceBuffer<uint16_t>& labelOfRank) {
  const cudaStream_t st = s.stream.get();
  const uint32_t W = leafWordCount(s.grid.leafSize), V = s.grid.leafVoxels();
  DeviceBuffer<uint32_t> multiLeaf(s.memory, multi);
  multiLeaves(st, leaves, claimCount.data(), multiIndex.data(), multiLeaf.data());
  DeviceBuffer<uint32_t> flag(s.memory, leaves), mixedIndex(s.memory, leaves);
  markMixed(st, leaves, claimCount.data(), leafLabel.data(), flag.data());
  const uint32_t mixed = scanFlags(s.memory, s.scalars.host(), flag.data(), mixedIndex.data(), leaves);
  DeviceBuffer<uint32_t> paletteFlag(s.memory, leaves), wideFlag(s.memory, leaves);
  DeviceBuffer<uint32_t> paletteBlock(s.memory, leaves), wideBlock(s.memory, leaves);
  fill(s, paletteFlag, 0);
  fill(s, wideFlag, 0);
  markMixedForms(st, multi, multiLeaf.data(), leafLabel.data(), multiPalette.data(), paletteFlag.data(), wideFlag.data());
  const uint32_t paletteLeaves = scanFlags(s.memory, s.scalars.host(), paletteFlag.data(), paletteBlock.data(), leaves);
  const uint32_t wideLeaves = scanFlags(s.memory, s.scalars.host(), wideFlag.data(), wideBlock.data(), leaves);
  MixedOnDevice out;
  out.palettes = DeviceBuffer<LeafPalette>(s.memory, mixed);
  gatherPalettes(st, multi, multiLeaf.data(), leafLabel.data(), mixedIndex.data(), multiPalette.data(),
                 out.palettes.data());
  out.paletteIndices = DeviceBuffer<uint32_t>(s.memory, size_t(paletteLeaves) * W);
  paletteIndices(st, multi, W, multiLeaf.data(), paletteFlag.data(), paletteBlock.data(), multiPalette.data(),
                 voxelRanks.data(), labelOfRank.data(), out.paletteIndices.data());
  out.wideLabels = DeviceBuffer<uint16_t>(s.memory, size_t(wideLeaves) * V);
  wideLabels(st, multi, V, multiLeaf.data(), wideFlag.data(), wideBlock.data(), voxelRanks.data(), labelOfRank.data(),
             out.wideLabels.data());
  out.mixedIndex = DeviceBuffer<uint32_t>(s.memory, leaves);
  out.mixedBlock = DeviceBuffer<uint32_t>(s.memory, mixed);
  indexMixed(st, leaves, flag.data(), mixedIndex.data(), wideFlag.data(), paletteBlock.data(), wideBlock.data(),
             out.mixedIndex.data(), out.mixedBlock.data());
  s.sync(); // the scratch buffers go back to the pool
  return out;
}

// Appends "name ms" to `laps` for the time since the last lap, the stream
// waited for (the log line's breakdown of the combination).
class Laps {
public:
  Laps(const Session& s, std::string& out) : s_(s), out_(out), last_(Clock::now()) {}
  void operator()(const char* name) {
    s_.sync();
    const auto now = Clock::now();
    out_ += std::string(out_.empty() ? "" : ", ") + name + " " +
            std::to_string(int(std::chrono::duration<double, std::milli>(now - last_).count()));
    last_ = now;
  }

private:
  const Session& s_;
  std::string& out_;
  Clock::time_point last_;
};

// Host threads the copy beside the labelling kernels leaves to others.
constexpr int kCoresLeftBeside = 2;

// A copy back on a stream and host thread of its own, queued after the work
// on the session's stream so far: the leaf words, final before the labelling
// kernels, go to the host while those run. wait() before the host reads the
// words or the device frees them (the destructor waits too).
class CopyBeside {
public:
  CopyBeside(Session& s, uint32_t* host, const uint32_t* device, size_t count) : bytes_(count * sizeof(uint32_t)) {
    HDT_CUDA_CHECK(cudaEventCreateWithFlags(&ready_, cudaEventDisableTiming));
    HDT_CUDA_CHECK(cudaEventRecord(ready_, s.stream.get()));
    HDT_CUDA_CHECK(cudaStreamWaitEvent(side_.get(), ready_, 0));
    done_ = std::async(std::launch::async, [this, dev = s.device, host, device] {
      HDT_CUDA_CHECK(cudaSetDevice(dev));
      const auto t0 = Clock::now();
      // The copy's host threads leave cores to the threads that drive the
      // device meanwhile (the build's, the element arrays' fill): the copy
      // and the kernels beside it end sooner (bench/results/labels-gpu.md).
      copyToHost(side_.get(), host, device, bytes_, {}, kCoresLeftBeside);
      return std::chrono::duration<double, std::milli>(Clock::now() - t0).count();
    });
  }
  ~CopyBeside() {
    if (done_.valid()) done_.wait();
    cudaEventDestroy(ready_);
  }
  CopyBeside(const CopyBeside&) = delete;
  CopyBeside& operator=(const CopyBeside&) = delete;
  // Waits for the copy (rethrowing its error) and counts it as the session's.
  double wait(Session& s) {
    const double ms = done_.get();
    s.copyBackMs += ms;
    s.copyBackBytes += bytes_;
    return ms;
  }

private:
  const size_t bytes_;
  cudaEvent_t ready_ = nullptr;
  Stream side_;
  std::future<double> done_;
};

// Steps 3 and the copy back. counts: the volume's surface and inside voxels
// (its statistics).
Volume combineOnDevice(Session& s, UnionState& u, std::vector<PartOnDevice>& parts,
                       const std::vector<uint16_t>& labelOfRankHost, unsigned long long counts[2],
                       std::string& laps) {
  Laps lap(s, laps);
  const GridSpec& g = s.grid;
  const cudaStream_t st = s.stream.get();
  const size_t h = size_t(g.height);
  const uint32_t leaves = u.tree.tree.leaves.count;
  const uint32_t W = leafWordCount(g.leafSize);
  const uint32_t V = uint32_t(g.leafSize) * g.leafSize * g.leafSize;
  const CombineError e{u.error.data()};
  DeviceBuffer<uint16_t> labelOfRank(s.memory, labelOfRankHost.size());
  HDT_CUDA_CHECK(cudaMemcpyAsync(labelOfRank.data(), labelOfRankHost.data(), labelOfRank.bytes(),
                                 cudaMemcpyHostToDevice, st));
  std::vector<Level>& levels = u.tree.tree.levels;

  for (size_t k = 0; k < h; ++k) propagateFull(st, levels[k].words.data(), levels[k].count, u.start[k], u.fullRank.data());
  collectInherited(st, levels[h].words.data(), levels[h].count, u.start[h], u.fullRank.data(), u.leafInherited.data(),
                   u.claimCount.data(), u.claimRank.data());
  finalizeLeafWords(st, leaves, W, u.tree.words.data(), u.leafInherited.data(), u.acc.data(), e);
  u.tree.words = DeviceBuffer<uint32_t>();
  Volume v;
  const size_t warmBefore = warmPagesState().free;
  v.leafWords.resize(size_t(leaves) * W);
  const bool warmWords = warmPagesState().free + v.leafWords.size() * sizeof(uint32_t) <= warmBefore;
  // The voxel ranks' array (the combination's largest) is made and filled
  // before the copy starts: beside the copy, that fill (and the pool's growth
  // for it) took several times as long on the device, and the copy slowed.
  DeviceBuffer<uint32_t> flags(s.memory, leaves), multiIndex(s.memory, leaves);
  markMulti(st, leaves, u.claimCount.data(), flags.data());
  const uint32_t multi = scanFlags(s.memory, s.scalars.host(), flags.data(), multiIndex.data(), leaves);
  DeviceBuffer<uint16_t> voxelRanks(s.memory, size_t(multi) * V);
  fill(s, voxelRanks, 0xFF);
  CopyBeside words(s, v.leafWords.data(), u.acc.data(), v.leafWords.size()); // read-only from here on
  // The element arrays' zero fill (std::vector's resize) beside the kernels too.
  std::future<void> elementArrays = std::async(std::launch::async, [&v, n = u.start.back()] {
    v.elements.resize(n);
    v.labels.elementLabels.resize(n);
  });

  for (const PartOnDevice& p : parts)
    partVoxelRanks(st, p.words.data(), p.leaves, W, p.leafMap.data(), u.claimCount.data(), multiIndex.data(),
                   u.acc.data(), voxelRanks.data(), p.leafRank.data());
  inheritedVoxelRanks(st, leaves, W, u.claimCount.data(), multiIndex.data(), u.leafInherited.data(), u.acc.data(),
                      voxelRanks.data());
  lap("voxel ranks");
  parts.clear();

  DeviceBuffer<uint16_t> leafLabel(s.memory, leaves);
  DeviceBuffer<LeafPalette> multiPalette(s.memory, multi);
  leafPalettes(st, leaves, V, u.claimCount.data(), u.claimRank.data(), multiIndex.data(), voxelRanks.data(),
               labelOfRank.data(), leafLabel.data(), multiPalette.data(), e);
  lap("palettes");
  MixedOnDevice mixed = compactMixedLeaves(s, leaves, multi, u.claimCount, multiIndex, leafLabel, multiPalette, voxelRanks,
                                           labelOfRank);
  lap("mixed leaves");
  DeviceBuffer<uint16_t> elementLabels(s.memory, u.start.back());
  for (size_t k = 0; k <= h; ++k)
    finalizeElements(st, levels[k].words.data(), levels[k].count, u.start[k], u.fullRank.data(), leafLabel.data(),
                     labelOfRank.data(), elementLabels.data());
  DeviceBuffer<unsigned long long> voxelCounts(s.memory, 2); // surface, inside
  fill(s, voxelCounts, 0);
  for (size_t k = 0; k <= h; ++k) {
    const uint64_t edge = uint64_t(g.elementVoxels(int(k)));
    countFullVoxels(st, levels[k].words.data(), levels[k].count, edge * edge * edge, voxelCounts.data());
  }
  countLeafVoxels(st, u.acc.data(), u.acc.size(), voxelCounts.data());
  s.clock.mark(kClassify);
  lap("elements");

  uint32_t error = 0;
  download(s, &error, u.error.data(), 1);
  if (error) throw Mismatch("the parts' trees or surfaces do not match the whole mesh's");
  download(s, counts, voxelCounts.data(), 2);

  v.grid = g;
  v.levelStart = u.start;
  elementArrays.get();
  for (size_t k = 0; k <= h; ++k) download(s, v.elements.data() + u.start[k], levels[k].words.data(), levels[k].count);
  lap("elements down");
  const double wordsMs = words.wait(s);
  lap("words down");
  download(s, v.labels.elementLabels.data(), elementLabels.data(), v.labels.elementLabels.size());
  LabelField& f = v.labels;
  f.palettes.resize(mixed.palettes.size());
  download(s, f.palettes.data(), mixed.palettes.data(), f.palettes.size());
  f.paletteIndices.resize(mixed.paletteIndices.size());
  download(s, f.paletteIndices.data(), mixed.paletteIndices.data(), f.paletteIndices.size());
  f.wideLabels.resize(mixed.wideLabels.size());
  download(s, f.wideLabels.data(), mixed.wideLabels.data(), f.wideLabels.size());
  // The index of the mixed leaves (indexMixedLeaves), made on the device.
  f.mixedIndex.resize(mixed.mixedIndex.size());
  download(s, f.mixedIndex.data(), mixed.mixedIndex.data(), f.mixedIndex.size());
  f.mixedBlock.resize(mixed.mixedBlock.size());
  download(s, f.mixedBlock.data(), mixed.mixedBlock.data(), f.mixedBlock.size());
  s.clock.mark(kDownload);
  lap("labels down");
  laps += warmWords ? " (leaf words in warm pages" : " (leaf words in fresh pages";
  laps += ", " + std::to_string(int(wordsMs)) + " ms their copy)";
  return v;
}

bool sameGrid(const GridSpec& a, const GridSpec& b) {
  return a.resolution == b.resolution && a.rootGrid == b.rootGrid && a.leafSize == b.leafSize &&
         a.height == b.height && a.origin == b.origin && a.voxelSize == b.voxelSize;
}

// Why the device path does not apply to these parts (empty: it does).
std::string notApplicable(const PreparedMesh& whole, const std::vector<PreparedMesh>& parts,
                          const std::vector<Label>& partLabels) {
  if (parts.empty() || parts.size() != partLabels.size() || parts.size() > kNoRank) return "no parts";
  for (const PreparedMesh& p : parts) {
    if (p.triangles.empty()) return "a part has no triangles";
    if (!p.surfaceOnly && p.insideTest == InsideTest::WindingNumber) return "a part uses the winding number";
    if (p.surfaceOnly != parts[0].surfaceOnly || !sameGrid(p.grid, whole.grid)) return "the parts are not on one grid";
  }
  return "";
}

Volume buildLabelled(const PreparedMesh& whole, const std::vector<PreparedMesh>& parts,
                     const std::vector<Label>& partLabels, const LabelOptions& labels, const BuildOptions& options,
                     const std::function<void()>& partsReady, std::string& logLine, Clock::time_point& logged) {
  const auto wall0 = Clock::now();
  const GridSpec& g = whole.grid;
  const uint64_t cells = uint64_t(g.rootGrid) * g.rootGrid * g.rootGrid;
  // Progress: the whole mesh (the first tenth: the number of part builds
  // is known only after it), then each part build and the combination.
  constexpr double kWholeShare = 0.1;
  double stage = 0, stages = 0; // stages: part builds + 1, once known
  BuildOptions wrapped = options;
  if (options.progress)
    wrapped.progress = [&](double f, const char* phase) {
      const double x = stages == 0 ? kWholeShare * f : kWholeShare + (1 - kWholeShare) * (stage - 1 + f) / stages;
      return options.progress(x, phase);
    };
  Session s(whole, wrapped);
  uploadTriangles(s);

  UnionState u;
  {
    RootMapping root = mapTrianglesToRootCells(s.memory, s.scalars, s.deviceMesh, g, 0, cells, false);
    u.tree = buildOnDevice(s, s.deviceMesh, true, false, std::move(root));
  }
  s.triangles = DeviceBuffer<LatticeTriangle>();
  if (partsReady) partsReady(); // the parts, prepared on the host meanwhile
  const std::string why = notApplicable(whole, parts, partLabels);
  if (!why.empty()) throw Mismatch(why);
  std::vector<uint16_t> labelOfRank;
  const std::vector<uint16_t> rank = ranksOf(partLabels, labels, labelOfRank);
  const std::vector<PartBuild> builds = partBuilds(parts, rank);
  stages = double(builds.size() + 1);
  stage = 1;
  s.sync();
  const auto parts0 = Clock::now();
  u.start = levelStarts(u.tree.tree);
  const uint32_t leaves = u.tree.tree.leaves.count;
  u.fullRank = DeviceBuffer<uint16_t>(s.memory, u.start.back());
  u.acc = DeviceBuffer<uint32_t>(s.memory, size_t(leaves) * leafWordCount(g.leafSize));
  u.claimCount = DeviceBuffer<uint32_t>(s.memory, leaves);
  u.claimRank = DeviceBuffer<uint16_t>(s.memory, leaves);
  u.leafInherited = DeviceBuffer<uint16_t>(s.memory, leaves);
  u.error = DeviceBuffer<uint32_t>(s.memory, 1);
  fill(s, u.fullRank, 0xFF);
  fill(s, u.acc, 0);
  fill(s, u.claimCount, 0);
  fill(s, u.claimRank, 0xFF);
  fill(s, u.error, 0);

  std::vector<PartOnDevice> onDevice;
  onDevice.reserve(builds.size());
  for (size_t i = 0; i < builds.size(); ++i) {
    stage = double(i + 1);
    onDevice.push_back(foldPart(s, u, parts, builds[i]));
  }
  stage = stages;
  s.progress(0.0, "combining labels");
  s.sync();
  const auto combine0 = Clock::now();
  std::string laps;
  unsigned long long voxelCounts[2] = {0, 0}; // surface, inside
  Volume v = combineOnDevice(s, u, onDevice, labelOfRank, voxelCounts, laps);
  s.sync();
  s.clock.collect(s.ms);
  const auto finish0 = Clock::now(); // the index of mixed leaves came with the copy back

  v.surfaceOnly = parts[0].surfaceOnly;
  v.closedMesh = true;
  Statistics& st = v.stats;
  for (const PreparedMesh& p : parts) {
    v.closedMesh = v.closedMesh && p.closed;
    st.triangles += p.triangles.size();
    st.degenerateTriangles += p.degenerateTriangles;
  }
  v.insideTest = InsideTest::Parity;
  computeStructureStatistics(v, voxelCounts[0], voxelCounts[1]);
  st.backend = "cuda";
  st.threads = 0;
  st.time.mapping = s.ms[kMapping];
  st.time.branching = s.ms[kBranching];
  st.time.leaf = s.ms[kLeaf];
  st.time.classify = s.ms[kClassify];
  st.peakDeviceBytes = s.memory.peak();
  st.peakHostBytes = peakResidentBytes();
  s.progress(1.0, "done");
  // As the caller waits: every part, the combination and the copy back.
  st.time.total = std::chrono::duration<double, std::milli>(Clock::now() - wall0).count();
  if (options.log) {
    const auto ms = [](Clock::time_point a, Clock::time_point b) {
      return std::to_string(int(std::chrono::duration<double, std::milli>(b - a).count()));
    };
    logLine = ("CUDA labelled build: " + std::to_string(parts.size()) + " parts in " +
                std::to_string(builds.size()) + " part builds combined on the device: " +
                ms(wall0, combine0) + " ms the whole mesh and the parts (" + ms(wall0, parts0) + " + " +
                ms(parts0, combine0) + "), " + ms(combine0, finish0) + " ms the combination and the copy back (" +
                std::to_string(s.copyBackBytes >> 20) + " MiB in " + std::to_string(int(s.copyBackMs)) + " ms), " +
                ms(finish0, Clock::now()) + " ms the statistics; the combination's steps: " + laps);
  }
  logged = Clock::now();
  return v;
}


} // namespace

bool buildLabelledCuda(const PreparedMesh& whole, const std::vector<PreparedMesh>& parts,
                       const std::vector<Label>& partLabels, const LabelOptions& labels, const BuildOptions& options,
                       Volume& out, const std::function<void()>& partsReady) {
  const auto skip = [&](const std::string& why) {
    if (options.log) options.log("CUDA labelled build: per-part builds combined on the host (" + why + ")");
    return false;
  };
  try {
    std::string line;
    Clock::time_point logged;
    out = buildLabelled(whole, parts, partLabels, labels, options, partsReady, line, logged);
    if (options.log)
      options.log(line + "; " + std::to_string(int(std::chrono::duration<double, std::milli>(Clock::now() - logged).count())) +
                  " ms the device's release");
    return true;
  } catch (const Mismatch& e) {
    return skip(e.what());
  } catch (const DeviceMemoryExhausted& e) {
    return skip("does not fit the device in one piece: " + std::to_string(e.neededBytes() >> 20) + " MiB more");
  }
}

} // namespace hdt
