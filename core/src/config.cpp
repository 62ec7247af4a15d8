#include "hdt/config.hpp"

#include "hdt/error.hpp"
#include "hdt/lattice.hpp"

#include <algorithm>
#include <cmath>
#include <sstream>

namespace hdt {

std::vector<int> nearestValidResolutions(int n, int rootGrid, int leafSize) {
  std::vector<int> valid;
  if (rootGrid < 1 || leafSize < 1) return valid;
  for (int64_t v = int64_t(rootGrid) * leafSize; v <= kMaxResolution; v *= 2) valid.push_back(int(v));
  if (valid.empty()) return valid;
  auto above = std::lower_bound(valid.begin(), valid.end(), n);
  std::vector<int> nearest;
  if (above != valid.begin()) nearest.push_back(*(above - 1));
  if (above != valid.end()) nearest.push_back(*above);
  return nearest;
}

int validateConfig(const BuildConfig& c) {
  if (c.leafSize != 8 && c.leafSize != 16 && c.leafSize != 32) {
    throw Error(ErrorKind::InvalidArgument,
                "leaf grid size must be 8, 16 or 32 (got " + std::to_string(c.leafSize) + ")");
  }
  if (c.rootGrid < 1 || int64_t(c.rootGrid) * c.leafSize > kMaxResolution) {
    throw Error(ErrorKind::InvalidArgument,
                "root grid size must be at least 1 and R * L at most " +
                    std::to_string(kMaxResolution) + " (got R = " + std::to_string(c.rootGrid) + ")");
  }
  const int64_t base = int64_t(c.rootGrid) * c.leafSize;
  const int64_t n = c.resolution;
  int height = -1;
  if (n >= base && n <= kMaxResolution && n % base == 0) {
    const int64_t q = n / base;
    if ((q & (q - 1)) == 0) {
      height = 0;
      while ((int64_t(1) << height) < q) ++height;
    }
  }
  if (height < 0) {
    std::ostringstream msg;
    msg << "resolution " << c.resolution << " is not of the form R * 2^h * L with R = " << c.rootGrid
        << ", L = " << c.leafSize << " and at most " << kMaxResolution;
    const std::vector<int> nearest = nearestValidResolutions(c.resolution, c.rootGrid, c.leafSize);
    if (!nearest.empty()) {
      msg << "; nearest valid: ";
      for (size_t i = 0; i < nearest.size(); ++i) msg << (i ? " or " : "") << nearest[i];
    }
    throw Error(ErrorKind::InvalidArgument, msg.str());
  }
  return height;
}

GridSpec placeGrid(const BuildConfig& config, const std::array<double, 3>& lo,
                   const std::array<double, 3>& hi) {
  GridSpec g;
  g.height = validateConfig(config);
  g.resolution = config.resolution;
  g.rootGrid = config.rootGrid;
  g.leafSize = config.leafSize;
  double extent = 0;
  for (int a = 0; a < 3; ++a) {
    if (!std::isfinite(lo[a]) || !std::isfinite(hi[a]) || hi[a] < lo[a]) {
      throw Error(ErrorKind::BadInput, "bounds are not finite or are inverted");
    }
    extent = std::max(extent, hi[a] - lo[a]);
  }
  if (!std::isfinite(extent)) {
    // Finite coordinates can still be too far apart: +-1e308 overflow to inf.
    throw Error(ErrorKind::BadInput, "the mesh's extent overflows double precision (coordinates near "
                                     "+-1.8e308 are too far apart); scale the mesh down");
  }
  if (!(extent > 0)) {
    throw Error(ErrorKind::BadInput, "the mesh has zero extent (all points coincide)");
  }
  // Two voxels of the N are margin, so the closed boxes that touch the
  // surface never leave the grid.
  g.voxelSize = extent / double(g.resolution - 2);
  for (int a = 0; a < 3; ++a) {
    // (lo + hi) / 2 as always (same bytes as before), or lo + (hi - lo) / 2
    // where the sum of two large coordinates overflows.
    double centre = 0.5 * (lo[a] + hi[a]);
    if (!std::isfinite(centre)) centre = lo[a] + 0.5 * (hi[a] - lo[a]);
    g.origin[a] = centre - 0.5 * double(g.resolution) * g.voxelSize;
  }
  const double latticeScale = double(kLatticePerVoxel) / g.voxelSize;
  bool representable = g.voxelSize > 0 && std::isfinite(latticeScale);
  for (int a = 0; a < 3; ++a)
    representable = representable && std::isfinite(g.origin[a] + double(g.resolution) * g.voxelSize);
  if (!representable) {
    throw Error(ErrorKind::BadInput, "the grid around the mesh is not representable in double precision "
                                     "(coordinates near +-1.8e308 or an extent near 1e-308); rescale the mesh");
  }
  return g;
}

} // namespace hdt
