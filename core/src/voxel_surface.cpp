// Voxel surface extraction (voxel_surface.hpp).
//
// The walk (volume_walk.hpp) down to the cut level gives the units: leaf
// grids (coarsened to cells of edge c when the level of detail asks for it),
// Full elements and Branch elements at the cut (which take the largest state
// below them). Each unit makes the faces on its own side of every face:
//   * a leaf grid, as bit rows of n = L / c cells (bit = x), face masks per
//     slice against its own cells or, on its border, one layer of the
//     neighbour (another leaf, a uniform element, or outside the grid), then
//     greedy rectangles per slice;
//   * a solid unit, against the neighbour pieces under its face (a larger or
//     equal uniform element, or the subtree of an equal Branch: uniform
//     elements, cut Branches, leaf layers), one rectangle when all of it is
//     unoccupied.
// Units are independent, so they run in parallel, in chunks of units; each
// thread appends its chunks' quads to its own list, and the chunks are joined
// in walk order, which fixes the output whatever the thread count. Every
// large array is written fresh, so all of them get huge pages
// (huge_pages.hpp): page faults, not the faces, were most of the time.
#include "hdt/voxel_surface.hpp"

#include "hdt/error.hpp"
#include "hdt/huge_pages.hpp"
#include "hdt/labels.hpp"
#include "hdt/volume_walk.hpp"

#include <tbb/enumerable_thread_specific.h>
#include <tbb/parallel_for.h>

#include <algorithm>
#include <functional>
#include <string>

namespace hdt {
namespace {

constexpr int kMaxCells = 32; // cells per leaf axis (L <= 32)

int log2Exact(int v) {
  int l = 0;
  while ((1 << l) < v) ++l;
  return l;
}

uint32_t lowBits(int n) { return n >= 32 ? ~0u : (1u << n) - 1u; }

// The two in-plane axes of a face across `axis` (voxel_surface.hpp).
int uAxis(int axis) { return axis == 0 ? 1 : 0; }
int vAxis(int axis) { return axis == 2 ? 1 : 2; }

// Even bits of x packed to the low half (the inverse of spreading).
uint32_t compactEven(uint64_t x) {
  x &= 0x5555555555555555ull;
  x = (x | (x >> 1)) & 0x3333333333333333ull;
  x = (x | (x >> 2)) & 0x0F0F0F0F0F0F0F0Full;
  x = (x | (x >> 4)) & 0x00FF00FF00FF00FFull;
  x = (x | (x >> 8)) & 0x0000FFFF0000FFFFull;
  x = (x | (x >> 16)) & 0x00000000FFFFFFFFull;
  return uint32_t(x);
}

// Row (y, z) of an L^3 leaf grid as 2L bits, voxel x at bits 2x, 2x + 1.
uint64_t leafRow(const uint32_t* words, int L, int y, int z) {
  const uint32_t v = uint32_t(L) * uint32_t(y + L * z);
  switch (L) {
  case 8: return (words[v >> 4] >> (2 * (v & 15u))) & 0xFFFFu;
  case 16: return words[v >> 4];
  default: return uint64_t(words[v >> 4]) | (uint64_t(words[(v >> 4) + 1]) << 32);
  }
}

struct Context {
  const Volume& v;
  int N = 0, L = 0;
  int c = 1;        // cell edge in voxels
  int n = 1;        // cells per leaf axis (when c <= L)
  int cutLevel = 0; // the walk's depth limit
  bool surfaceOnly = false;
  bool labelled = false;
  std::vector<uint8_t> largest; // largest state below each element of level >= cutLevel (cut < h only)

