// Fixed-point lattice on which all geometric predicates are exact.
//
// Vertices are snapped once, on the host, to 1/256 of a voxel. With the
// effective resolution capped at 65536 every lattice coordinate is below 2^24,
// so edge vectors stay below 2^25, 2D orientations below 2^51 and the plane
// test needs one 128-bit product. The CPU and CUDA drivers therefore evaluate
// the same integers and cannot disagree, and ties (a face lying exactly on a
// voxel plane, a ray through a vertex) are decided by rule, not by rounding.
#pragma once

#include "hdt/platform.hpp"

#include <cstdint>

namespace hdt {

constexpr int kLatticeBits = 8;
constexpr int64_t kLatticePerVoxel = int64_t(1) << kLatticeBits;
constexpr int kMaxResolution = 65536;

// A triangle with its vertices on the lattice (voxel units * 256).
struct LatticeTriangle {
  int32_t v[3][3];
};

// Voxel index -> lattice coordinate of the voxel's low corner / centre.
HDT_HD constexpr int64_t latticeOfVoxel(int64_t voxel) { return voxel * kLatticePerVoxel; }
HDT_HD constexpr int64_t latticeOfVoxelCentre(int64_t voxel) {
  return voxel * kLatticePerVoxel + kLatticePerVoxel / 2;
}

} // namespace hdt
