// Kernels of the device combination of a labelled build (label_combine.hpp).
#include "label_combine.hpp"

#include "check.hpp"
#include "device_common.cuh"

#include "hdt/label_field.hpp"

#include <cub/device/device_scan.cuh>

#include <algorithm>

namespace hdt {
namespace cuda {
namespace {

constexpr unsigned kBlock = 256;

__device__ __forceinline__ uint64_t threadIndex() { return uint64_t(blockIdx.x) * blockDim.x + threadIdx.x; }

__device__ __forceinline__ void fail(CombineError e) { atomicOr(e.flag, 1u); }

// The thread of a kernel over `total` items grouped `perLeaf` to a leaf
// (leaf words, or voxels): item j, its leaf and its place in that leaf.
struct LeafItem {
  uint64_t j, leaf, at;
};
__device__ __forceinline__ bool leafItemOfThread(uint64_t total, uint32_t perLeaf, LeafItem& item) {
  item.j = threadIndex();
  if (item.j >= total) return false;
  item.leaf = item.j / perLeaf;
  item.at = item.j % perLeaf;
  return true;
}

__global__ void mapPartLevelKernel(const ElementWord* partWords, const uint64_t* coords, uint32_t partCount, int level,
                                   uint64_t partNextStart, const uint32_t* map, const ElementWord* unionWords,
                                   uint64_t unionStart, uint64_t unionNextStart, uint32_t* nextMap, uint32_t* leafMap,
                                   uint16_t* leafRank, PartOwners owners, uint16_t* fullRank, CombineError e) {
  const uint64_t i = threadIndex();
  if (i >= partCount) return;
  const ElementWord pw = partWords[i];
  const ElementState ps = elementState(pw);
  if (ps == ElementState::Empty) return;
  const uint16_t rank = ownerOfElement(owners, coords[i], level);
  if (rank == kNoRank || (rank == kMixedOwners && ps != ElementState::Branch)) {
    fail(e); // not the parts' own builds (labelled.cpp, partBuilds)
    return;
  }
  const uint32_t u = map ? map[i] : uint32_t(i);
  const ElementWord uw = unionWords[u];
  switch (ps) {
  case ElementState::Full: {
    uint16_t& r = fullRank[unionStart + u];
    r = r < rank ? r : rank;
    break;
  }
  case ElementState::Branch:
    if (elementState(uw) != ElementState::Branch || !nextMap) {
      fail(e);
      return;
    }
    for (uint32_t c = 0; c < 8; ++c)
      nextMap[uint64_t(elementPayload(pw)) - partNextStart + c] = uint32_t(uint64_t(elementPayload(uw)) - unionNextStart + c);
    break;
  case ElementState::Boundary:
    if (elementState(uw) != ElementState::Boundary || !leafMap) {
      fail(e);
      return;
    }
    leafMap[elementPayload(pw)] = elementPayload(uw);
    leafRank[elementPayload(pw)] = rank;
    break;
  default: break;
  }
}

__global__ void orPartLeavesKernel(const uint32_t* partWords, uint64_t total, uint32_t wordsPerLeaf,
                                   const uint32_t* leafMap, const uint16_t* leafRank, uint32_t* acc,
                                   uint32_t* claimCount, uint16_t* claimRank) {
  LeafItem t;
  if (!leafItemOfThread(total, wordsPerLeaf, t)) return;
  const uint64_t j = t.j, w = t.at;
  const uint64_t ul = leafMap[t.leaf];
  acc[ul * wordsPerLeaf + w] |= partWords[j];
  if (w == 0) {
    claimCount[ul] += 1;
    claimRank[ul] = leafRank[t.leaf];
  }
}

__global__ void propagateFullKernel(const ElementWord* words, uint32_t count, uint64_t start, uint16_t* fullRank) {
  const uint64_t i = threadIndex();
  if (i >= count) return;
  const ElementWord w = words[i];
  if (elementState(w) != ElementState::Branch) return;
  const uint16_t parent = fullRank[start + i];
  if (parent == kNoRank) return;
  for (uint32_t c = 0; c < 8; ++c) {
    uint16_t& r = fullRank[uint64_t(elementPayload(w)) + c];
    r = r < parent ? r : parent;
  }
}

__global__ void collectInheritedKernel(const ElementWord* words, uint32_t count, uint64_t start,
                                       const uint16_t* fullRank, uint16_t* leafInherited, uint32_t* claimCount,
                                       uint16_t* claimRank) {
  const uint64_t i = threadIndex();
  if (i >= count) return;
  const ElementWord w = words[i];
  if (elementState(w) != ElementState::Boundary) return;
  const uint32_t leaf = elementPayload(w);
  const uint16_t r = fullRank[start + i];
  leafInherited[leaf] = r;
  if (r != kNoRank) {
    claimCount[leaf] += 1;
    claimRank[leaf] = r;
  }
}

__global__ void finalizeLeafWordsKernel(uint64_t total, uint32_t wordsPerLeaf, const uint32_t* unionSurface,
                                        const uint16_t* leafInherited, uint32_t* acc, CombineError e) {
  const uint64_t j = threadIndex();
  if (j >= total) return;
  const uint32_t a = acc[j];
  const uint32_t surface = planeOf(a, kSurfacePlane);
  if (surface != planeOf(unionSurface[j], kSurfacePlane)) fail(e);
  const uint32_t full = leafInherited[j / wordsPerLeaf] != kNoRank ? kInsidePlaneBits : 0u;
  const uint32_t inside = (planeOf(a, kInsidePlane) | full) & ~surface;
  acc[j] = inside | (surface << 1);
}

__global__ void markMultiKernel(uint32_t leaves, const uint32_t* claimCount, uint32_t* flag) {
  const uint64_t i = threadIndex();
  if (i < leaves) flag[i] = claimCount[i] >= 2 ? 1u : 0u;
}

// The claim's voxels (mine: a word's voxels at even bits, those of the
// claim in the combined state) take the lower of their rank and the claim's.
// A word's 16 ranks are 32 bytes, 32-byte aligned: read and written whole
// (two 16-byte accesses rather than one 2-byte access a voxel), updated in
// registers. Each word belongs to one thread, so nothing else writes them.
__device__ __forceinline__ void claimVoxels(uint32_t mine, uint16_t* ranks, uint16_t rank) {
  static_assert(kVoxelsPerWord == 16, "a word's ranks are two 16-byte vectors");
  if (!mine) return;
  uint4* const at = reinterpret_cast<uint4*>(ranks);
  uint4 v[2] = {at[0], at[1]};
  uint32_t* const pair = reinterpret_cast<uint32_t*>(v); // voxels 2k (low half) and 2k + 1
#pragma unroll
  for (int voxel = 0; voxel < kVoxelsPerWord; ++voxel) {
    if (!((mine >> (2 * voxel)) & 1u)) continue;
    const int shift = 16 * (voxel & 1);
    if (rank < ((pair[voxel / 2] >> shift) & 0xFFFFu))
      pair[voxel / 2] = (pair[voxel / 2] & ~(0xFFFFu << shift)) | (uint32_t(rank) << shift);
  }
  at[0] = v[0];
  at[1] = v[1];
}

__global__ void partVoxelRanksKernel(const uint32_t* partWords, uint64_t total, uint32_t wordsPerLeaf,
                                     const uint32_t* leafMap, const uint16_t* leafRank, const uint32_t* claimCount,
                                     const uint32_t* multiIndex, const uint32_t* combined, uint16_t* voxelRanks) {
  LeafItem t;
  if (!leafItemOfThread(total, wordsPerLeaf, t)) return;
  const uint64_t j = t.j, w = t.at;
  const uint64_t ul = leafMap[t.leaf];
  if (claimCount[ul] < 2) return;
  const uint32_t pw = partWords[j], c = combined[ul * wordsPerLeaf + w];
  const uint32_t mine = (planeOf(pw, kSurfacePlane) & planeOf(c, kSurfacePlane)) |
                        (planeOf(pw, kInsidePlane) & planeOf(c, kInsidePlane));
  claimVoxels(mine, voxelRanks + (uint64_t(multiIndex[ul]) * wordsPerLeaf + w) * kVoxelsPerWord, leafRank[t.leaf]);
}

__global__ void inheritedVoxelRanksKernel(uint64_t total, uint32_t wordsPerLeaf, const uint32_t* claimCount,
                                          const uint32_t* multiIndex, const uint16_t* leafInherited,
                                          const uint32_t* combined, uint16_t* voxelRanks) {
  LeafItem t;
  if (!leafItemOfThread(total, wordsPerLeaf, t)) return;
  const uint64_t j = t.j, ul = t.leaf, w = t.at;
  const uint16_t rank = leafInherited[ul];
  if (claimCount[ul] < 2 || rank == kNoRank) return;
  claimVoxels(planeOf(combined[j], kInsidePlane),
              voxelRanks + (uint64_t(multiIndex[ul]) * wordsPerLeaf + w) * kVoxelsPerWord, rank);
}

// The label of a voxel rank (kNoRank: outside, 0).
__device__ __forceinline__ uint32_t labelOfVoxel(uint16_t rank, const uint16_t* labelOfRank) {
  return rank == kNoRank ? 0u : labelOfRank[rank];
}

// One warp a leaf. Multi-claim leaves: their distinct labels, ascending, one
// warp minimum a label (at most kPaletteSize + 1 rounds), as paletteOfLeaf.
__global__ void leafPalettesKernel(uint32_t leaves, uint32_t voxelsPerLeaf, const uint32_t* claimCount,
                                   const uint16_t* claimRank, const uint32_t* multiIndex, const uint16_t* voxelRanks,
                                   const uint16_t* labelOfRank, uint16_t* leafLabel, LeafPalette* multiPalette,
                                   CombineError e) {
  const uint64_t leaf = threadIndex() / 32;
  const unsigned lane = threadIdx.x % 32;
  if (leaf >= leaves) return; // whole warps leave together (blockDim is a multiple of 32)
  const uint32_t count = claimCount[leaf];
  if (count == 0) {
    if (lane == 0) fail(e);
    return;
  }
  if (count == 1) {
    if (lane == 0) leafLabel[leaf] = labelOfRank[claimRank[leaf]];
    return;
  }
  const uint16_t* ranks = voxelRanks + uint64_t(multiIndex[leaf]) * voxelsPerLeaf;
  LeafPalette palette = {};
  uint32_t distinct = 0, previous = 0;
  while (distinct <= uint32_t(kPaletteSize)) {
    uint32_t next = 0x10000; // the least label above `previous`
    for (uint32_t v = lane; v < voxelsPerLeaf; v += 32) {
      const uint32_t label = labelOfVoxel(ranks[v], labelOfRank);
      next = label > previous && label < next ? label : next;
    }
    for (int o = 16; o > 0; o >>= 1) {
      const uint32_t n = __shfl_xor_sync(kFullMask, next, o);
      next = n < next ? n : next;
    }
    if (next == 0x10000) break;
    if (distinct < uint32_t(kPaletteSize)) palette.labels[distinct] = uint16_t(next);
    ++distinct;
    previous = next;
  }
  if (lane != 0) return;
  leafLabel[leaf] = distinct == 1 ? palette.labels[0] : uint16_t(0);
  multiPalette[multiIndex[leaf]] = distinct > uint32_t(kPaletteSize) ? LeafPalette{} : palette;
}

__global__ void markMixedKernel(uint32_t leaves, const uint32_t* claimCount, const uint16_t* leafLabel,
                                uint32_t* flag) {
  const uint64_t i = threadIndex();
  if (i < leaves) flag[i] = (claimCount[i] >= 2 && leafLabel[i] == 0) ? 1u : 0u;
}

__global__ void multiLeavesKernel(uint32_t leaves, const uint32_t* claimCount, const uint32_t* multiIndex,
                                  uint32_t* multiLeaf) {
  const uint64_t i = threadIndex();
  if (i < leaves && claimCount[i] >= 2) multiLeaf[multiIndex[i]] = uint32_t(i);
}

// Per leaf: 1 for a mixed leaf stored with a palette (paletteFlag) or wide (wideFlag).
__global__ void markMixedFormsKernel(uint32_t multiCount, const uint32_t* multiLeaf, const uint16_t* leafLabel,
                                     const LeafPalette* multiPalette, uint32_t* paletteFlag, uint32_t* wideFlag) {
  const uint64_t m = threadIndex();
  if (m >= multiCount) return;
  const uint32_t leaf = multiLeaf[m];
  const bool mixed = leafLabel[leaf] == 0, wide = multiPalette[m].labels[0] == 0;
  paletteFlag[leaf] = mixed && !wide ? 1u : 0u;
  wideFlag[leaf] = mixed && wide ? 1u : 0u;
}

__global__ void indexMixedKernel(uint32_t leaves, const uint32_t* flag, const uint32_t* mixedIndex,
                                 const uint32_t* wideFlag, const uint32_t* paletteBlock, const uint32_t* wideBlock,
                                 uint32_t* leafMixedIndex, uint32_t* mixedBlock) {
  const uint64_t i = threadIndex();
  if (i >= leaves) return;
  if (!flag[i]) {
    leafMixedIndex[i] = kNotMixed;
    return;
  }
  const uint32_t k = mixedIndex[i];
  leafMixedIndex[i] = k;
  mixedBlock[k] = wideFlag[i] ? wideBlock[i] : paletteBlock[i];
}

__global__ void gatherPalettesKernel(uint32_t multiCount, const uint32_t* multiLeaf, const uint16_t* leafLabel,
                                     const uint32_t* mixedIndex, const LeafPalette* multiPalette, LeafPalette* out) {
  const uint64_t m = threadIndex();
  if (m >= multiCount) return;
  const uint32_t leaf = multiLeaf[m];
  if (leafLabel[leaf] == 0) out[mixedIndex[leaf]] = multiPalette[m];
}

// One thread a word of palette indices (16 voxels), as packPaletteIndices.
__global__ void paletteIndicesKernel(uint64_t total, uint32_t wordsPerLeaf, const uint32_t* multiLeaf,
                                     const uint32_t* paletteFlag, const uint32_t* paletteBlock,
                                     const LeafPalette* multiPalette, const uint16_t* voxelRanks,
                                     const uint16_t* labelOfRank, uint32_t* out) {
  LeafItem t;
  if (!leafItemOfThread(total, wordsPerLeaf, t)) return;
  const uint64_t j = t.j, m = t.leaf, w = t.at;
  const uint32_t leaf = multiLeaf[m];
  if (!paletteFlag[leaf]) return;
  const LeafPalette palette = multiPalette[m];
  const uint16_t* ranks = voxelRanks + j * kVoxelsPerWord;
  uint32_t word = 0;
  for (uint32_t b = 0; b < uint32_t(kVoxelsPerWord); ++b)
    word |= paletteSlotOf(palette.labels, uint16_t(labelOfVoxel(ranks[b], labelOfRank))) << (kPaletteIndexBits * b);
  out[uint64_t(paletteBlock[leaf]) * wordsPerLeaf + w] = word;
}

__global__ void wideLabelsKernel(uint64_t total, uint32_t voxelsPerLeaf, const uint32_t* multiLeaf,
                                 const uint32_t* wideFlag, const uint32_t* wideBlock, const uint16_t* voxelRanks,
                                 const uint16_t* labelOfRank, uint16_t* out) {
  LeafItem t;
  if (!leafItemOfThread(total, voxelsPerLeaf, t)) return;
  const uint64_t j = t.j, m = t.leaf, v = t.at;
  const uint32_t leaf = multiLeaf[m];
  if (!wideFlag[leaf]) return;
  out[uint64_t(wideBlock[leaf]) * voxelsPerLeaf + v] = uint16_t(labelOfVoxel(voxelRanks[j], labelOfRank));
}

__global__ void finalizeElementsKernel(ElementWord* words, uint32_t count, uint64_t start, const uint16_t* fullRank,
                                       const uint16_t* leafLabel, const uint16_t* labelOfRank,
                                       uint16_t* elementLabels) {
  const uint64_t i = threadIndex();
  if (i >= count) return;
  const ElementWord w = words[i];
  const ElementState st = elementState(w);
  uint16_t label = 0;
  if (st == ElementState::Boundary) {
    label = leafLabel[elementPayload(w)];
  } else if (st != ElementState::Branch) {
    const uint16_t r = fullRank[start + i];
    words[i] = makeElement(r == kNoRank ? ElementState::Empty : ElementState::Full, 0);
    label = r == kNoRank ? uint16_t(0) : labelOfRank[r];
  }
  elementLabels[start + i] = label;
}

template <class... Args, class... Params>
void launch(const char* name, cudaStream_t s, uint64_t threads, void (*kernel)(Params...), Args... args) {
  if (threads == 0) return;
  kernel<<<blocksFor(threads, kBlock), kBlock, 0, s>>>(args...);
  HDT_CUDA_CHECK_LAUNCH(name);
}

} // namespace

void mapPartLevel(cudaStream_t s, const ElementWord* partWords, const uint64_t* coords, uint32_t partCount,
                  int level, uint64_t partNextStart, const uint32_t* map, const ElementWord* unionWords,
                  uint64_t unionStart, uint64_t unionNextStart, uint32_t* nextMap, uint32_t* leafMap,
                  uint16_t* leafRank, PartOwners owners, uint16_t* fullRank, CombineError e) {
  launch("mapPartLevel", s, partCount, mapPartLevelKernel, partWords, coords, partCount, level, partNextStart, map,
         unionWords, unionStart, unionNextStart, nextMap, leafMap, leafRank, owners, fullRank, e);
}

void orPartLeaves(cudaStream_t s, const uint32_t* partWords, uint32_t partLeaves, uint32_t wordsPerLeaf,
                  const uint32_t* leafMap, const uint16_t* leafRank, uint32_t* acc, uint32_t* claimCount,
                  uint16_t* claimRank) {
  const uint64_t total = uint64_t(partLeaves) * wordsPerLeaf;
  launch("orPartLeaves", s, total, orPartLeavesKernel, partWords, total, wordsPerLeaf, leafMap, leafRank, acc,
         claimCount, claimRank);
}

void propagateFull(cudaStream_t s, const ElementWord* unionWords, uint32_t count, uint64_t start, uint16_t* fullRank) {
  launch("propagateFull", s, count, propagateFullKernel, unionWords, count, start, fullRank);
}

void collectInherited(cudaStream_t s, const ElementWord* leafLevelWords, uint32_t count, uint64_t start,
                      const uint16_t* fullRank, uint16_t* leafInherited, uint32_t* claimCount, uint16_t* claimRank) {
  launch("collectInherited", s, count, collectInheritedKernel, leafLevelWords, count, start, fullRank, leafInherited,
         claimCount, claimRank);
}

void finalizeLeafWords(cudaStream_t s, uint32_t leaves, uint32_t wordsPerLeaf, const uint32_t* unionSurface,
                       const uint16_t* leafInherited, uint32_t* acc, CombineError e) {
  const uint64_t total = uint64_t(leaves) * wordsPerLeaf;
  launch("finalizeLeafWords", s, total, finalizeLeafWordsKernel, total, wordsPerLeaf, unionSurface, leafInherited,
         acc, e);
}

void markMulti(cudaStream_t s, uint32_t leaves, const uint32_t* claimCount, uint32_t* flag) {
  launch("markMulti", s, leaves, markMultiKernel, leaves, claimCount, flag);
}

void partVoxelRanks(cudaStream_t s, const uint32_t* partWords, uint32_t partLeaves, uint32_t wordsPerLeaf,
                    const uint32_t* leafMap, const uint32_t* claimCount, const uint32_t* multiIndex,
                    const uint32_t* combined, uint16_t* voxelRanks, const uint16_t* leafRank) {
  const uint64_t total = uint64_t(partLeaves) * wordsPerLeaf;
  launch("partVoxelRanks", s, total, partVoxelRanksKernel, partWords, total, wordsPerLeaf, leafMap, leafRank,
         claimCount, multiIndex, combined, voxelRanks);
}

void inheritedVoxelRanks(cudaStream_t s, uint32_t leaves, uint32_t wordsPerLeaf, const uint32_t* claimCount,
                         const uint32_t* multiIndex, const uint16_t* leafInherited, const uint32_t* combined,
                         uint16_t* voxelRanks) {
  const uint64_t total = uint64_t(leaves) * wordsPerLeaf;
  launch("inheritedVoxelRanks", s, total, inheritedVoxelRanksKernel, total, wordsPerLeaf, claimCount, multiIndex,
         leafInherited, combined, voxelRanks);
}

void leafPalettes(cudaStream_t s, uint32_t leaves, uint32_t voxelsPerLeaf, const uint32_t* claimCount,
                  const uint16_t* claimRank, const uint32_t* multiIndex, const uint16_t* voxelRanks,
                  const uint16_t* labelOfRank, uint16_t* leafLabel, LeafPalette* multiPalette, CombineError e) {
  launch("leafPalettes", s, uint64_t(leaves) * 32, leafPalettesKernel, leaves, voxelsPerLeaf, claimCount, claimRank,
         multiIndex, voxelRanks, labelOfRank, leafLabel, multiPalette, e);
}

void markMixed(cudaStream_t s, uint32_t leaves, const uint32_t* claimCount, const uint16_t* leafLabel,
               uint32_t* flag) {
  launch("markMixed", s, leaves, markMixedKernel, leaves, claimCount, leafLabel, flag);
}

void multiLeaves(cudaStream_t s, uint32_t leaves, const uint32_t* claimCount, const uint32_t* multiIndex,
                 uint32_t* multiLeaf) {
  launch("multiLeaves", s, leaves, multiLeavesKernel, leaves, claimCount, multiIndex, multiLeaf);
}

void markMixedForms(cudaStream_t s, uint32_t multiCount, const uint32_t* multiLeaf, const uint16_t* leafLabel,
                    const LeafPalette* multiPalette, uint32_t* paletteFlag, uint32_t* wideFlag) {
  launch("markMixedForms", s, multiCount, markMixedFormsKernel, multiCount, multiLeaf, leafLabel, multiPalette,
         paletteFlag, wideFlag);
}

void indexMixed(cudaStream_t s, uint32_t leaves, const uint32_t* flag, const uint32_t* mixedIndex,
                const uint32_t* wideFlag, const uint32_t* paletteBlock, const uint32_t* wideBlock,
                uint32_t* leafMixedIndex, uint32_t* mixedBlock) {
  launch("indexMixed", s, leaves, indexMixedKernel, leaves, flag, mixedIndex, wideFlag, paletteBlock, wideBlock,
         leafMixedIndex, mixedBlock);
}

void gatherPalettes(cudaStream_t s, uint32_t multiCount, const uint32_t* multiLeaf, const uint16_t* leafLabel,
                    const uint32_t* mixedIndex, const LeafPalette* multiPalette, LeafPalette* out) {
  launch("gatherPalettes", s, multiCount, gatherPalettesKernel, multiCount, multiLeaf, leafLabel, mixedIndex,
         multiPalette, out);
}

void paletteIndices(cudaStream_t s, uint32_t multiCount, uint32_t wordsPerLeaf, const uint32_t* multiLeaf,
                    const uint32_t* paletteFlag, const uint32_t* paletteBlock, const LeafPalette* multiPalette,
                    const uint16_t* voxelRanks, const uint16_t* labelOfRank, uint32_t* out) {
  const uint64_t total = uint64_t(multiCount) * wordsPerLeaf;
  launch("paletteIndices", s, total, paletteIndicesKernel, total, wordsPerLeaf, multiLeaf, paletteFlag, paletteBlock,
         multiPalette, voxelRanks, labelOfRank, out);
}

void wideLabels(cudaStream_t s, uint32_t multiCount, uint32_t voxelsPerLeaf, const uint32_t* multiLeaf,
                const uint32_t* wideFlag, const uint32_t* wideBlock, const uint16_t* voxelRanks,
                const uint16_t* labelOfRank, uint16_t* out) {
  const uint64_t total = uint64_t(multiCount) * voxelsPerLeaf;
  launch("wideLabels", s, total, wideLabelsKernel, total, voxelsPerLeaf, multiLeaf, wideFlag, wideBlock, voxelRanks,
         labelOfRank, out);
}

void finalizeElements(cudaStream_t s, ElementWord* words, uint32_t count, uint64_t start, const uint16_t* fullRank,
                      const uint16_t* leafLabel, const uint16_t* labelOfRank, uint16_t* elementLabels) {
  launch("finalizeElements", s, count, finalizeElementsKernel, words, count, start, fullRank, leafLabel, labelOfRank,
         elementLabels);
}

namespace {
__global__ void flagSumKernel(const uint32_t* index, const uint32_t* flags, uint32_t last, uint64_t* out) {
  *out = uint64_t(index[last]) + flags[last];
}
} // namespace

uint32_t scanFlags(DeviceMemory& mem, uint64_t* pinned, const uint32_t* flags, uint32_t* index, uint32_t n) {
  if (n == 0) return 0;
  runCub(mem, [&](void* temp, size_t& bytes) {
    return cub::DeviceScan::ExclusiveSum(temp, bytes, flags, index, n, mem.stream());
  });
  uint64_t* out = nullptr;
  HDT_CUDA_CHECK(cudaHostGetDevicePointer(reinterpret_cast<void**>(&out), pinned, 0));
  flagSumKernel<<<1, 1, 0, mem.stream()>>>(index, flags, n - 1, out);
  HDT_CUDA_CHECK(cudaGetLastError());
  HDT_CUDA_CHECK(cudaStreamSynchronize(mem.stream()));
  return uint32_t(*static_cast<volatile uint64_t*>(pinned));
}

} // namespace cuda
} // namespace hdt