  explicit Context(const Volume& vol) : v(vol) {}
  bool occupied(int state) const { return surfaceOnly ? state == int(VoxelState::Surface) : state != 0; }
  uint32_t occupancy(uint32_t surface, uint32_t inside) const { return surface | (surfaceOnly ? 0u : inside); }
};

// Surface and inside bits (bit = x cell) of the cell row (cy, cz) of a leaf at
// cell edge c: a cell is Surface if any voxel is, else Inside if any voxel is.
void cellRow(const Context& ctx, const uint32_t* words, int cy, int cz, uint32_t& surface, uint32_t& inside) {
  if (ctx.c == 1) { // full depth: the voxels themselves
    const uint64_t r = leafRow(words, ctx.L, cy, cz);
    surface = compactEven(r >> 1);
    inside = compactEven(r) & ~surface;
    return;
  }
  uint32_t s = 0, in = 0;
  for (int z = cz * ctx.c; z < (cz + 1) * ctx.c; ++z)
    for (int y = cy * ctx.c; y < (cy + 1) * ctx.c; ++y) {
      const uint64_t r = leafRow(words, ctx.L, y, z);
      in |= compactEven(r);
      s |= compactEven(r >> 1);
    }
  if (ctx.c > 1) {
    uint32_t cs = 0, ci = 0;
    const uint32_t group = lowBits(ctx.c);
    for (int k = 0; k < ctx.n; ++k) {
      cs |= ((s >> (k * ctx.c)) & group) ? 1u << k : 0u;
      ci |= ((in >> (k * ctx.c)) & group) ? 1u << k : 0u;
    }
    s = cs;
    in = ci;
  }
  surface = s;
  inside = in & ~s;
}

uint32_t occupiedRow(const Context& ctx, const uint32_t* words, int cy, int cz) {
  uint32_t s, in;
  cellRow(ctx, words, cy, cz, s, in);
  return ctx.occupancy(s, in);
}

// Occupancy of cell layer k across `axis` of a leaf, as rows (index: the v
// axis) of bits (the u axis).
void leafLayer(const Context& ctx, const uint32_t* words, int axis, int k, uint32_t* layer) {
  const int n = ctx.n;
  for (int r = 0; r < n; ++r) layer[r] = 0;
  if (axis == 2) {
    for (int y = 0; y < n; ++y) layer[y] = occupiedRow(ctx, words, y, k);
  } else if (axis == 1) {
    for (int z = 0; z < n; ++z) layer[z] = occupiedRow(ctx, words, k, z);
  } else {
    for (int z = 0; z < n; ++z)
      for (int y = 0; y < n; ++y) layer[z] |= ((occupiedRow(ctx, words, y, z) >> k) & 1u) << y;
  }
}

// Rectangles of set bits of rows[0..n) (bit = u), greedy: widest run first,
// then as many rows down as it fits. Clears the rows.
template <class Emit>
void greedyRectangles(uint32_t* rows, int n, bool merge, Emit&& emit) {
  for (int v = 0; v < n; ++v) {
    while (rows[v]) {
      const int u = __builtin_ctz(rows[v]);
      int w = 1;
      if (merge) {
        const uint64_t rest = uint64_t(rows[v]) >> u;
        w = __builtin_ctzll(~rest);
      }
      const uint32_t run = uint32_t(((uint64_t(1) << w) - 1) << u);
      int v1 = v + 1;
      while (merge && v1 < n && (rows[v1] & run) == run) rows[v1++] &= ~run;
      rows[v] &= ~run;
      emit(u, v, w, v1 - v);
    }
  }
}

using QuadList = std::vector<SurfaceQuad, HugePageAllocator<SurfaceQuad>>;

class UnitFaces {
public:
  UnitFaces(const Context& ctx, bool merge, QuadList& out) : ctx_(ctx), merge_(merge), out_(out) {
    std::fill(&surfaceMask_[0][0], &surfaceMask_[0][0] + kMaxCells * kMaxCells, 0u);
    std::fill(&insideMask_[0][0], &insideMask_[0][0] + kMaxCells * kMaxCells, 0u);
  }

  void leaf(const WalkedElement& e) {
    const int n = ctx_.n;
    const uint32_t* words = ctx_.v.leaf(e.payload());
    leafLabel_ = ctx_.labelled ? ctx_.v.labels.elementLabels[e.index] : kOutsideLabel;
    mixed_ = ctx_.labelled && leafLabel_ == kOutsideLabel;
    if (mixed_) computeCellLabels(e);
    for (int z = 0; z < n; ++z)
      for (int y = 0; y < n; ++y) {
        uint32_t in;
        cellRow(ctx_, words, y, z, surface_[z][y], in);
        occupied_[z][y] = ctx_.occupancy(surface_[z][y], in);
      }
    for (int axis = 0; axis < 3; ++axis)
      for (int outward : {1, -1}) leafSide(e, axis, outward);
  }

