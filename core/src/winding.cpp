// The classification of a volume by the winding-number tree (winding.hpp,
// docs/design.md "Winding number"): uniform elements, leaves, the entry
// points of both drivers. The tree itself: winding_tree_build.cpp; the re-lay
// of split elements: winding_refine.cpp.
#include "hdt/winding_tree.hpp"

#include "hdt/build_steps.hpp"
#include "hdt/error.hpp"
#include "hdt/huge_pages.hpp"
#include "hdt/mesh.hpp"
#include "hdt/progress.hpp"
#include "hdt/volume.hpp"
#include "hdt/volume_walk.hpp"
#include "hdt/winding_far.hpp"
#include "hdt/winding_leaf.hpp"
#include "morton_key.hpp"
#include "winding_pass.hpp"

#include <algorithm>
#include <chrono>
#include <numeric>

#include <tbb/enumerable_thread_specific.h>
#include <tbb/parallel_for.h>

namespace hdt {

InsideTest resolveInsideTest(InsideTest requested, bool closedMesh) {
  if (requested != InsideTest::Auto) return requested;
  return closedMesh ? InsideTest::Parity : InsideTest::WindingNumber;
}

const char* insideTestName(InsideTest test) {
  switch (test) {
  case InsideTest::Auto: return "auto";
  case InsideTest::Parity: return "parity";
  case InsideTest::WindingNumber: return "winding";
  }
  return "unknown";
}

std::string insideTestReason(InsideTest requested, InsideTest ran, bool closedMesh) {
  const std::string mesh = closedMesh ? "the mesh is closed" : "the mesh is open";
  if (requested == InsideTest::Auto) {
    return "Auto: " + mesh + (ran == InsideTest::WindingNumber ? ", winding number" : ", exact ray parity");
  }
  return std::string(ran == InsideTest::Parity ? "Parity" : "Winding number") + " as requested; " + mesh;
}

namespace winding_pass {

// Sets the inside plane of the non-surface voxels of box b in one leaf.
void settleLeafBox(uint32_t* words, int L, const VoxelBox& b, bool inside) {
  if (!inside) return; // the plane was cleared first
  for (int z = b.lo[2]; z < b.hi[2]; ++z)
    for (int y = b.lo[1]; y < b.hi[1]; ++y)
      for (int x = b.lo[0]; x < b.hi[0]; ++x) {
        const uint32_t v = uint32_t(x + L * (y + L * z));
        uint32_t& w = words[v / kVoxelsPerWord];
        const uint32_t shift = 2 * (v % kVoxelsPerWord);
        if (((w >> shift) & 3u) == 0) w |= 1u << shift;
      }
}

bool hasSurfaceVoxel(const LeafView& view, const VoxelBox& b) {
  for (int z = b.lo[2]; z < b.hi[2]; ++z)
    for (int y = b.lo[1]; y < b.hi[1]; ++y)
      for (int x = b.lo[0]; x < b.hi[0]; ++x)
        if (view.voxel(x, y, z) == VoxelState::Surface) return true;
  return false;
}

// The per-voxel decision (windingDecideBox) of the non-surface voxels of a
// leaf that `decided` does not mark (all of them when decided is empty).
void decideLeafVoxels(const WindingTreeView& t, uint32_t* words, int L, const std::array<int, 3>& origin,
                      const std::vector<uint8_t>& decided) {
  const LeafView view{words, L};
  VoxelBox box;
  for (int a = 0; a < 3; ++a) {
    box.lo[a] = origin[size_t(a)];
    box.hi[a] = origin[size_t(a)] + L;
  }
  auto local = [&](const VoxelBox& b) {
    VoxelBox l = b;
    for (int a = 0; a < 3; ++a) {
      l.lo[a] -= origin[size_t(a)];
      l.hi[a] -= origin[size_t(a)];
    }
    return l;
  };
  auto settled = [&](int x, int y, int z) {
    return view.voxel(x, y, z) == VoxelState::Surface || (!decided.empty() && decided[size_t(x + L * (y + L * z))]);
  };
  windingDecideBox(
      t, box,
      [&](const VoxelBox& b) { // nothing left to decide in b
        const VoxelBox l = local(b);
        for (int z = l.lo[2]; z < l.hi[2]; ++z)
          for (int y = l.lo[1]; y < l.hi[1]; ++y)
            for (int x = l.lo[0]; x < l.hi[0]; ++x)
              if (!settled(x, y, z)) return false;
        return true;
      },
      [&](const VoxelBox& b) { return hasSurfaceVoxel(view, local(b)); },
      [&](const VoxelBox& b, bool inside) { settleLeafBox(words, L, local(b), inside); }, [] { return false; });
}

// One leaf: each face-connected piece of its non-surface voxels is decided
// from one certified sum at its seed carried along the pieces' paths
// (windingGradientBound over the piece's box); the voxels it leaves unsure
// take the per-voxel decision.
void classifyLeaf(const WindingTreeView& t, uint32_t* words, int L, const std::array<int, 3>& origin) {
  for (uint32_t i = 0; i < leafWordCount(L); ++i) words[i] &= kSurfacePlaneBits;
  const LeafView view{words, L};
  const size_t n = size_t(L) * size_t(L) * size_t(L);
  // Scratch kept per thread (filling it afresh for every leaf cost more than
  // the leaf's sums): label is written whole by windingLeafPieces, steps,
  // queue and pieces before they are read, visit is compared with a stamp
  // that only grows.
  struct Scratch {
    std::vector<uint16_t> label, steps, queue;
    std::vector<WindingPiece> pieces;
    std::vector<uint32_t> visit;
    uint32_t stamp = 0;
  };
  thread_local Scratch scratch;
  Scratch& sc = scratch;
  if (sc.label.size() < n || sc.stamp > 0xF0000000u) {
    sc.label.resize(n);
    sc.steps.resize(n);
    sc.queue.resize(n);
    sc.pieces.resize(n / 2 + 1);
    sc.visit.assign(n, 0);
    sc.stamp = 0;
  }
  uint16_t* label = sc.label.data();
  const int count = windingLeafPieces(
      L, [&](uint32_t v) { return view.voxel(int(v % uint32_t(L)), int((v / uint32_t(L)) % uint32_t(L)), int(v / uint32_t(L * L))) == VoxelState::Surface; },
      label, sc.steps.data(), sc.queue.data(), sc.pieces.data(), int(n / 2 + 1));
  std::vector<uint8_t> decided(n, 0); // 0 open, 1 decided, 2 per-voxel decision
  for (int k = 0; k < count; ++k) {
    windingCarryPiece(t, L, origin.data(), sc.pieces[size_t(k)], k, label, sc.steps.data(), sc.queue.data(),
                      sc.visit.data(), &sc.stamp, decided.data(), [&](uint32_t v, bool inside) {
                        if (inside) words[v / kVoxelsPerWord] |= 1u << (2 * (v % kVoxelsPerWord));
                      });
  }
  bool allDecided = true;
  for (size_t v = 0; v < n; ++v)
    if (label[v] != 0xFFFF && decided[v] != 1) {
      allDecided = false;
      decided[v] = 0;
    }
  if (count < 0) std::fill(decided.begin(), decided.end(), uint8_t(0));
  if (count < 0 || !allDecided) decideLeafVoxels(t, words, L, origin, decided);
}

// A fresh leaf (a child of a refined uniform element: no surface voxel) by
// windingDecideLeaf, as the volume's leaves: N at each row's last voxel
// centre by one ray walk (windingRayCrossings), the rest of the row from the
// leaf's own crossings (a crossing with `before` = L lies ahead of the last
// centre, so its walk counted it). False when a centre lies on a triangle or
// a count does not fit 16 bits (then classifyLeaf).
bool decideFreshLeaf(const WindingTreeView& t, uint32_t* words, int L, const std::array<int, 3>& origin) {
  thread_local std::vector<int32_t> wide;
  thread_local std::vector<int16_t> counts;
  const size_t n = size_t(L) * size_t(L) * size_t(L);
  wide.resize(n);
  counts.resize(n);
  for (int z = 0; z < L; ++z)
    for (int y = 0; y < L; ++y) {
      const int64_t P[3] = {latticeOfVoxelCentre(origin[0] + L - 1), latticeOfVoxelCentre(origin[1] + y),
                            latticeOfVoxelCentre(origin[2] + z)};
      int count = 0;
      if (!windingRayCrossings(t, P, count)) return false;
      std::fill_n(wide.data() + size_t(y + L * z) * size_t(L), L, count);
    }
  windingForEachLeafCrossing(t, origin.data(), L, [&](int row, int before, int sign) {
    if (before >= L) return;
    for (int x = 0; x < before; ++x) wide[size_t(row) * size_t(L) + size_t(x)] += sign;
  });
  for (size_t v = 0; v < n; ++v) {
    if (wide[v] < INT16_MIN || wide[v] > INT16_MAX) return false;
    counts[v] = int16_t(wide[v]);
  }
  windingDecideLeafLinear(t, L, origin.data(), words, counts.data(), words);
  return true;
}

// Leaves and uniform elements are grouped in aligned blocks of kCoarseLeaves
// leaf edges a side; a block that no strip sheet meets and whose K range holds
// no tie (windingBoxThreshold over the block's voxel centres) certifies one
// threshold T for every point in it: inside iff N >= T. A leaf in it is
// settled by T at once (the verdict windingDecideLeaf's first step would
// certify leaf by leaf); a uniform element in it takes the verdict of one of
// its voxel centres (N there by one ray walk): w is continuous over the
// element (no triangle touches it) and never 1/2 in the block.
constexpr int kCoarseLeaves = 4;

uint64_t coarseKey(const std::array<int, 3>& origin, int blockEdge) {
  return mortonKey(uint64_t(origin[0] / blockEdge), uint64_t(origin[1] / blockEdge), uint64_t(origin[2] / blockEdge));
}

struct CoarseThresholds {
  int blockEdge = 0;
  std::vector<uint64_t> keys; // ascending block keys
  std::vector<int> T;
  std::vector<uint8_t> holds;
  // The threshold of the block holding the voxel `origin`, or false.
  bool find(const std::array<int, 3>& origin, int& threshold) const {
    const auto it = std::lower_bound(keys.begin(), keys.end(), coarseKey(origin, blockEdge));
    if (it == keys.end() || *it != coarseKey(origin, blockEdge) || !holds[size_t(it - keys.begin())]) return false;
    threshold = T[size_t(it - keys.begin())];
    return true;
  }
};

// The blocks holding the voxels `origins`, each clipped to the volume's
// `resolution` voxels a side.
CoarseThresholds coarseThresholds(const WindingTreeView& t, const std::vector<std::array<int, 3>>& origins, int L,
                                  int resolution, ProgressPoll* progress) {
  const int blockEdge = kCoarseLeaves * L;
  CoarseThresholds c;
  c.blockEdge = blockEdge;
  c.keys.reserve(origins.size());
  for (const std::array<int, 3>& o : origins) c.keys.push_back(coarseKey(o, blockEdge));
  std::sort(c.keys.begin(), c.keys.end());
  c.keys.erase(std::unique(c.keys.begin(), c.keys.end()), c.keys.end());
  c.T.assign(c.keys.size(), 0);
  c.holds.assign(c.keys.size(), 0);
  std::vector<std::array<int, 3>> corner(c.keys.size());
  for (const std::array<int, 3>& o : origins) {
    const uint64_t key = coarseKey(o, blockEdge);
    const size_t i = size_t(std::lower_bound(c.keys.begin(), c.keys.end(), key) - c.keys.begin());
    for (int a = 0; a < 3; ++a) corner[i][size_t(a)] = o[size_t(a)] / blockEdge * blockEdge;
  }
  tbb::parallel_for(size_t(0), c.keys.size(), [&](size_t i) {
    if (abortRequested(progress)) return;
    double lo[3], hi[3];
    for (int a = 0; a < 3; ++a) {
      lo[a] = corner[i][size_t(a)] + 0.5;
      hi[a] = std::min(corner[i][size_t(a)] + blockEdge, resolution) - 0.5;
    }
    double gradient = INFINITY;
    c.holds[i] = !windingSheetsMeetBox(t, lo, hi) && windingBoxThreshold(t, lo, hi, c.T[i], gradient);
  });
  return c;
}

// Decided box by box (windingDecideBox): each box first tries one certified
// sum at its centre carried to its voxel centres (windingCarriedBoxVerdict).
UniformVerdict classifyUniform(const WindingTreeView& t, const std::array<int, 3>& origin, int edge) {
  VoxelBox box;
  for (int a = 0; a < 3; ++a) {
    box.lo[a] = origin[size_t(a)];
    box.hi[a] = origin[size_t(a)] + edge;
  }
  bool seen[2] = {false, false};
  windingDecideBox(
      t, box, [](const VoxelBox&) { return false; }, [](const VoxelBox&) { return false; },
      [&](const VoxelBox&, bool inside) { seen[inside] = true; },
      [&] { return seen[0] && seen[1]; });
  if (seen[0] && seen[1]) return {false, true};
  return {seen[1], false};
}

// An element within a block whose threshold holds: N at one voxel centre
// against T. False when the ray walk cannot say (then classifyUniform).
bool uniformByBlock(const WindingTreeView& t, const WindingUniformJob& job, const CoarseThresholds* coarse,
                    UniformVerdict& verdict) {
  int T = 0;
  if (coarse == nullptr || job.edge > coarse->blockEdge || !coarse->find(job.origin, T)) return false;
  const int64_t P[3] = {latticeOfVoxelCentre(job.origin[0] + job.edge / 2),
                        latticeOfVoxelCentre(job.origin[1] + job.edge / 2),
                        latticeOfVoxelCentre(job.origin[2] + job.edge / 2)};
  int N = 0;
  if (!windingRayCrossings(t, P, N)) return false;
  verdict = UniformVerdict{N >= T, false};
  return true;
}

std::vector<UniformVerdict> decideUniformJobs(const WindingTree& tree, const std::vector<WindingUniformJob>& jobs,
                                              const WindingUniformPass& pass, ProgressPoll* progress,
                                              const CoarseThresholds* coarse) {
  std::vector<UniformVerdict> out(jobs.size());
  std::vector<uint8_t> verdicts;
  if (pass && pass(tree, jobs, verdicts)) {
    for (size_t i = 0; i < jobs.size(); ++i) out[i] = UniformVerdict{(verdicts[i] & 1) != 0, (verdicts[i] & 2) != 0};
    return out;
  }
  const WindingTreeView t = tree.view();
  tbb::parallel_for(size_t(0), jobs.size(), [&](size_t i) {
    if (abortRequested(progress)) return;
    if (!uniformByBlock(t, jobs[i], coarse, out[i])) out[i] = classifyUniform(t, jobs[i].origin, jobs[i].edge);
  });
  return out;
}

// ---- leaves from signed crossing counts (winding_leaf.hpp) --------------------

// One +x crossing of a leaf's row (windingForEachLeafCrossing): it counts
// for the row's voxel centres x < before.
struct LeafCrossing {
  uint16_t row;
  uint8_t before;
  int8_t sign;
};

// One leaf's crossings, in the pool of the thread that found them (a vector
// that grows to many MB: huge pages, fewer page faults).
using LeafCrossingPool = std::vector<LeafCrossing, HugePageAllocator<LeafCrossing>>;
struct LeafCrossingSpan {
  const LeafCrossingPool* pool = nullptr;
  size_t first = 0, count = 0;
  const LeafCrossing* begin() const { return pool->data() + first; }
  const LeafCrossing* end() const { return pool->data() + first + count; }
};

// A leaf in a block whose threshold holds: the surface plane kept, each
// non-surface voxel inside iff its count N >= T. A row's count is the count
// beyond the leaf (`exit`) up to its last crossing, so a row with no crossing
// before its end is one bit; the others are walked down from `exit` with
// their crossings. Whole words then (withInsidePlane), no count array.
void settleLeafByThreshold(uint32_t* words, int L, const int32_t* exit, const LeafCrossingSpan& crossings, int T) {
  // step[row L + x]: the crossings counting from x down; all zero between
  // leaves (the entries set here are cleared at the end, not the whole array).
  thread_local std::vector<int32_t> step;
  if (step.size() < size_t(L) * size_t(L) * size_t(L)) step.assign(size_t(L) * size_t(L) * size_t(L), 0);
  uint32_t rows[32 * 32];    // bit x: N >= T at voxel x of the row
  uint32_t pending[32] = {}; // rows with a crossing before their end, not yet walked
  const uint32_t all = L == 32 ? 0xFFFFFFFFu : (1u << L) - 1u;
  for (int row = 0; row < L * L; ++row) rows[row] = exit[row] >= T ? all : 0u;
  for (const LeafCrossing& c : crossings)
    if (c.before > 0) {
      step[size_t(c.row) * size_t(L) + size_t(c.before - 1)] += c.sign;
      pending[c.row >> 5] |= 1u << (c.row & 31);
    }
  for (const LeafCrossing& c : crossings) {
    if (!((pending[c.row >> 5] >> (c.row & 31)) & 1u)) continue;
    pending[c.row >> 5] &= ~(1u << (c.row & 31));
    int32_t n = exit[c.row];
    uint32_t mask = 0;
    for (int x = L - 1; x >= 0; --x) {
      n += step[size_t(c.row) * size_t(L) + size_t(x)];
      if (n >= T) mask |= 1u << x;
    }
    rows[c.row] = mask;
  }
  for (uint32_t i = 0; i < leafWordCount(L); ++i) words[i] = withInsidePlane(words[i], wordBitsFromRows(rows, L, int(i)));
  for (const LeafCrossing& c : crossings)
    if (c.before > 0) step[size_t(c.row) * size_t(L) + size_t(c.before - 1)] = 0;
}

// Every leaf of the volume by windingDecideLeaf: the signed crossings of each
// leaf's rows summed per row, their suffix sums along each line of leaves
// (between two leaves of a line lie only uniform elements, which hold no
// triangle) give the count at each row's +x exit, and the leaf's own
// crossings the count at each voxel centre. A leaf whose counts do not fit
// 16 bits takes the pieces-and-seeds decision (classifyLeaf).
void classifyLeavesByCrossings(const WindingTree& tree, Volume& volume,
                               const std::vector<std::array<int, 3>>& origins, const CoarseThresholds& coarse,
                               ProgressPoll* progress) {
  const WindingTreeView t = tree.view();
  const int L = volume.grid.leafSize;
  const size_t rows = size_t(L) * size_t(L), leaves = origins.size();
  // The leaf's own row totals, then the counts beyond it; zeroed leaf by leaf
  // below (huge pages: one array of many MB written once).
  std::vector<int32_t, HugePageScratchAllocator<int32_t>> exits(leaves * rows);
  // Each leaf's crossings, kept for its counts below (one walk of the tree a
  // leaf), appended to its thread's pool (one allocation a thread, not a leaf).
  tbb::enumerable_thread_specific<LeafCrossingPool> pools;
  std::vector<LeafCrossingSpan> crossings(leaves);
  tbb::parallel_for(size_t(0), leaves, [&](size_t leaf) {
    if (abortRequested(progress)) return;
    int32_t* total = exits.data() + leaf * rows;
    std::fill_n(total, rows, 0);
    LeafCrossingPool& pool = pools.local();
    const size_t first = pool.size();
    windingForEachLeafCrossing(t, origins[leaf].data(), L, [&](int row, int before, int sign) {
      total[row] += sign;
      pool.push_back({uint16_t(row), uint8_t(before), int8_t(sign)});
    });
    crossings[leaf] = LeafCrossingSpan{&pool, first, pool.size() - first};
  });
  reportWinding(progress, 0.45); // before anything reads the crossings (an aborted loop left some unwritten)
  // Lines of leaves (same y, z), each walked from its +x end.
  std::vector<uint32_t> order(leaves);
  std::iota(order.begin(), order.end(), 0u);
  std::sort(order.begin(), order.end(), [&](uint32_t a, uint32_t b) {
    const std::array<int, 3>&oa = origins[a], &ob = origins[b];
    if (oa[2] != ob[2]) return oa[2] < ob[2];
    if (oa[1] != ob[1]) return oa[1] < ob[1];
    return oa[0] > ob[0];
  });
  std::vector<size_t> lineStarts;
  for (size_t i = 0; i < leaves; ++i)
    if (i == 0 || origins[order[i]][1] != origins[order[i - 1]][1] || origins[order[i]][2] != origins[order[i - 1]][2])
      lineStarts.push_back(i);
  lineStarts.push_back(leaves);
  tbb::parallel_for(size_t(0), lineStarts.size() - 1, [&](size_t line) {
    std::vector<int32_t> running(rows, 0);
    for (size_t i = lineStarts[line]; i < lineStarts[line + 1]; ++i) {
      int32_t* e = exits.data() + size_t(order[i]) * rows;
      for (size_t r = 0; r < rows; ++r) {
        const int32_t own = e[r];
        e[r] = running[r];
        running[r] += own;
      }
    }
  });
  tbb::parallel_for(size_t(0), leaves, [&](size_t leaf) {
    if (abortRequested(progress)) return;
    thread_local std::vector<int32_t> wide;
    thread_local std::vector<int16_t> counts;
    const size_t n = rows * size_t(L);
    wide.resize(n);
    counts.resize(n);
    const int32_t* exit = exits.data() + leaf * rows;
    uint32_t* words = volume.leafWords.data() + leafWordOffset(leaf, L);
    int T = 0;
    if (coarse.find(origins[leaf], T)) {
      settleLeafByThreshold(words, L, exit, crossings[leaf], T);
      return;
    }
    for (size_t r = 0; r < rows; ++r)
      for (int x = 0; x < L; ++x) wide[r * size_t(L) + size_t(x)] = exit[r];
    for (const LeafCrossing& c : crossings[leaf])
      for (int x = 0; x < c.before; ++x) wide[size_t(c.row) * size_t(L) + size_t(x)] += c.sign;
    bool fits = true;
    for (size_t v = 0; v < n; ++v) {
      fits = fits && wide[v] >= INT16_MIN && wide[v] <= INT16_MAX;
      counts[v] = int16_t(wide[v]);
    }
    if (!fits) {
      classifyLeaf(t, words, L, origins[leaf]);
      return;
    }
    windingDecideLeafLinear(t, L, origins[leaf].data(), words, counts.data(), words);
  });
}

// The walk's units in its order: the elements it stops at above level
// `unitLevel` and the subtrees rooted at that level (up to 64 per root cell
// at level 2: many small tasks, so one dense root cell is not one thread's).
void collectWalkUnits(const Volume& v, const WalkedElement& e, int deepest, int unitLevel,
                      std::vector<WalkedElement>& units) {
  if (e.state() != ElementState::Branch || e.level >= deepest || e.level >= unitLevel) {
    units.push_back(e);
    return;
  }
  for (int c = 0; c < 8; ++c) collectWalkUnits(v, childElement(v, e, c), deepest, unitLevel, units);
}

// The leaves' origins (by leaf index) and the uniform elements in the order
// of walkVolume, the walk's units (collectWalkUnits) in parallel: each unit's
// uniform elements counted by a first walk, written at their place by a second.
void walkForWinding(const Volume& v, int deepest, std::vector<std::array<int, 3>>& leafOrigins,
                    std::vector<WindingUniformJob>& jobs) {
  const auto t0 = std::chrono::steady_clock::now();
  const uint64_t R = uint64_t(v.grid.rootGrid), roots = R * R * R;
  std::vector<WalkedElement> units;
  for (uint64_t r = 0; r < roots; ++r) collectWalkUnits(v, rootElement(v, r), deepest, 2, units);
  const auto uniform = [](const WalkedElement& e) {
    return e.state() == ElementState::Empty || e.state() == ElementState::Full;
  };
  std::vector<uint64_t> start(units.size() + 1, 0);
  tbb::parallel_for(size_t(0), units.size(), [&](size_t u) {
    uint64_t n = 0;
    auto visit = [&](const WalkedElement& e) {
      if (e.state() == ElementState::Boundary) leafOrigins[e.payload()] = e.origin;
      n += uniform(e);
    };
    walkSubtree(v, units[u], deepest, visit);
    start[u + 1] = n;
  });
  std::partial_sum(start.begin(), start.end(), start.begin());
  jobs.resize(start.back());
  tbb::parallel_for(size_t(0), units.size(), [&](size_t u) {
    WindingUniformJob* out = jobs.data() + start[u];
    auto visit = [&](const WalkedElement& e) {
      if (uniform(e)) *out++ = {e.index, e.origin, e.edge};
    };
    walkSubtree(v, units[u], deepest, visit);
  });
  traceWinding("walk of the volume", t0);
}

} // namespace winding_pass

using namespace winding_pass;

WindingOutcome classifyByWindingNumber(const WindingTree& tree, Volume& volume) {
  return classifyByWindingNumber(tree, volume, WindingLeafPass());
}

WindingOutcome classifyByWindingNumber(const WindingTree& tree, Volume& volume, const WindingLeafPass& leafPass,
                                       const WindingUniformPass& uniformPass, const WindingFreshLeafPass& freshPass,
                                       ProgressPoll* progress) {
  const WindingTreeView t = tree.view();
  const int L = volume.grid.leafSize;
  std::vector<uint8_t> split(volume.elements.size(), 0);
  bool anySplit = false;
  const int deepest = int(volume.levelStart.size()) - 2;
  const size_t leafCount = volume.leafWords.size() / leafWordCount(L);
  std::vector<std::array<int, 3>> leafOrigins(leafCount);
  std::vector<WindingUniformJob> jobs; // the uniform elements, in walk order
  walkForWinding(volume, deepest, leafOrigins, jobs);
  reportWinding(progress, 0.1);
  // The blocks of the leaves and of the uniform elements that fit in one,
  // for the host's passes.
  CoarseThresholds coarse;
  if (!uniformPass || !leafPass) {
    std::vector<std::array<int, 3>> inBlocks = leafOrigins;
    for (const WindingUniformJob& j : jobs)
      if (j.edge <= kCoarseLeaves * L) inBlocks.push_back(j.origin);
    coarse = coarseThresholds(t, inBlocks, L, volume.grid.resolution, progress);
    reportWinding(progress, 0.15);
  }
  const std::vector<UniformVerdict> verdicts = decideUniformJobs(tree, jobs, uniformPass, progress, &coarse);
  reportWinding(progress, 0.3);
  for (size_t i = 0; i < jobs.size(); ++i) {
    volume.elements[jobs[i].index] = makeElement(verdicts[i].inside ? ElementState::Full : ElementState::Empty, 0);
    if (verdicts[i].split) {
      split[jobs[i].index] = 1;
      anySplit = true;
    }
  }
  std::vector<uint32_t> left;
  if (leafPass && leafPass(tree, volume, leafOrigins, left)) {
    tbb::parallel_for(size_t(0), left.size(), [&](size_t i) {
      if (abortRequested(progress)) return;
      const uint32_t leaf = left[i];
      classifyLeaf(t, volume.leafWords.data() + leafWordOffset(leaf, L), L, leafOrigins[leaf]);
    });
  } else {
    if (coarse.keys.empty() && !leafOrigins.empty())
      coarse = coarseThresholds(t, leafOrigins, L, volume.grid.resolution, progress);
    classifyLeavesByCrossings(tree, volume, leafOrigins, coarse, progress);
  }
  reportWinding(progress, 0.85);
  WindingOutcome out;
  if (anySplit) out.refinedElements = refineSplitElements(tree, volume, split, uniformPass, freshPass, progress);
  return out;
}

double applyInsideTest(const PreparedMesh& mesh, Volume& volume) {
  return applyInsideTest(mesh, volume, WindingLeafPass());
}

double applyInsideTest(const PreparedMesh& mesh, Volume& volume, const WindingLeafPass& leafPass,
                       const WindingUniformPass& uniformPass, const WindingFreshLeafPass& freshPass,
                       WindingTreeInBackground* early, ProgressPoll* progress) {
  volume.insideTest = mesh.surfaceOnly ? InsideTest::Parity : mesh.insideTest;
  if (!windingPassFollows(mesh)) return 0;
  const auto t0 = std::chrono::steady_clock::now();
  reportWinding(progress, 0.0);
  WindingTree local;
  const WindingTree& tree = early && early->started() ? early->get() : (local = buildWindingTree(mesh.triangles));
  traceWinding("tree (built or waited for)", t0);
  volume.stats.windingRefinedElements =
      classifyByWindingNumber(tree, volume, leafPass, uniformPass, freshPass, progress).refinedElements;
  return std::chrono::duration<double, std::milli>(std::chrono::steady_clock::now() - t0).count();
}

double applyInsideTestAfterCpuPhases(const PreparedMesh& mesh, Volume& volume, const ProgressPoll::Callback& progress) {
  ProgressPoll poll(progress, kCpuPhasesShareBeforeWinding, 1.0);
  const double ms =
      applyInsideTest(mesh, volume, WindingLeafPass(), WindingUniformPass(), WindingFreshLeafPass(), nullptr, &poll);
  if (windingPassFollows(mesh)) poll.report(1.0, "done");
  return ms;
}

} // namespace hdt
