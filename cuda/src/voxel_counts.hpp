// The volume's surface and inside voxel counts for its statistics, counted on
// the device before the copy back, so the host need not read every leaf word
// again (computeStructureStatistics in core/src/volume.cpp is the reference).
#pragma once

#include "device_memory.hpp"

#include "hdt/types.hpp"

#include <cuda_runtime.h>

#include <cstdint>

namespace hdt {
namespace cuda {

// Adds into counts[1] (inside) the voxels of a level's Full elements
// (voxelsPerElement each, the words final).
void countFullVoxels(cudaStream_t s, const ElementWord* words, uint32_t count, uint64_t voxelsPerElement,
                     unsigned long long* counts);

// Adds into counts[0] (surface) and counts[1] (inside) the voxels of the
// final leaf words.
void countLeafVoxels(cudaStream_t s, const uint32_t* words, uint64_t total, unsigned long long* counts);

} // namespace cuda
} // namespace hdt
