// The re-lay of a volume whose uniform elements the w = 1/2 surface splits
// (docs/design.md, "uniform elements"): each split element refined, the fresh
// children decided level by level, the fresh leaves by the leaf decision, the
// tree laid out again in canonical level order.
#include "winding_pass.hpp"

#include "hdt/error.hpp"
#include "hdt/huge_pages.hpp"

#include <algorithm>
#include <atomic>
#include <future>
#include <stdexcept>

#include <tbb/parallel_for.h>
#include <tbb/parallel_invoke.h>

namespace hdt {
namespace winding_pass {
namespace {

std::array<int, 3> childOrigin(const std::array<int, 3>& o, int edge, int c) {
  const int h = edge / 2;
  return {o[0] + (c & 1) * h, o[1] + ((c >> 1) & 1) * h, o[2] + ((c >> 2) & 1) * h};
}

// An element of the refined layout: an old one (by index) or a new child of
// a split element.
// No member initializers: a level is sized unwritten (LaidLevel) and each
// element written whole, `LaidElement()` (zeros) first.
struct LaidElement {
  uint64_t old;
  bool fresh;
  bool split;
  bool inside; // fresh uniform elements
  std::array<int, 3> origin;
};
// One level of the refined layout (tens of MB at 8192^3: huge pages, sized
// without writing it, then written in parallel).
using LaidLevel = std::vector<LaidElement, HugePageScratchAllocator<LaidElement>>;

// Counts carried along a level by scanInChunks.
struct LaySums {
  uint64_t a = 0, b = 0;
  LaySums& operator+=(const LaySums& o) {
    a += o.a;
    b += o.b;
    return *this;
  }
};

// A serial loop `for i in [0, n): step(i, sums, write)` run in parallel:
// the chunks counted first (write false), then sized(total) (the outputs
// sized), then each chunk walked again from the sums of those before it
// (write true). The results are the serial loop's. (Not tbb::parallel_scan:
// its final pass may start before every chunk is counted, and the outputs
// are sized from the total first.)
template <class Step, class Sized>
LaySums scanInChunks(size_t n, const Step& step, const Sized& sized) {
  constexpr size_t kChunk = 8192;
  const size_t chunks = (n + kChunk - 1) / kChunk;
  std::vector<LaySums> before(chunks + 1);
  tbb::parallel_for(size_t(0), chunks, [&](size_t c) {
    LaySums s;
    for (size_t i = c * kChunk, end = std::min(n, i + kChunk); i < end; ++i) step(i, s, false);
    before[c + 1] = s;
  });
  for (size_t c = 0; c < chunks; ++c) before[c + 1] += before[c];
  sized(before[chunks]);
  tbb::parallel_for(size_t(0), chunks, [&](size_t c) {
    LaySums s = before[c];
    for (size_t i = c * kChunk, end = std::min(n, i + kChunk); i < end; ++i) step(i, s, true);
  });
  return before[chunks];
}

// Element payloads (branch places, leaf indices) hold 30 bits.
[[noreturn]] void throwRefinementTooLarge() {
  throw Error(ErrorKind::OutOfResources, "refining the winding number's w = 1/2 surface exceeds 2^30 elements");
}

// The elements of the refined layout from its levels (LaidElement, level
// order), each level in parallel: Branch payloads and leaf indices are prefix
// sums. Returns the number of leaves (old and fresh).
uint64_t layOutRefined(const Volume& v, const std::vector<LaidLevel>& levels, std::vector<uint64_t>& levelStart,
                       std::vector<ElementWord>& elements) {
  const int height = v.grid.height;
  for (int k = 0; k <= height; ++k) levelStart[size_t(k) + 1] = levelStart[size_t(k)] + levels[size_t(k)].size();
  if (levelStart.back() - 1 > kMaxElementPayload) throwRefinementTooLarge();
  elements.resize(levelStart.back());
  uint64_t leaves = 0;
  for (int k = 0; k <= height; ++k) {
    const LaidLevel& level = levels[size_t(k)];
    ElementWord* out = elements.data() + levelStart[size_t(k)];
    const uint64_t leafBase = leaves;
    // a: branches before element i, b: leaves.
    leaves += scanInChunks(
                  level.size(),
                  [&](size_t i, LaySums& s, bool write) {
                    const LaidElement& e = level[i];
                    const ElementWord old = e.fresh
                                                ? makeElement(e.inside ? ElementState::Full : ElementState::Empty, 0)
                                                : v.elements[e.old];
                    const ElementState state = elementState(old);
                    if (state == ElementState::Branch || (e.split && k < height)) {
                      if (write) out[i] = makeElement(ElementState::Branch, uint32_t(levelStart[size_t(k) + 1] + 8 * s.a));
                      ++s.a;
                    } else if (state == ElementState::Boundary || e.split) {
                      if (write) out[i] = makeElement(ElementState::Boundary, uint32_t(leafBase + s.b));
                      ++s.b;
                    } else if (write) {
                      out[i] = old;
                    }
                  },
                  [&](const LaySums& sums) {
                    if (leafBase + sums.b > kMaxElementPayload) throwRefinementTooLarge();
                  })
                  .b;
  }
  return leaves;
}

// Copies the old leaves' words into the refined layout: old leaf l goes to
// l + (fresh leaves before it), where fresh leaf j has cuts[j] old leaves
// before it (cuts ascending). Runs of old leaves between two fresh ones move
// by one offset: copied in blocks, in parallel.
void copyOldLeaves(const uint32_t* from, uint64_t oldLeaves, const std::vector<uint64_t>& cuts, uint32_t wc,
                   uint32_t* to) {
  constexpr uint64_t kBlock = 1024; // leaves
  tbb::parallel_for(uint64_t(0), (oldLeaves + kBlock - 1) / kBlock, [&](uint64_t block) {
    uint64_t l = block * kBlock;
    const uint64_t end = std::min(oldLeaves, l + kBlock);
    // fresh leaves before old leaf l: those with cuts[j] <= l
    uint64_t j = uint64_t(std::upper_bound(cuts.begin(), cuts.end(), l) - cuts.begin());
    while (l < end) {
      const uint64_t runEnd = j < cuts.size() ? std::min(end, cuts[j]) : end;
      std::copy(from + l * wc, from + runEnd * wc, to + (l + j) * wc);
      l = runEnd;
      while (j < cuts.size() && cuts[j] <= l) ++j;
    }
  });
}

// The levels of the refined layout, root cells first: each level's old
// elements and the 8 fresh children of each element split above it, whose
// verdicts (the uniform pass) say which of them split again, before the next
// level is laid. `refined` counts the split elements of every level.
struct RefinedLevels {
  std::vector<LaidLevel> levels;
  uint64_t refined = 0;
};

RefinedLevels layRefinedLevels(const WindingTree& tree, const Volume& v, const std::vector<uint8_t>& split,
                               const WindingUniformPass& uniformPass, ProgressPoll* progress) {
  const GridSpec& g = v.grid;
  const int height = g.height;
  const uint64_t R = uint64_t(g.rootGrid);
  RefinedLevels out;
  std::vector<LaidLevel>& levels = out.levels;
  levels.resize(size_t(height) + 1);
  levels[0].resize(R * R * R);
  tbb::parallel_for(uint64_t(0), R * R * R, [&](uint64_t i) {
    LaidElement& e = levels[0][i];
    e = LaidElement();
    e.old = i;
    e.split = split[i];
    const int edge = g.rootCellVoxels();
    e.origin = {int(i % R) * edge, int((i / R) % R) * edge, int(i / (R * R)) * edge};
  });
  double passMs = 0; // the fresh children's passes
  for (int k = 0; k < height; ++k) {
    const LaidLevel& level = levels[size_t(k)];
    LaidLevel& next = levels[size_t(k) + 1];
    const int edge = g.elementVoxels(k), childEdge = g.elementVoxels(k + 1);
    std::vector<WindingUniformJob> jobs; // the fresh children
    std::vector<uint64_t> at;            // their places in next
    // a: children before element i, b: split elements before it (each has 8
    // fresh children, the jobs).
    const LaySums total = scanInChunks(
        level.size(),
        [&](size_t i, LaySums& s, bool write) {
          const LaidElement& e = level[i];
          const bool oldBranch = !e.fresh && elementState(v.elements[e.old]) == ElementState::Branch;
          if (!oldBranch && !e.split) return;
          for (int c = 0; write && c < 8; ++c) {
            LaidElement& child = next[s.a + uint64_t(c)];
            child = LaidElement();
            child.origin = childOrigin(e.origin, edge, c);
            if (oldBranch) {
              child.old = uint64_t(elementPayload(v.elements[e.old])) + uint64_t(c);
              child.split = split[child.old];
            } else {
              child.fresh = true;
              jobs[8 * s.b + uint64_t(c)] = {0, child.origin, childEdge};
              at[8 * s.b + uint64_t(c)] = s.a + uint64_t(c);
            }
          }
          s.a += 8;
          s.b += e.split;
        },
        [&](const LaySums& sums) {
          next.resize(sums.a);
          jobs.resize(8 * sums.b);
          at.resize(8 * sums.b);
        });
    out.refined += total.b;
    if (jobs.empty()) continue; // no pass to run (nor a device call to make)
    const auto passStart = std::chrono::steady_clock::now();
    const std::vector<UniformVerdict> verdicts = decideUniformJobs(tree, jobs, uniformPass, progress);
    reportWinding(progress, 0.85 + 0.05 * double(k + 1) / double(height));
    passMs += std::chrono::duration<double, std::milli>(std::chrono::steady_clock::now() - passStart).count();
    tbb::parallel_for(size_t(0), jobs.size(), [&](size_t j) {
      next[at[j]].inside = verdicts[j].inside;
      next[at[j]].split = verdicts[j].split;
    });
  }
  for (const LaidElement& e : levels[size_t(height)]) out.refined += e.split;
  traceWindingMs("re-lay: fresh children's passes", passMs);
  return out;
}

// The fresh leaves: the split elements of the last level, in level order,
// and for each the number of old leaves before it in the refined layout
// (`cuts`, ascending). Old leaves keep their order (a level's old elements
// do, and leaf i is the i-th Boundary element); the leaves of the last level
// follow those above it.
struct FreshLeaves {
  std::vector<std::array<int, 3>> origins;
  std::vector<uint64_t> cuts;
};

FreshLeaves freshLeavesOf(const Volume& v, const LaidLevel& last) {
  const uint64_t oldLeaves = v.leafWords.size() / leafWordCount(v.grid.leafSize);
  FreshLeaves out;
  uint64_t lastBase = 0;             // old leaves above the last level
  std::atomic<bool> canonical{true}; // each old leaf where its order says
  // a: fresh leaves before element i, b: old leaves of the last level before it.
  scanInChunks(
      last.size(),
      [&](size_t i, LaySums& s, bool write) {
        const LaidElement& e = last[i];
        if (e.split) {
          if (write) {
            out.origins[s.a] = e.origin;
            out.cuts[s.a] = lastBase + s.b;
          }
          ++s.a;
        } else if (!e.fresh && elementState(v.elements[e.old]) == ElementState::Boundary) {
          if (write && elementPayload(v.elements[e.old]) != lastBase + s.b) canonical = false;
          ++s.b;
        }
      },
      [&](const LaySums& sums) {
        if (sums.b > oldLeaves) throw std::logic_error("refined layout: more leaves than leaf grids");
        lastBase = oldLeaves - sums.b;
        out.origins.resize(sums.a);
        out.cuts.resize(sums.a);
      });
  if (!canonical) throw std::logic_error("refined layout: the volume's leaves are not in level order");
  return out;
}

} // namespace

// Re-lays the tree in canonical level order with every split uniform element
// refined: a Branch of 8 fresh children above the last level, a Boundary
// with a new leaf grid (no surface voxel; every centre decided) at it.
// Each level is laid out in parallel (scanInChunks: the places of children,
// branches and leaves are prefix sums). Returns the number of elements refined.
uint64_t refineSplitElements(const WindingTree& tree, Volume& v, const std::vector<uint8_t>& split,
                             const WindingUniformPass& uniformPass, const WindingFreshLeafPass& freshPass,
                             ProgressPoll* progress) {
  auto t0 = std::chrono::steady_clock::now();
  const RefinedLevels laid = layRefinedLevels(tree, v, split, uniformPass, progress);
  traceWinding("re-lay: levels (fresh children's passes included)", t0);
  t0 = std::chrono::steady_clock::now();
  const int L = v.grid.leafSize;
  const uint32_t wc = leafWordCount(L);
  const uint64_t oldLeaves = v.leafWords.size() / wc;
  const FreshLeaves fresh = freshLeavesOf(v, laid.levels.back());
  // The new elements and the old leaves' words (host work) on a host thread
  // while the fresh leaves' pass runs (on the device, in the CUDA driver).
  std::vector<uint64_t> levelStart(size_t(v.grid.height) + 2, 0);
  std::vector<ElementWord> elements;
  LeafWordVector words;
  auto layout = std::async(std::launch::async, [&] {
    uint64_t leaves = 0;
    tbb::parallel_invoke([&] { leaves = layOutRefined(v, laid.levels, levelStart, elements); },
                         [&] {
                           words.resize((oldLeaves + fresh.origins.size()) * wc);
                           // written once below: few page faults
                           adviseHugePages(words.data(), words.size() * sizeof(uint32_t));
                           copyOldLeaves(v.leafWords.data(), oldLeaves, fresh.cuts, wc, words.data());
                         });
    if (leaves != oldLeaves + fresh.origins.size()) throw std::logic_error("refined layout: leaves out of step");
  });
  // Fresh leaves by the pass first (into their own array), the rest below.
  // (Should the pass throw, `layout`'s destructor waits for the task before
  // what it writes is destroyed: a future of std::async does.)
  std::vector<uint32_t> freshWords;
  std::vector<uint8_t> freshDone(fresh.origins.size(), 0);
  if (freshPass && !fresh.origins.empty()) {
    freshWords.assign(fresh.origins.size() * wc, 0u);
    std::vector<uint32_t> left;
    if (freshPass(tree, L, fresh.origins, freshWords.data(), left)) {
      std::fill(freshDone.begin(), freshDone.end(), uint8_t(1));
      for (uint32_t i : left) freshDone[i] = 0;
    }
  }
  traceWinding("re-lay: fresh leaves' pass", t0);
  layout.get();
  traceWinding("re-lay: elements and old leaves (beside the fresh leaves' pass)", t0);
  t0 = std::chrono::steady_clock::now();
  const WindingTreeView t = tree.view();
  tbb::parallel_for(size_t(0), fresh.origins.size(), [&](size_t f) {
    if (abortRequested(progress)) return;
    uint32_t* to = words.data() + (fresh.cuts[f] + f) * wc;
    if (freshDone[f]) {
      std::copy_n(freshWords.data() + f * wc, wc, to);
    } else {
      std::fill_n(to, wc, 0u);
      if (!decideFreshLeaf(t, to, L, fresh.origins[f])) classifyLeaf(t, to, L, fresh.origins[f]);
    }
  });
  v.elements = std::move(elements);
  v.levelStart = std::move(levelStart);
  v.leafWords = std::move(words);
  traceWinding("re-lay: fresh leaves' words", t0);
  return laid.refined;
}

} // namespace winding_pass
} // namespace hdt
