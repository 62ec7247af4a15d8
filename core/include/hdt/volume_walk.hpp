// One walk over the elements of a Volume (types.hpp layout).
//
// Every element the walk stops at is handed to a visitor with its place in the
// grid: origin (voxels), level (0 = root grid) and edge (voxels). It stops at
// uniform elements (Empty, Full), at leaf grids (Boundary: the payload is the
// leaf index) and at Branch elements of the depth limit `maxLevel`, so the
// visited elements tile the N^3 grid exactly once. Children are visited in
// Morton order (bit 0 = +x half), root cells x fastest: the order is fixed.
//
// voxelAt, the dense export, the voxel surface and (breadth first) the hyper
// tree grid conversion use it; the indices it follows are trusted
// (validateVolume checks them; the file reader does when it loads a volume).
#pragma once

#include "hdt/volume.hpp"

#include <tbb/parallel_for.h>

#include <array>
#include <cstdint>
#include <vector>

namespace hdt {

struct WalkedElement {
  uint64_t index = 0; // into Volume::elements
  ElementWord word = 0;
  int level = 0;
  int edge = 0;                     // voxels
  std::array<int, 3> origin{0, 0, 0}; // voxels, low corner

  ElementState state() const { return elementState(word); }
  uint32_t payload() const { return elementPayload(word); } // leaf index of a Boundary element
};

// Root cell `root` (x fastest) as a WalkedElement.
inline WalkedElement rootElement(const Volume& v, uint64_t root) {
  const uint64_t R = uint64_t(v.grid.rootGrid);
  const int edge = v.grid.rootCellVoxels();
  WalkedElement e;
  e.index = root;
  e.word = v.elements[root];
  e.edge = edge;
  e.origin = {int(root % R) * edge, int((root / R) % R) * edge, int(root / (R * R)) * edge};
  return e;
}

// Child c (Morton bits) of Branch element e.
inline WalkedElement childElement(const Volume& v, const WalkedElement& e, int c) {
  WalkedElement k;
  k.index = uint64_t(e.payload()) + uint64_t(c);
  k.word = v.elements[k.index];
  k.level = e.level + 1;
  k.edge = e.edge / 2;
  k.origin = {e.origin[0] + (c & 1) * k.edge, e.origin[1] + ((c >> 1) & 1) * k.edge,
              e.origin[2] + ((c >> 2) & 1) * k.edge};
  return k;
}

// Visits the subtree of e (e included) down to maxLevel, depth first.
// With `parallelFromEdge` > 0, the 8 children of a Branch whose children are
// at least that many voxels wide are walked as parallel tasks (so that a grid
// of few root cells is not walked serially); the visitor must then allow
// concurrent calls.
template <class Visit>
void walkSubtree(const Volume& v, const WalkedElement& e, int maxLevel, Visit& visit, int parallelFromEdge = 0) {
  if (e.state() != ElementState::Branch || e.level >= maxLevel) {
    visit(e);
    return;
  }
  auto child = [&](int c) { walkSubtree(v, childElement(v, e, c), maxLevel, visit, parallelFromEdge); };
  if (parallelFromEdge > 0 && e.edge / 2 >= parallelFromEdge) {
    tbb::parallel_for(0, 8, child);
  } else {
    for (int c = 0; c < 8; ++c) child(c);
  }
}

// Every element of the volume down to maxLevel, serially, in the walk order.
template <class Visit>
void walkVolume(const Volume& v, int maxLevel, Visit&& visit) {
  const uint64_t R = uint64_t(v.grid.rootGrid);
  for (uint64_t root = 0; root < R * R * R; ++root) walkSubtree(v, rootElement(v, root), maxLevel, visit);
}

// The same elements with root cells (and large subtrees, see walkSubtree) as
// parallel tasks; the visitor is called concurrently, in no fixed order.
template <class Visit>
void parallelWalkVolume(const Volume& v, int maxLevel, Visit&& visit, int parallelFromEdge = 64) {
  const uint64_t R = uint64_t(v.grid.rootGrid);
  tbb::parallel_for(uint64_t(0), R * R * R, [&](uint64_t root) {
    walkSubtree(v, rootElement(v, root), maxLevel, visit, parallelFromEdge);
  });
}

// The tree of root cell `root` level by level (breadth first): each level's
// elements in the order of their parents, the children of each in Morton
// order, which is the order of a VTK hyper tree's descriptor. visit(e) is
// called for every element reached and returns whether to descend into it;
// only a Branch element above maxLevel can be descended into. `level` and
// `next` are scratch storage a caller can keep between trees.
template <class Visit>
void walkTreeBreadthFirst(const Volume& v, uint64_t root, int maxLevel, Visit&& visit,
                          std::vector<WalkedElement>& level, std::vector<WalkedElement>& next) {
  level.assign(1, rootElement(v, root));
  while (!level.empty()) {
    next.clear();
    for (const WalkedElement& e : level) {
      const bool descend = visit(e);
      if (descend && e.state() == ElementState::Branch && e.level < maxLevel)
        for (int c = 0; c < 8; ++c) next.push_back(childElement(v, e, c));
    }
    level.swap(next);
  }
}

// The element the walk to maxLevel stops at that contains voxel (x, y, z),
// which must lie in the grid.
inline WalkedElement locateElement(const Volume& v, int x, int y, int z, int maxLevel) {
  const uint64_t R = uint64_t(v.grid.rootGrid);
  const int rootEdge = v.grid.rootCellVoxels();
  WalkedElement e = rootElement(v, uint64_t(x / rootEdge) + R * (uint64_t(y / rootEdge) + R * uint64_t(z / rootEdge)));
  while (e.state() == ElementState::Branch && e.level < maxLevel) {
    const int half = e.edge / 2;
    const int c = int(x - e.origin[0] >= half) | (int(y - e.origin[1] >= half) << 1) |
                  (int(z - e.origin[2] >= half) << 2);
    e = childElement(v, e, c);
  }
  return e;
}

} // namespace hdt
