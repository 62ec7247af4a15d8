// The combination of a labelled build's parts on the device (labelled.cpp
// schedules it): the same function as combineLabelledParts (labels.cpp) of
// the parts' trees and leaf words, computed into the tree of the whole mesh
// (the union of the parts' trees: an element is refined where a triangle
// meets it, whatever its part).
//
// Parts are numbered by rank, the overlap policy's order (rank 0 wins);
// kNoRank: no claim. A part build is one part, or several whose root cells
// are disjoint (labelled.cpp), so that every kernel of one part build
// touches each of its union elements, leaves or voxels from one thread; part
// builds run one after another on one stream, so the per-element minima
// need no atomics.
#pragma once

#include "device_memory.hpp"

#include "hdt/build_steps.hpp" // unpackCoord
#include "hdt/label_field.hpp"
#include "hdt/types.hpp"

#include <cuda_runtime.h>

#include <cstdint>

namespace hdt {
namespace cuda {

constexpr uint16_t kNoRank = 0xFFFF;
constexpr uint16_t kMixedOwners = 0xFFFE; // an element of a shared build that spans several parts' cells

// One part of a shared build: its rank and its cells (inclusive, per axis)
// at the build's ownership level, those its triangles can meet.
struct PartCells {
  int32_t first[3], last[3];
  uint16_t rank;
};

// Whose an element of a part build is: with count == 0 (a one-part build),
// `rank`'s everywhere; otherwise parts[0, count) on device, their cells
// disjoint.
struct PartOwners {
  const PartCells* parts = nullptr;
  uint32_t count = 0;
  int level = 0; // the ownership level
  uint16_t rank = kNoRank;
};

// The rank of the element at `cell` (packed coordinates) of `level`: a
// part's where all its cells of the ownership level are that part's,
// kMixedOwners where it spans a part's cells and others, kNoRank where it
// meets no part's cells.
HDT_HD uint16_t ownerOfElement(const PartOwners& o, uint64_t cell, int level) {
  if (o.count == 0) return o.rank;
  int64_t lo[3], hi[3];
  for (int a = 0; a < 3; ++a) {
    const int64_t c = unpackCoord(cell, a);
    if (level >= o.level) {
      lo[a] = hi[a] = c >> (level - o.level);
    } else {
      lo[a] = c << (o.level - level);
      hi[a] = lo[a] + (int64_t(1) << (o.level - level)) - 1;
    }
  }
  for (uint32_t p = 0; p < o.count; ++p) {
    const PartCells& q = o.parts[p];
    bool meets = true, inside = true;
    for (int a = 0; a < 3; ++a) {
      meets = meets && lo[a] <= q.last[a] && q.first[a] <= hi[a];
      inside = inside && q.first[a] <= lo[a] && hi[a] <= q.last[a];
    }
    if (inside) return q.rank;
    if (meets) return kMixedOwners;
  }
  return kNoRank;
}

// Any inconsistency between a part's tree and the union's (a part refined
// where the union is not, a part surface voxel the union lacks) sets
// *error; the host then rejects the device result.
struct CombineError {
  uint32_t* flag;
};

// One level of a part build's tree against the union's. map: the union
// index (level-local) of each part element of this level (null at level 0:
// the same root cells). Each element takes its owner's rank (coords: the
// level's packed cell coordinates); in a shared build an element but Empty
// that meets no part's cells, or that spans several and is not a Branch,
// sets *error. Writes the next level's map (Branch children) or, at the leaf
// level, leafMap (part leaf -> union leaf) and leafRank; records Full
// elements in fullRank (union global indices).
void mapPartLevel(cudaStream_t s, const ElementWord* partWords, const uint64_t* coords, uint32_t partCount,
                  int level, uint64_t partNextStart, const uint32_t* map, const ElementWord* unionWords,
                  uint64_t unionStart, uint64_t unionNextStart, uint32_t* nextMap, uint32_t* leafMap,
                  uint16_t* leafRank, PartOwners owners, uint16_t* fullRank, CombineError e);

// ORs a part build's leaf words into acc (union leaves) and counts each
// leaf's claim, of rank leafRank[leaf].
void orPartLeaves(cudaStream_t s, const uint32_t* partWords, uint32_t partLeaves, uint32_t wordsPerLeaf,
                  const uint32_t* leafMap, const uint16_t* leafRank, uint32_t* acc, uint32_t* claimCount,
                  uint16_t* claimRank);

// Full claims inherited from Full ancestors, one union level at a time (top down).
void propagateFull(cudaStream_t s, const ElementWord* unionWords, uint32_t count, uint64_t start, uint16_t* fullRank);

// Leaf level of the union: per union leaf, the inherited Full claim (counted
// as a claim) in leafInherited.
void collectInherited(cudaStream_t s, const ElementWord* leafLevelWords, uint32_t count, uint64_t start,
                      const uint16_t* fullRank, uint16_t* leafInherited, uint32_t* claimCount, uint16_t* claimRank);

// The combined leaf words, in place in acc: inside (the parts' and inherited
// Full) where not surface. Checks that the parts' surface is the union's.
void finalizeLeafWords(cudaStream_t s, uint32_t leaves, uint32_t wordsPerLeaf, const uint32_t* unionSurface,
                       const uint16_t* leafInherited, uint32_t* acc, CombineError e);

// 1 for leaves of two claims or more (their voxels need a rank each).
void markMulti(cudaStream_t s, uint32_t leaves, const uint32_t* claimCount, uint32_t* flag);

// The voxel ranks of multi-claim leaves: per voxel the best rank of the
// claims in its combined state. multiIndex: exclusive scan of markMulti.
void partVoxelRanks(cudaStream_t s, const uint32_t* partWords, uint32_t partLeaves, uint32_t wordsPerLeaf,
                    const uint32_t* leafMap, const uint32_t* claimCount, const uint32_t* multiIndex,
                    const uint32_t* combined, uint16_t* voxelRanks, const uint16_t* leafRank);
void inheritedVoxelRanks(cudaStream_t s, uint32_t leaves, uint32_t wordsPerLeaf, const uint32_t* claimCount,
                         const uint32_t* multiIndex, const uint16_t* leafInherited, const uint32_t* combined,
                         uint16_t* voxelRanks);

// Per union leaf its label: the one claim's, or, for multi-claim leaves, the
// one label of its voxels (0: mixed, as combineLeafLabels); per multi-claim
// leaf (multiIndex order) its palette, as paletteOfLeaf.
void leafPalettes(cudaStream_t s, uint32_t leaves, uint32_t voxelsPerLeaf, const uint32_t* claimCount,
                  const uint16_t* claimRank, const uint32_t* multiIndex, const uint16_t* voxelRanks,
                  const uint16_t* labelOfRank, uint16_t* leafLabel, LeafPalette* multiPalette, CombineError e);
// 1 for mixed leaves (multi-claim, label 0).
void markMixed(cudaStream_t s, uint32_t leaves, const uint32_t* claimCount, const uint16_t* leafLabel,
               uint32_t* flag);

// multiLeaf[multiIndex[i]] = i for the multi-claim leaves i.
void multiLeaves(cudaStream_t s, uint32_t leaves, const uint32_t* claimCount, const uint32_t* multiIndex,
                 uint32_t* multiLeaf);

// Per leaf (indexed by union leaf, written for multi-claim ones): 1 for a
// mixed palette leaf in paletteFlag, for a mixed wide leaf in wideFlag.
void markMixedForms(cudaStream_t s, uint32_t multiCount, const uint32_t* multiLeaf, const uint16_t* leafLabel,
                    const LeafPalette* multiPalette, uint32_t* paletteFlag, uint32_t* wideFlag);
// The mixed leaves' palettes in leaf order (mixedIndex: exclusive scan of markMixed).
void gatherPalettes(cudaStream_t s, uint32_t multiCount, const uint32_t* multiLeaf, const uint16_t* leafLabel,
                    const uint32_t* mixedIndex, const LeafPalette* multiPalette, LeafPalette* out);
// The palette leaves' 2-bit indices (block: exclusive scan of paletteFlag),
// and the wide leaves' labels (block: exclusive scan of wideFlag), from the
// ranks of the multiCount multi-claim leaves: LabelField's layout.
void paletteIndices(cudaStream_t s, uint32_t multiCount, uint32_t wordsPerLeaf, const uint32_t* multiLeaf,
                    const uint32_t* paletteFlag, const uint32_t* paletteBlock, const LeafPalette* multiPalette,
                    const uint16_t* voxelRanks, const uint16_t* labelOfRank, uint32_t* out);
void wideLabels(cudaStream_t s, uint32_t multiCount, uint32_t voxelsPerLeaf, const uint32_t* multiLeaf,
                const uint32_t* wideFlag, const uint32_t* wideBlock, const uint16_t* voxelRanks,
                const uint16_t* labelOfRank, uint16_t* out);
// LabelField::mixedIndex (per leaf: its number among the mixed leaves,
// kNotMixed for the others) and ::mixedBlock (per mixed leaf: its block among
// the palette leaves or the wide leaves), as indexMixedLeaves makes them.
// flag: markMixed's, mixedIndex its exclusive scan; the blocks: scans of the
// forms' flags.
void indexMixed(cudaStream_t s, uint32_t leaves, const uint32_t* flag, const uint32_t* mixedIndex,
                const uint32_t* wideFlag, const uint32_t* paletteBlock, const uint32_t* wideBlock,
                uint32_t* leafMixedIndex, uint32_t* mixedBlock);
// One union level's final words (uniform elements: Full where a part claims
// them) and element labels, in place.
void finalizeElements(cudaStream_t s, ElementWord* words, uint32_t count, uint64_t start, const uint16_t* fullRank,
                      const uint16_t* leafLabel, const uint16_t* labelOfRank, uint16_t* elementLabels);

// Exclusive scan of n 0/1 flags into index; returns their sum (waits for it).
// A kernel writes the sum into `pinned` (pinned host memory, HostScalars::host)
// rather than a copy: a copy to the host would queue behind the leaf words'
// copy back that runs beside these kernels (bench/results/labels-gpu.md).
uint32_t scanFlags(DeviceMemory& mem, uint64_t* pinned, const uint32_t* flags, uint32_t* index, uint32_t n);

} // namespace cuda
} // namespace hdt