  void solid(const WalkedElement& e, uint8_t state, Label label) {
    for (int axis = 0; axis < 3; ++axis)
      for (int outward : {1, -1}) solidSide(e, state, label, axis, outward);
  }

private:
  void emit(int axis, int outward, int plane, int u, int v, int du, int dv, int state, Label label) {
    SurfaceQuad q;
    q.axis = uint8_t(axis);
    q.outward = int8_t(outward);
    q.state = uint8_t(state);
    q.label = label;
    q.plane = plane;
    q.u = u;
    q.v = v;
    q.du = du;
    q.dv = dv;
    out_.push_back(q);
  }

  // Occupancy of the neighbour cell layer beyond side (axis, outward) of leaf e.
  void neighbourLayer(const WalkedElement& e, int axis, int outward, uint32_t* layer) const {
    const int p = outward > 0 ? e.origin[axis] + e.edge : e.origin[axis] - 1;
    if (p < 0 || p >= ctx_.N) {
      std::fill(layer, layer + ctx_.n, 0u);
      return;
    }
    std::array<int, 3> at = e.origin;
    at[axis] = p;
    const WalkedElement nb = locateElement(ctx_.v, at[0], at[1], at[2], ctx_.cutLevel);
    if (nb.state() == ElementState::Boundary) {
      leafLayer(ctx_, ctx_.v.leaf(nb.payload()), axis, outward > 0 ? 0 : ctx_.n - 1, layer);
      return;
    }
    const bool full = nb.state() == ElementState::Full && ctx_.occupied(int(VoxelState::Inside));
    std::fill(layer, layer + ctx_.n, full ? lowBits(ctx_.n) : 0u);
  }

  void leafSide(const WalkedElement& e, int axis, int outward) {
    const int n = ctx_.n;
    uint32_t layer[kMaxCells];
    neighbourLayer(e, axis, outward, layer);
    // Face masks per slice (cell index across axis): rows v, bits u. They
    // are all zero here: the greedy pass below clears every bit it reads.
    const int last = outward > 0 ? n - 1 : 0;
    auto split = [&](int slice, int row, uint32_t faces, uint32_t surfaceCells) {
      surfaceMask_[slice][row] |= faces & surfaceCells;
      insideMask_[slice][row] |= faces & ~surfaceCells;
    };
    if (axis == 2) {
      for (int z = 0; z < n; ++z)
        for (int y = 0; y < n; ++y) {
          const uint32_t beyond = z == last ? layer[y] : occupied_[z + outward][y];
          split(z, y, occupied_[z][y] & ~beyond, surface_[z][y]);
        }
    } else if (axis == 1) {
      for (int z = 0; z < n; ++z)
        for (int y = 0; y < n; ++y) {
          const uint32_t beyond = y == last ? layer[z] : occupied_[z][y + outward];
          split(y, z, occupied_[z][y] & ~beyond, surface_[z][y]);
        }
    } else {
      const uint32_t cells = lowBits(n);
      for (int z = 0; z < n; ++z)
        for (int y = 0; y < n; ++y) {
          const uint32_t row = occupied_[z][y];
          const uint32_t edge = (layer[z] >> y) & 1u;
          const uint32_t beyond = outward > 0 ? (row >> 1) | (edge << (n - 1)) : (row << 1) | edge;
          uint32_t faces = row & ~beyond & cells;
          while (faces) { // x faces: transpose to slices x, rows z, bits y
            const int x = __builtin_ctz(faces);
            faces &= faces - 1;
            ((surface_[z][y] >> x) & 1u ? surfaceMask_ : insideMask_)[x][z] |= 1u << y;
          }
        }
    }
    const int c = ctx_.c, ou = e.origin[uAxis(axis)], ov = e.origin[vAxis(axis)];
    for (int i = 0; i < n; ++i) {
      const int plane = e.origin[axis] + (outward > 0 ? i + 1 : i) * c;
      for (int state : {int(VoxelState::Surface), int(VoxelState::Inside)}) {
        uint32_t* rows = state == int(VoxelState::Surface) ? surfaceMask_[i] : insideMask_[i];
        sliceRectangles(axis, i, rows, [&](int u, int v, int du, int dv, Label label) {
          emit(axis, outward, plane, ou + u * c, ov + v * c, du * c, dv * c, state, label);
        });
      }
    }
  }

