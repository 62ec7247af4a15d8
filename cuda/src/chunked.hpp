// Building the root grid in chunks when the whole build does not fit in the
// device memory budget: the chunks are root ranges (core's root_ranges.hpp:
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
