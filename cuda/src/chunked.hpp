// Building the root grid in chunks when the whole build does not fit in the
// device memory budget.
//
// Why chunks of root cells work: elements are stored level by level, and
// inside a level in the order of their parents, so the level-k elements of
// the whole tree are the concatenation, in root-cell order, of the level-k
// elements of contiguous root-cell ranges. A chunk is built with chunk-local
// payloads; joining renumbers Branch payloads by the level offsets of the
// chunk and Boundary payloads by its first leaf.
//
// A build runs in two phases: A) per chunk, the tree and, for solid builds,
// the pass-1 parity of its leaves (classification is not chunk-local: rays
// cross chunks); then on the host the line suffix XOR over all leaves (exit
// parity) and the uniform elements; B) per chunk again, the tree (rebuilt:
// cheaper than storing it), the leaf grids (solid: pass 2 with the joined
// exit parity), copied straight to their place in the volume, which is so
// the only host copy of the leaf grids.
// Phase A reserves the room phase B will need, so a chunk that passed A fits
// in B. A chunk that does not fit is split in two; a single root cell that
// does not fit ends the build with Error(OutOfResources).
#pragma once

#include "session.hpp"

#include "hdt/cuda_build.hpp"
#include "hdt/volume.hpp"

#include <cstdint>

namespace hdt {
namespace cuda {

// Device bytes a build (or a chunk) is expected to need, from the surface
// area (voxel^2) and the number of (root cell, triangle) pairs it covers.
// A deliberate over-estimate: the driver chunks rather than fails.
uint64_t estimateBytes(const PreparedMesh& mesh, double area, uint64_t rootPairs, uint64_t rootCells);
// Bytes every piece needs regardless of chunking: triangles and T1 arrays.
uint64_t fixedBytes(const PreparedMesh& mesh);

Volume buildChunked(Session& s, CudaBuildReport& report);

} // namespace cuda
} // namespace hdt
