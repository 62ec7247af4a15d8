// Build configuration and grid placement.
//
// Effective resolution N = R * 2^h * L along the longest side of the mesh:
// R root cells per axis, an octree of height h under each, and L^3 leaf grids.
// The voxel size is s = longest extent / (N - 2) and the mesh is centred in
// the N^3 cube, so there is at least one voxel of empty margin on every side.
#pragma once

#include <array>
#include <cstdint>
#include <string>
#include <vector>

namespace hdt {

// How inside voxels are told from outside ones (solid builds).
//   Parity: ray parity along +x for closed meshes, the majority of the +x, +y
//           and +z parities for open ones (the paper's rule).
//   WindingNumber: the generalized winding number at the voxel centre is at
//           least 1/2 (Jacobson et al. 2013), for any mesh.
//   Auto (the default): Parity for closed meshes, WindingNumber for open ones.
// A built Volume records the test that ran (never Auto).
enum class InsideTest : uint8_t { Auto = 0, Parity = 1, WindingNumber = 2 };

struct BuildConfig {
  int resolution = 1024; // N, effective voxels along the longest side
  int rootGrid = 16;     // R
  int leafSize = 16;     // L: 8, 16 or 32
  bool surfaceOnly = false;
  InsideTest insideTest = InsideTest::Auto;
  // Optional explicit placement box; when set the grid covers this box
  // instead of the mesh's bounding box (same centring and margin rule).
  bool hasBounds = false;
  std::array<double, 3> boundsMin{0, 0, 0};
  std::array<double, 3> boundsMax{0, 0, 0};
};

// Where the N^3 grid lies in space and how it is divided.
struct GridSpec {
  int resolution = 0;
  int rootGrid = 0;
  int leafSize = 0;
  int height = 0;                   // octree levels below the root grid
  std::array<double, 3> origin{};   // low corner of voxel (0, 0, 0)
  double voxelSize = 0;

  int rootCellVoxels() const { return resolution / rootGrid; }
  // Edge length in voxels of an element at octree level k (0 = root grid).
  int elementVoxels(int level) const { return rootCellVoxels() >> level; }
  uint32_t leafVoxels() const { return uint32_t(leafSize) * uint32_t(leafSize) * uint32_t(leafSize); }
  int cellsPerAxis(int level) const { return rootGrid << level; }
};

// Checks R, L and N; returns the height on success. Throws Error
// (InvalidArgument) naming the nearest valid resolutions otherwise.
int validateConfig(const BuildConfig& config);

// The valid resolutions R * 2^h * L (h >= 0, N <= kMaxResolution) nearest to n.
std::vector<int> nearestValidResolutions(int n, int rootGrid, int leafSize);

// Places the grid around the box [lo, hi] (the mesh bounds, or the explicit ones).
GridSpec placeGrid(const BuildConfig& config, const std::array<double, 3>& lo,
                   const std::array<double, 3>& hi);

} // namespace hdt
