// Coarsened states over a box: each block counts the surface and inside voxels
// of the tree elements it meets (uniform elements by their overlap, leaf grids
// by popcount when the block holds them whole), then applies aggregateState.
// Blocks are independent, so they are computed in parallel without sharing.
#include "hdt/region.hpp"

#include "hdt/error.hpp"

#include <tbb/blocked_range.h>
#include <tbb/parallel_for.h>

#include <algorithm>
#include <bitset>
#include <string>

namespace hdt {
namespace {

struct Counts {
  uint64_t surface = 0;
  uint64_t inside = 0;
};

// Leaf words hold 16 two-bit states; 1 = inside, 2 = surface (types.hpp).
void countWord(uint32_t w, Counts& c) {
  const uint32_t lo = w & 0x55555555u, hi = (w >> 1) & 0x55555555u;
  c.surface += std::bitset<32>(hi & ~lo).count();
  c.inside += std::bitset<32>(lo & ~hi).count();
}

class BlockCounter {
public:
  explicit BlockCounter(const Volume& v) : v_(v), L_(v.grid.leafSize) {}

  // Adds the counts of element `index` (at `level`, first voxel `o`) inside `box`.
  void element(uint64_t index, int level, const int64_t o[3], const VoxelBox& box, Counts& c) const {
    const int64_t edge = v_.grid.elementVoxels(level);
    int64_t lo[3], hi[3], overlap = 1;
    bool whole = true;
    for (int a = 0; a < 3; ++a) {
      lo[a] = std::max(o[a], box.lo[a]);
      hi[a] = std::min(o[a] + edge, box.hi[a]);
      if (hi[a] <= lo[a]) return;
      overlap *= hi[a] - lo[a];
      whole = whole && hi[a] - lo[a] == edge;
    }
    const ElementWord w = v_.elements[index];
    switch (elementState(w)) {
    case ElementState::Empty: return;
    case ElementState::Full: c.inside += uint64_t(overlap); return;
    case ElementState::Boundary: leaf(elementPayload(w), o, lo, hi, whole, c); return;
    case ElementState::Branch: {
      const int64_t half = edge / 2;
      for (int ch = 0; ch < 8; ++ch) {
        const int64_t co[3] = {o[0] + (ch & 1) * half, o[1] + ((ch >> 1) & 1) * half, o[2] + ((ch >> 2) & 1) * half};
        element(uint64_t(elementPayload(w)) + uint64_t(ch), level + 1, co, box, c);
      }
      return;
    }
    }
  }

private:
  void leaf(uint64_t index, const int64_t o[3], const int64_t lo[3], const int64_t hi[3], bool whole,
            Counts& c) const {
    const uint32_t* words = v_.leaf(index);
    if (whole) {
      for (uint32_t i = 0, n = leafWordCount(L_); i < n; ++i) countWord(words[i], c);
      return;
    }
    for (int64_t z = lo[2]; z < hi[2]; ++z)
      for (int64_t y = lo[1]; y < hi[1]; ++y)
        for (int64_t x = lo[0]; x < hi[0]; ++x) {
          const uint32_t voxel = uint32_t((x - o[0]) + L_ * ((y - o[1]) + L_ * (z - o[2])));
          const uint32_t state = (words[voxel >> 4] >> (2 * (voxel & 15u))) & 3u;
          c.surface += state == uint32_t(VoxelState::Surface);
          c.inside += state == uint32_t(VoxelState::Inside);
        }
  }

  const Volume& v_;
  int L_;
};

int log2Exact(int64_t n) {
  int k = 0;
  while ((int64_t(1) << k) < n) ++k;
  return k;
}

} // namespace

VoxelBox alignToBlocks(const Volume& volume, VoxelBox box, int level) {
  const int64_t N = volume.grid.resolution, f = int64_t(1) << std::clamp(level, 0, 30);
  for (int a = 0; a < 3; ++a) {
    const int64_t lo = std::clamp<int64_t>(box.lo[a], 0, N), hi = std::clamp<int64_t>(box.hi[a], 0, N);
    box.lo[a] = std::min(lo / f * f, N);
    box.hi[a] = std::min((hi + f - 1) / f * f, N);
    if (box.hi[a] <= box.lo[a]) box.lo[a] = box.hi[a] = 0;
  }
  return box;
}

std::vector<uint8_t> coarseStates(const Volume& volume, const VoxelBox& box, int level) {
  const GridSpec& g = volume.grid;
  const int64_t N = g.resolution, R = g.rootGrid;
  if (level < 0 || level > log2Exact(N)) {
    throw Error(ErrorKind::InvalidArgument, "coarsening level " + std::to_string(level) +
                                                " is outside [0, " + std::to_string(log2Exact(N)) + "]");
  }
  const int64_t f = int64_t(1) << level;
  int64_t n[3];
  for (int a = 0; a < 3; ++a) {
    if (box.lo[a] < 0 || box.hi[a] > N || box.lo[a] % f || (box.size(a) % f && box.hi[a] != N) ||
        box.size(a) < 0) {
      throw Error(ErrorKind::InvalidArgument, "region is not aligned to blocks of " + std::to_string(f) +
                                                  " voxels inside the grid");
    }
    n[a] = (box.size(a) + f - 1) / f;
  }
  if (volume.elements.size() < uint64_t(R * R * R)) {
    throw Error(ErrorKind::InvalidArgument, "region export: the volume is empty or malformed");
  }
  std::vector<uint8_t> out(size_t(n[0] * n[1] * n[2]));
  const BlockCounter counter(volume);
  const int64_t cell = g.rootCellVoxels();
  tbb::parallel_for(tbb::blocked_range<int64_t>(0, n[1] * n[2]), [&](const tbb::blocked_range<int64_t>& rows) {
    for (int64_t row = rows.begin(); row != rows.end(); ++row) {
      const int64_t j = row % n[1], k = row / n[1];
      for (int64_t i = 0; i < n[0]; ++i) {
        VoxelBox block;
        const int64_t idx[3] = {i, j, k};
        for (int a = 0; a < 3; ++a) {
          block.lo[a] = box.lo[a] + idx[a] * f;
          block.hi[a] = std::min(block.lo[a] + f, box.hi[a]);
        }
        Counts c;
        for (int64_t rz = block.lo[2] / cell; rz * cell < block.hi[2]; ++rz)
          for (int64_t ry = block.lo[1] / cell; ry * cell < block.hi[1]; ++ry)
            for (int64_t rx = block.lo[0] / cell; rx * cell < block.hi[0]; ++rx) {
              const int64_t o[3] = {rx * cell, ry * cell, rz * cell};
              counter.element(uint64_t(rx + R * (ry + R * rz)), 0, o, block, c);
            }
        const uint64_t voxels = uint64_t(block.hi[0] - block.lo[0]) * uint64_t(block.hi[1] - block.lo[1]) *
                                uint64_t(block.hi[2] - block.lo[2]);
        out[size_t(i + n[0] * row)] = uint8_t(aggregateState(voxels, c.surface, c.inside));
      }
    }
  });
  return out;
}

} // namespace hdt