  // Labels of the cells of a leaf holding several labels: a voxel's own, a
  // coarser cell's the majority of its voxels (the hyper tree grid's rule).
  void computeCellLabels(const WalkedElement& e) {
    const int L = ctx_.L, n = ctx_.n, c = ctx_.c;
    const LeafLabels voxels = leafLabels(ctx_.v, e.index);
    cellLabels_.resize(size_t(n) * n * n);
    LabelHistogram histogram;
    for (int z = 0; z < n; ++z)
      for (int y = 0; y < n; ++y)
        for (int x = 0; x < n; ++x) {
          histogram.clear();
          for (int vz = z * c; vz < (z + 1) * c; ++vz)
            for (int vy = y * c; vy < (y + 1) * c; ++vy)
              for (int vx = x * c; vx < (x + 1) * c; ++vx) addToHistogram(histogram, voxels[uint32_t(vx + L * (vy + L * vz))], 1);
          cellLabels_[size_t(x + n * (y + n * z))] = majorityLabel(histogram);
        }
  }

  // Label of the cell at bit `bit` of row `row` of slice `slice` of the face
  // masks across `axis` (the layout leafSide writes).
  Label cellLabel(int axis, int slice, int row, int bit) const {
    int x = bit, y = row, z = slice; // axis 2
    if (axis == 1) {
      y = slice;
      z = row;
    } else if (axis == 0) {
      x = slice;
      y = bit;
      z = row;
    }
    return cellLabels_[size_t(x + ctx_.n * (y + ctx_.n * z))];
  }

  // Rectangles of the face mask rows of one slice and state, emitted with
  // their label: in a leaf of several labels one greedy pass per label, so
  // that no rectangle spans two. Clears the rows.
  template <class Emit> void sliceRectangles(int axis, int slice, uint32_t* rows, Emit&& emit) {
    const int n = ctx_.n;
    if (!mixed_) {
      greedyRectangles(rows, n, merge_, [&](int u, int v, int du, int dv) { emit(u, v, du, dv, leafLabel_); });
      return;
    }
    uint32_t part[kMaxCells];
    for (int first = 0; first < n;) {
      if (!rows[first]) {
        ++first;
        continue;
      }
      const Label label = cellLabel(axis, slice, first, __builtin_ctz(rows[first]));
      for (int v = 0; v < n; ++v) {
        part[v] = 0;
        for (uint32_t bits = rows[v]; bits; bits &= bits - 1) {
          const int u = __builtin_ctz(bits);
          if (cellLabel(axis, slice, v, u) == label) part[v] |= 1u << u;
        }
        rows[v] &= ~part[v];
      }
      greedyRectangles(part, n, merge_, [&](int u, int v, int du, int dv) { emit(u, v, du, dv, label); });
    }
  }

  struct Rect {
    int u, v, du, dv;
  };

  // Unoccupied parts of neighbour element nb under the face of e (side axis, outward).
  void unoccupiedParts(const WalkedElement& e, const WalkedElement& nb, int axis, int outward) {
    const int ua = uAxis(axis), va = vAxis(axis);
    const WalkedElement& box = nb.edge >= e.edge ? e : nb; // the part of the face nb covers
    const Rect whole{box.origin[ua], box.origin[va], box.edge, box.edge};
    switch (nb.state()) {
    case ElementState::Empty:
    case ElementState::Full:
      if (!ctx_.occupied(int(nb.state()))) parts_.push_back(whole);
      return;
    case ElementState::Boundary: {
      uint32_t layer[kMaxCells];
      leafLayer(ctx_, ctx_.v.leaf(nb.payload()), axis, outward > 0 ? 0 : ctx_.n - 1, layer);
      for (int r = 0; r < ctx_.n; ++r) layer[r] = ~layer[r] & lowBits(ctx_.n);
      const int c = ctx_.c;
      greedyRectangles(layer, ctx_.n, merge_, [&](int u, int v, int du, int dv) {
        parts_.push_back(Rect{nb.origin[ua] + u * c, nb.origin[va] + v * c, du * c, dv * c});
      });
      return;
    }
    case ElementState::Branch:
      if (nb.level >= ctx_.cutLevel) {
        if (!ctx_.occupied(ctx_.largest[nb.index])) parts_.push_back(whole);
        return;
      }
      for (int child = 0; child < 8; ++child)
        if (((child >> axis) & 1) == (outward > 0 ? 0 : 1)) // the children touching the face
          unoccupiedParts(e, childElement(ctx_.v, nb, child), axis, outward);
      return;
    }
  }

