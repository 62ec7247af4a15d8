// Building the root grid, or one range of it, in chunks when the whole build
// does not fit in the device memory budget: the chunks are root ranges (core's root_ranges.hpp:
// plan, lines and boundary parities, uniform elements, join); this file only
// schedules them on the device.
//
// A build runs in two phases: A) per chunk on the device, the tree and, for
// solid builds, the pass-1 parity of its leaves; then on the host, per chunk, the lines'
// exit parity stitched with the parity beyond the chunk, and the uniform
// elements; B) per chunk again, the tree (rebuilt: cheaper than storing it),
// the leaf grids (solid: pass 2 with that exit parity), copied straight to
// their place in the volume, which is so the only host copy of the leaf grids.
// Phase A reserves the room phase B will need, so a chunk that passed A fits
// in B. A chunk that does not fit is split in two; a single root cell that
// does not fit ends the build with Error(OutOfResources).
#pragma once

#include "session.hpp"

#include "pipeline.hpp"

#include "hdt/cuda_build.hpp"
#include "hdt/root_ranges.hpp"
#include "hdt/volume.hpp"

#include <cstdint>
#include <vector>

namespace hdt {
namespace cuda {

// Device bytes a build (or a chunk) is expected to need, from the surface
// area (voxel^2) and the number of (root cell, triangle) pairs it covers.
// A deliberate over-estimate: the driver chunks rather than fails.
uint64_t estimateBytes(const PreparedMesh& mesh, double area, uint64_t rootPairs, uint64_t rootCells);
// Bytes every piece needs regardless of chunking: triangles and T1 arrays.
uint64_t fixedBytes(const PreparedMesh& mesh);

// A range of root cells built chunk by chunk in the two stages of
// root_ranges.hpp: the whole grid for buildChunked, one range for a range
// build (makeCudaRangeBuild, range_build.cpp). The session's triangles must
// be on the device.
class ChunkedRange {
public:
  ChunkedRange(Session& s, RootRange cells) : s_(s), cells_(cells) {}

  // Stage 1: phase A over the range's chunks; for solid builds the lines of
  // their leaves and the range's boundary parities (the XOR of the chunks').
  const RangeBoundary& buildTree();
  // Stage 2: the chunks' lines stitched with the parity beyond each chunk
  // (the later chunks' and `beyond`, the parity beyond the range; null:
  // nothing), their uniform elements, phase B. Returns the chunks' pieces;
  // their leaves, in order, are in `leafWords`.
  std::vector<RangeTree> finish(const RangeBoundary* beyond, LeafWordVector& leafWords);

  int chunks() const { return chunks_; } // pieces phase B ran in
  double hostMs() const { return hostMs_; } // host classification (lines, uniform elements)

private:
  void planAndBuildTrees();

  Session& s_;
  RootRange cells_;
  std::vector<RootRange> done_;                // the chunks, in root-cell order
  std::vector<ChunkTree> trees_;               // their phase-A results (parities)
  std::vector<RangeTree> pieces_;              // their trees
  std::vector<std::vector<RangeLines>> lines_; // solid: per chunk and axis
  std::vector<RangeBoundary> chunkBoundary_;
  RangeBoundary boundary_;
  int chunks_ = 0;
  double hostMs_ = 0;
};

Volume buildChunked(Session& s, CudaBuildReport& report);

} // namespace cuda
} // namespace hdt
