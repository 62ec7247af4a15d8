// The HDT (hybrid dynamic tree) data structure of Hossain et al., IA^3 2015.
//
//   root grid  R^3 elements, x fastest
//   octree     every Branch element owns 8 contiguous children in Morton order
//              (child bit 0 = +x half, bit 1 = +y half, bit 2 = +z half)
//   leaf grid  every Boundary element owns one L^3 grid of 2-bit voxel states
//
// Elements are stored level by level (breadth first): level 0 is the root grid,
// level k+1 holds the children of the Branch elements of level k in the order of
// their parents. That order is canonical (it depends on nothing but the mesh
// and the configuration), it is the order a level-synchronous GPU build produces,
// and it is the breadth-first order vtkHyperTree descriptors want.
#pragma once

#include "hdt/platform.hpp"

#include <cstdint>

namespace hdt {

enum class ElementState : uint8_t {
  Empty = 0,    // uniform, outside the solid (or: surface-only build)
  Full = 1,     // uniform, inside the solid
  Branch = 2,   // payload: index of the first of 8 contiguous children
  Boundary = 3, // payload: index of the leaf grid
};

enum class VoxelState : uint8_t {
  Outside = 0,
  Inside = 1,
  Surface = 2,
};

// One element is one 32-bit word: state in the low 2 bits, payload above.
// (The paper's element is 20 bytes; statistics report both accountings.)
using ElementWord = uint32_t;
constexpr uint32_t kMaxElementPayload = (1u << 30) - 1;

HDT_HD constexpr ElementWord makeElement(ElementState s, uint32_t payload) {
  return (payload << 2) | static_cast<uint32_t>(s);
}
HDT_HD constexpr ElementState elementState(ElementWord w) {
  return static_cast<ElementState>(w & 3u);
}
HDT_HD constexpr uint32_t elementPayload(ElementWord w) { return w >> 2; }

// ---- the leaf grid: L^3 voxels of 2 bits ------------------------------------
// Voxel (x, y, z) of an L^3 leaf is linear index v = x + L * (y + L * z); it
// lives in 32-bit word v / 16 at bits 2 * (v % 16). A 16^3 leaf is 256 words
// = 1024 bytes, a row of 16 voxels one word. The two bits of a voxel are two
// planes: plane 0 (the even bits of a word) is "inside", plane 1 (the odd
// bits) is "surface"; both set never happens (the invalid state 3). The
// VoxelState values are the planes' bits, so a field reads as its state.
constexpr int kVoxelsPerWord = 16;
enum LeafPlane : int {
  kInsidePlane = 0,  // plane 0: inside the solid (classification)
  kSurfacePlane = 1, // plane 1: meets a triangle (T3)
};
constexpr uint32_t kInsidePlaneBits = 0x55555555u;  // plane 0 of all 16 fields
constexpr uint32_t kSurfacePlaneBits = 0xAAAAAAAAu; // plane 1 of all 16 fields
static_assert(kVoxelsPerWord * 2 == 32, "16 two-bit voxels fill a 32-bit word");
static_assert(uint32_t(VoxelState::Inside) == 1u << kInsidePlane, "Inside is plane 0");
static_assert(uint32_t(VoxelState::Surface) == 1u << kSurfacePlane, "Surface is plane 1");
static_assert((kInsidePlaneBits << 1) == kSurfacePlaneBits && (kInsidePlaneBits | kSurfacePlaneBits) == ~0u,
              "the two planes interleave");

HDT_HD constexpr uint32_t leafWordCount(int leafSize) {
  return static_cast<uint32_t>(leafSize) * leafSize * leafSize / kVoxelsPerWord;
}
static_assert(leafWordCount(8) == 32 && leafWordCount(16) == 256 && leafWordCount(32) == 2048,
              "L^3 / 16 words a leaf");

// Bit count without a library call: baseline x86-64 has no POPCNT
// instruction, and GCC's fallback is a function call per word.
HDT_HD constexpr uint32_t popcount32(uint32_t x) {
  x = x - ((x >> 1) & 0x55555555u);
  x = (x & 0x33333333u) + ((x >> 2) & 0x33333333u);
  x = (x + (x >> 4)) & 0x0F0F0F0Fu;
  return (x * 0x01010101u) >> 24;
}

// One plane of a leaf word, at the even bit positions (one bit per field).
HDT_HD constexpr uint32_t planeOf(uint32_t word, LeafPlane plane) { return (word >> plane) & kInsidePlaneBits; }
// Voxels of a word in that plane.
HDT_HD constexpr uint32_t planeCount(uint32_t word, LeafPlane plane) { return popcount32(planeOf(word, plane)); }
// Fields of a word in the invalid state 3 (both planes set), at even positions.
HDT_HD constexpr uint32_t invalidFields(uint32_t word) { return word & (word >> 1) & kInsidePlaneBits; }

// One leaf grid's words (Volume::leaf, a driver's output buffer).
struct LeafView {
  const uint32_t* words;
  int size; // L
  HDT_HD uint32_t wordCount() const { return leafWordCount(size); }
  HDT_HD VoxelState voxel(int x, int y, int z) const {
    const uint32_t v = static_cast<uint32_t>(x + size * (y + size * z));
    return static_cast<VoxelState>((words[v / kVoxelsPerWord] >> (2 * (v % kVoxelsPerWord))) & 3u);
  }
};

// Where leaf `leaf` starts in a driver's array of leaf words. An integer, so
// that kernels can add it to their own pointer: the T3 kernel's stores
// compiled to slower code through the pointer-returning form (leafWordsAt;
// bench/results/gpu-notes.md, "Refactor speed check").
HDT_HD constexpr uint64_t leafWordOffset(uint64_t leaf, int leafSize) { return leaf * leafWordCount(leafSize); }

// Leaf `leaf` of a driver's array of leaf words.
HDT_HD uint32_t* leafWordsAt(uint32_t* all, uint64_t leaf, int leafSize) { return all + leafWordOffset(leaf, leafSize); }

HDT_HD VoxelState leafVoxel(const uint32_t* leafWords, int leafSize, int x, int y, int z) {
  return LeafView{leafWords, leafSize}.voxel(x, y, z);
}

// Spreads the low 16 bits of m so that bit i moves to bit 2*i: turns a row
// mask of 16 voxels into the "bit 0 of each 2-bit state" plane of one word.
HDT_HD constexpr uint32_t spreadBits16(uint32_t m) {
  m &= 0xFFFFu;
  m = (m | (m << 8)) & 0x00FF00FFu;
  m = (m | (m << 4)) & 0x0F0F0F0Fu;
  m = (m | (m << 2)) & 0x33333333u;
  m = (m | (m << 1)) & kInsidePlaneBits;
  return m;
}

} // namespace hdt