  void solidSide(const WalkedElement& e, int state, Label label, int axis, int outward) {
    const int plane = e.origin[axis] + (outward > 0 ? e.edge : 0);
    const int ua = uAxis(axis), va = vAxis(axis);
    parts_.clear();
    const int p = outward > 0 ? plane : plane - 1;
    if (p < 0 || p >= ctx_.N) {
      parts_.push_back(Rect{e.origin[ua], e.origin[va], e.edge, e.edge});
    } else {
      std::array<int, 3> at = e.origin;
      at[axis] = p;
      unoccupiedParts(e, locateElement(ctx_.v, at[0], at[1], at[2], e.level), axis, outward);
    }
    int64_t area = 0;
    for (const Rect& r : parts_) area += int64_t(r.du) * r.dv;
    if (merge_ && area == int64_t(e.edge) * e.edge) {
      emit(axis, outward, plane, e.origin[ua], e.origin[va], e.edge, e.edge, state, label);
      return;
    }
    for (const Rect& r : parts_) {
      if (merge_) {
        emit(axis, outward, plane, r.u, r.v, r.du, r.dv, state, label);
        continue;
      }
      for (int dv = 0; dv < r.dv; dv += ctx_.c) // unmerged: one quad a cell
        for (int du = 0; du < r.du; du += ctx_.c) emit(axis, outward, plane, r.u + du, r.v + dv, ctx_.c, ctx_.c, state, label);
    }
  }

