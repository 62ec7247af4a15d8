// Splits of the root grid into ranges for the range-build tests of both
// drivers (tests/test_root_ranges.cpp, tests/cuda/test_cuda_ranges.cpp), so
// the CPU and CUDA range builds are checked on the same splits.
#pragma once

#include "hdt/root_ranges.hpp"

#include <cstdint>
#include <string>
#include <vector>

namespace hdt {
namespace test {

// "[a,b)[b,c)...": for failure messages.
std::string describeRanges(const std::vector<RootRange>& ranges);

// [0, cells) split at the given cuts (equal cuts make empty ranges).
std::vector<RootRange> cutAt(const std::vector<uint64_t>& cuts, uint64_t cells);

// The splits every range-build test runs: 1-5 ranges balanced by T1 pairs
// (any cell, and whole rows along x), more ranges than rows (some empty),
// uneven cuts whose edge ranges hold no triangles, empty ranges at both ends
// and inside, and a cut inside a row of cells.
std::vector<std::vector<RootRange>> rangeSplitsOf(const PreparedMesh& mesh);

} // namespace test
} // namespace hdt
