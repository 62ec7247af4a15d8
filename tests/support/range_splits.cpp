#include "support/range_splits.hpp"

#include "hdt/builder.hpp"

namespace hdt {
namespace test {

std::string describeRanges(const std::vector<RootRange>& ranges) {
  std::string s;
  for (const RootRange& r : ranges) s += "[" + std::to_string(r.first) + "," + std::to_string(r.end) + ")";
  return s;
}

std::vector<RootRange> cutAt(const std::vector<uint64_t>& cuts, uint64_t cells) {
  std::vector<RootRange> out;
  uint64_t start = 0;
  for (uint64_t c : cuts) {
    out.push_back(RootRange{start, c});
    start = c;
  }
  out.push_back(RootRange{start, cells});
  return out;
}

std::vector<std::vector<RootRange>> rangeSplitsOf(const PreparedMesh& mesh) {
  const uint64_t R = uint64_t(mesh.grid.rootGrid), cells = R * R * R;
  const std::vector<CellLoad> loads = cellLoads(mesh);
  std::vector<std::vector<RootRange>> splits;
  for (int k = 1; k <= 5; ++k) {
    splits.push_back(planRootRanges(loads, cells, k));
    splits.push_back(planRootRanges(loads, cells, k, R));
  }
  splits.push_back(planRootRanges(loads, cells, int(R * R) + 3, R));
  splits.push_back(cutAt({1, 2, cells - 1}, cells));
  splits.push_back(cutAt({0, cells / 3, cells / 3, cells}, cells));
  splits.push_back(cutAt({cells / 2 + 1}, cells));
  return splits;
}

} // namespace test
} // namespace hdt