  const Context& ctx_;
  bool merge_;
  QuadList& out_;
  uint32_t surface_[kMaxCells][kMaxCells];  // [z][y], bit x
  uint32_t occupied_[kMaxCells][kMaxCells]; // [z][y], bit x
  uint32_t surfaceMask_[kMaxCells][kMaxCells], insideMask_[kMaxCells][kMaxCells]; // [slice][v], bit u
  std::vector<Rect> parts_;
  Label leafLabel_ = kOutsideLabel; // the label of every occupied cell of the leaf, unless mixed_
  bool mixed_ = false;              // the leaf holds several labels: cellLabels_
  std::vector<Label> cellLabels_;   // [x + n (y + n z)]
};

// Largest state below every element of levels h .. cutLevel, bottom-up.
void computeLargestStates(Context& ctx) {
  const Volume& v = ctx.v;
  ctx.largest.assign(v.elements.size(), 0);
  const uint32_t wordsPerLeaf = leafWordCount(ctx.L);
  for (int level = v.grid.height; level >= ctx.cutLevel; --level) {
    tbb::parallel_for(v.levelStart[size_t(level)], v.levelStart[size_t(level) + 1], [&](uint64_t i) {
      const ElementWord w = v.elements[i];
      uint8_t s = 0;
      switch (elementState(w)) {
      case ElementState::Empty: break;
      case ElementState::Full: s = uint8_t(VoxelState::Inside); break;
      case ElementState::Boundary: {
        uint32_t any = 0;
        const uint32_t* words = v.leaf(elementPayload(w));
        for (uint32_t k = 0; k < wordsPerLeaf; ++k) any |= words[k];
        s = (any & 0xAAAAAAAAu) ? uint8_t(VoxelState::Surface) : (any & 0x55555555u) ? uint8_t(VoxelState::Inside) : 0;
        break;
      }
      case ElementState::Branch:
        for (uint32_t k = 0; k < 8; ++k) s = std::max(s, ctx.largest[elementPayload(w) + k]);
        break;
      }
      ctx.largest[i] = s;
    });
  }
}

void checkWalkable(const Volume& v) {
  const GridSpec& g = v.grid;
  const uint64_t R = uint64_t(g.rootGrid);
  if ((g.leafSize != 8 && g.leafSize != 16 && g.leafSize != 32) || R < 1 || g.height < 0 ||
      v.levelStart.size() != size_t(g.height) + 2 || v.elements.size() < R * R * R ||
      int64_t(g.rootGrid) * (int64_t(1) << g.height) * g.leafSize != g.resolution) {
    throw Error(ErrorKind::InvalidArgument, "voxel surface: the volume is empty or malformed");
  }
}

} // namespace

int surfaceCellEdge(const GridSpec& g, int maxDepth) {
  const int full = g.height + log2Exact(g.leafSize);
  const int depth = (maxDepth < 0 || maxDepth > full) ? full : maxDepth;
  return std::max(1, g.rootCellVoxels() >> depth);
}

namespace {

// The quads of a fixed chunk of units (walk order): a range of the list of
// the thread that made them.
struct ChunkQuads {
  const QuadList* list = nullptr;
  size_t begin = 0, end = 0;
  size_t size() const { return end - begin; }
  const SurfaceQuad* data() const { return list->data() + begin; }
};

struct SurfaceChunks {
  tbb::enumerable_thread_specific<QuadList> lists; // addresses stable
  std::vector<ChunkQuads> chunks;                  // walk order
};

// Label of a uniform element or of a Branch cut by the level of detail.
Label solidLabel(const Volume& v, const WalkedElement& e) {
  if (v.labels.empty()) return kOutsideLabel;
  if (e.state() == ElementState::Full) return v.labels.elementLabels[e.index];
  return majorityLabel(cellLabelHistogram(v, e.origin[0], e.origin[1], e.origin[2], e.edge));
}

// The quads of every unit, in fixed chunks of units (walk order): the order
// does not depend on how tasks are scheduled.
void extractChunks(const Volume& volume, const SurfaceOptions& options, SurfaceChunks& out) {
  checkWalkable(volume);
  const GridSpec& g = volume.grid;
  Context ctx(volume);
  ctx.N = g.resolution;
  ctx.L = g.leafSize;
  ctx.c = surfaceCellEdge(g, options.maxDepth);
  ctx.n = std::max(1, ctx.L / ctx.c);
  ctx.cutLevel = std::min(g.height, log2Exact(g.rootCellVoxels() / ctx.c));
  ctx.surfaceOnly = volume.surfaceOnly;
  ctx.labelled = !volume.labels.empty();
  if (ctx.cutLevel < g.height) computeLargestStates(ctx);

  // Units that can have faces, in walk order.
  std::vector<WalkedElement> units;
  const int rootEdge = g.rootCellVoxels();
  const uint64_t R = uint64_t(g.rootGrid);
  const bool allCells = options.cellsFirst == 0 && options.cellsEnd >= R * R * R;
  walkVolume(volume, ctx.cutLevel, [&](const WalkedElement& e) {
    if (!allCells) {
      const uint64_t cell = uint64_t(e.origin[0] / rootEdge) +
                            R * (uint64_t(e.origin[1] / rootEdge) + R * uint64_t(e.origin[2] / rootEdge));
      if (cell < options.cellsFirst || cell >= options.cellsEnd) return;
    }
    const ElementState s = e.state();
    const bool maybe = s == ElementState::Boundary ||
                       (s == ElementState::Full && ctx.occupied(int(VoxelState::Inside))) ||
                       (s == ElementState::Branch && ctx.occupied(ctx.largest[e.index]));
    if (maybe) units.push_back(e);
  });

  constexpr size_t kChunk = 256;
  const size_t chunks = (units.size() + kChunk - 1) / kChunk;
  out.chunks.assign(chunks, ChunkQuads{});
  tbb::parallel_for(size_t(0), chunks, [&](size_t chunk) {
    QuadList& list = out.lists.local();
    const size_t begin = list.size();
    UnitFaces faces(ctx, options.merge, list);
    const size_t end = std::min(units.size(), (chunk + 1) * kChunk);
    for (size_t i = chunk * kChunk; i < end; ++i) {
      const WalkedElement& e = units[i];
      switch (e.state()) {
      case ElementState::Boundary: faces.leaf(e); break;
      case ElementState::Full: faces.solid(e, uint8_t(VoxelState::Inside), solidLabel(volume, e)); break;
      default: faces.solid(e, ctx.largest[e.index], solidLabel(volume, e)); break;
      }
    }
    out.chunks[chunk] = ChunkQuads{&list, begin, list.size()};
  });
}

std::vector<size_t> chunkOffsets(const std::vector<ChunkQuads>& chunks) {
  std::vector<size_t> offset(chunks.size() + 1, 0);
  for (size_t i = 0; i < chunks.size(); ++i) offset[i + 1] = offset[i] + chunks[i].size();
  return offset;
}

// A vector of `count` elements whose pages are huge where the kernel allows.
template <class T> void resizeFresh(std::vector<T>& v, size_t count) {
  v.clear();
  v.reserve(count);
  adviseHugePages(v.data(), count * sizeof(T));
  v.resize(count);
}

// The 4 corners of q in mesh units.
void quadCorners(const GridSpec& g, const SurfaceQuad& q, float* out) {
  const int ua = uAxis(q.axis), va = vAxis(q.axis);
  // Corners p, p + u, p + u + v, p + v turn around u x v, which is +axis for
  // x and z and -axis for y (u, v in increasing order); reverse as needed.
  const int turn = (q.axis == 1 ? -1 : 1) * q.outward;
  const int du[4] = {0, q.du, q.du, 0}, dv[4] = {0, 0, q.dv, q.dv};
  for (int k = 0; k < 4; ++k) {
    const int corner = turn > 0 ? k : 3 - k;
    int voxel[3];
    voxel[q.axis] = q.plane;
    voxel[ua] = q.u + du[corner];
    voxel[va] = q.v + dv[corner];
    for (int a = 0; a < 3; ++a) out[3 * k + a] = float(g.origin[size_t(a)] + double(voxel[a]) * g.voxelSize);
  }
}

} // namespace

std::vector<SurfaceQuad> extractSurfaceQuads(const Volume& volume, const SurfaceOptions& options) {
  SurfaceChunks parts;
  extractChunks(volume, options, parts);
  const std::vector<size_t> offset = chunkOffsets(parts.chunks);
  std::vector<SurfaceQuad> quads;
  resizeFresh(quads, offset.back());
  tbb::parallel_for(size_t(0), parts.chunks.size(), [&](size_t i) {
    const ChunkQuads& c = parts.chunks[i];
    std::copy(c.data(), c.data() + c.size(), quads.begin() + long(offset[i]));
  });
  return quads;
}

void extractVoxelSurfaceInto(const Volume& volume, const SurfaceOptions& options,
                             const std::function<SurfaceBuffers(size_t quads)>& allocate) {
  SurfaceChunks parts;
  extractChunks(volume, options, parts);
  const std::vector<size_t> offset = chunkOffsets(parts.chunks);
  const SurfaceBuffers out = allocate(offset.back());
  adviseHugePages(out.points, 12 * offset.back() * sizeof(float)); // a hint: the caller's memory, not yet written
  tbb::parallel_for(size_t(0), parts.chunks.size(), [&](size_t i) {
    const SurfaceQuad* quads = parts.chunks[i].data();
    for (size_t k = 0; k < parts.chunks[i].size(); ++k) {
      const size_t quad = offset[i] + k;
      quadCorners(volume.grid, quads[k], out.points + 12 * quad);
      out.states[quad] = quads[k].state;
      if (out.labels) out.labels[quad] = quads[k].label;
    }
  });
}

VoxelSurface extractVoxelSurface(const Volume& volume, const SurfaceOptions& options) {
  VoxelSurface s;
  extractVoxelSurfaceInto(volume, options, [&](size_t quads) {
    resizeFresh(s.points, 12 * quads);
    s.states.resize(quads);
    if (!volume.labels.empty()) s.labels.resize(quads);
    return SurfaceBuffers{s.points.data(), s.states.data(), volume.labels.empty() ? nullptr : s.labels.data()};
  });
  return s;
}

} // namespace hdt
