// The bookkeeping of classification, shared by the CPU and CUDA drivers
// (docs/design.md, "Classification"): which leaves share a line of rays, how
// the parity beyond a leaf is accumulated along its line, and how uniform
// elements take their state. The geometry (pass 1) is in build_steps.hpp.
#pragma once

#include "hdt/build_steps.hpp"
#include "hdt/platform.hpp"

#include <cstdint>

namespace hdt {

// ---- line keys --------------------------------------------------------------------
// A leaf's place on its line of leaves along ray axis `axis`: key =
// (w << 2b) | (u << b) | along, in leaf coordinates, b = bits per field. Sorting
// the keys groups the leaves by line (w, u) and orders each line along the
// ray; key >> b names the line. One layout for both drivers (the CUDA radix
// sort takes 3b bits).
struct LineKeys {
  int bits; // b: enough for the leaves along one axis

  HDT_HD uint64_t key(uint64_t u, uint64_t w, uint64_t along) const {
    return (w << (2 * bits)) | (u << bits) | along;
  }
  HDT_HD uint64_t line(uint64_t key) const { return key >> bits; }
  HDT_HD bool sameLine(uint64_t a, uint64_t b) const { return (a >> bits) == (b >> bits); }
  // The key of the leaf at packed leaf coordinate c (packCoord).
  HDT_HD uint64_t ofLeaf(uint64_t c, int axis) const {
    return key(unpackCoord(c, rayAxisU(axis)), unpackCoord(c, rayAxisW(axis)), unpackCoord(c, axis));
  }
};

// Bits a field needs for `leavesPerAxis` leaves (N / L) along an axis.
HDT_HD int lineFieldBits(uint64_t leavesPerAxis) {
  int b = 0;
  while ((uint64_t(1) << b) < leavesPerAxis) ++b;
  return b;
}

// Words of one bit per leaf row (L * L rows).
HDT_HD constexpr int rowWordsFor(int leafSize) { return leafSize * leafSize / 32; }

// ---- the parity beyond each leaf ---------------------------------------------------
// Along one line, walked from its far end: a leaf's exit parity (of the
// crossings beyond it, per row) is the XOR of the pass-1 parities of the
// leaves after it; `running` carries that XOR (rowWords words, one bit a
// row). Takes the leaf's pass-1 parity in `parity` and leaves its exit parity
// there. Between two leaves of a line there are only uniform elements, which
// hold no triangle, so they add nothing.
HDT_HD void suffixParityStep(uint32_t* parity, uint32_t* running, int rowWords) {
  for (int k = 0; k < rowWords; ++k) {
    const uint32_t inside = parity[k];
    parity[k] = running[k];
    running[k] ^= inside;
  }
}

// ---- pass 2 -------------------------------------------------------------------------
// The exit parity of row r (one bit a row) as a mask over the row's L voxels.
HDT_HD uint32_t exitRowMask(const uint32_t* exitBits, int row, int L) {
  return (exitBits[row >> 5] >> (row & 31)) & 1u ? fullRowMask(L) : 0u;
}

// Pass 2 of one leaf word (16 voxels) from its +x answer: the rows' exit
// parity widened to the word (rowBitsToWordBits) XOR the in-leaf masks pass 1
// left in plane 0; plane 0 := that where the voxel is not surface.
HDT_HD uint32_t classifiedWord(uint32_t word, uint32_t exitBits) {
  return withInsidePlane(word, exitBits ^ planeBits16(word, kInsidePlane));
}
// The same with the exit parity given as plane-0 fields (spreadBits16 of
// exitBits: exitFieldsOfWord): spread(exit ^ planeBits16(word)) is
// spread(exit) ^ plane 0, so no compaction and spreading per word.
HDT_HD constexpr uint32_t classifiedWordFields(uint32_t word, uint32_t exitFields) {
  return (word & kSurfacePlaneBits) | ((word ^ exitFields) & kInsidePlaneBits & ~(word >> 1));
}
// The first row that word w of a leaf of size L holds. The rows of eight
// consecutive words from a multiple of 8 (one 32-byte sector) lie in one
// 32-bit word of row bits: rows w .. w + 7 (L = 16), 2w .. 2w + 15 (L = 8),
// w / 2 .. w / 2 + 3 (L = 32).
HDT_HD constexpr int firstRowOfWord(int L, int w) { return L == 16 ? w : L == 8 ? 2 * w : w >> 1; }
// rowBitsToWordBits as plane-0 fields (spreadBits16 of it), from the word of
// row bits that holds word w's rows (rowBits[firstRowOfWord(L, w) / 32]).
HDT_HD constexpr uint32_t exitFieldsOfWord(uint32_t rowBitsWord, int L, int w) {
  return L == 16 ? ((rowBitsWord >> (w & 31)) & 1u) * kInsidePlaneBits
         : L == 8 ? ((rowBitsWord >> ((2 * w) & 31)) & 1u) * 0x00005555u |
                        ((rowBitsWord >> ((2 * w + 1) & 31)) & 1u) * 0x55550000u
                  : ((rowBitsWord >> ((w >> 1) & 31)) & 1u) * kInsidePlaneBits; // L == 32
}
// Open meshes: the majority of the +x answer and the +y and +z answers (16
// voxel bits each, as x rows: xRowsOfAxisMatrix, wordBitsFromRows).
HDT_HD uint32_t classifiedWord(uint32_t word, uint32_t exitBits, uint32_t yInside, uint32_t zInside) {
  return withInsidePlane(word, majorityOf3(exitBits ^ planeBits16(word, kInsidePlane), yInside, zInside));
}

// ---- uniform elements -------------------------------------------------------------
// A uniform element takes the state of its lowest-corner voxel centre: along
// `axis` that ray's parity is the entry parity (row 0) of the first leaf
// beyond the element on the line of leaves through that corner. The key to
// search for (the first key >= it on the same line is that leaf); false when
// the element ends at the grid's end (nothing beyond: parity 0).
HDT_HD bool uniformLineKey(const LineKeys& keys, uint64_t coord, uint64_t leavesPerElement, uint64_t leavesPerAxis,
                           int axis, uint64_t& key) {
  const uint64_t along = (unpackCoord(coord, axis) + 1) * leavesPerElement;
  if (along >= leavesPerAxis) return false;
  key = keys.key(unpackCoord(coord, rayAxisU(axis)) * leavesPerElement,
                 unpackCoord(coord, rayAxisW(axis)) * leavesPerElement, along);
  return true;
}

// Closed meshes ask one axis (all agree), open ones take the majority of
// the three: the state of a uniform element from its axes' parities.
HDT_HD constexpr int classifiedAxes(bool closedMesh) { return closedMesh ? 1 : 3; }
HDT_HD constexpr bool majorityInside(int oddVotes, int axes) { return 2 * oddVotes > axes; }

} // namespace hdt
