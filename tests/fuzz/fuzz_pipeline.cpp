// libFuzzer harness: read-prepare-build at N = 32 or 64 on small arbitrary
// meshes, checked voxel by voxel against the tests' brute-force references
// (the comparisons the unit tests run): the parity voxelizer
// (tests/support/reference_voxelizer.hpp) or, for solid builds with byte 0's
// bit 5 set, the winding number summed over every triangle at every voxel
// centre (tests/support/winding_reference.hpp; voxels within 1e-9 of the 1/2
// threshold are left unjudged: the reference's own rounding), and through a
// .hdt round trip.
//
// Input: byte 0 picks R, L, N, surface-only and the inside test; byte 1 the number of points
// (3..34); then 3 signed bytes a point; then index triples (mod the point
// count), at most 64 triangles.
#include "hdt/builder.hpp"
#include "hdt/error.hpp"
#include "hdt/hdt_file.hpp"
#include "hdt/mesh.hpp"
#include "support/reference_voxelizer.hpp"
#include "support/winding_reference.hpp"

#include <cstdint>
#include <cstdio>
#include <cstdlib>

namespace {

// The tests' comparison: every voxel for closed meshes; for open ones (where
// the three ray axes may disagree inside a uniform element) every leaf voxel
// and each uniform element's corner.
::testing::AssertionResult matchesParityReference(const hdt::Volume& volume, const hdt::PreparedMesh& prepared) {
  const hdt::test::TreeView tree = hdt::test::walkVolume(volume);
  if (!tree.problems.empty()) return ::testing::AssertionFailure() << "malformed tree: " << tree.problems.front();
  return hdt::test::volumeMatchesReference(volume, tree, hdt::test::referenceVoxelize(prepared, prepared.surfaceOnly));
}

} // namespace

extern "C" int LLVMFuzzerTestOneInput(const uint8_t* data, size_t size) {
  if (size < 2) return 0;
  hdt::BuildConfig config;
  const uint8_t pick = data[0];
  config.rootGrid = 1 << (pick & 3) % 3;       // 1, 2, 4
  config.leafSize = (pick & 4) ? 16 : 8;
  config.resolution = (pick & 8) ? 64 : 32;
  config.surfaceOnly = (pick & 16) != 0;
  const bool winding = !config.surfaceOnly && (pick & 32) != 0;
  config.insideTest = winding ? hdt::InsideTest::WindingNumber : hdt::InsideTest::Parity;
  const size_t points = 3 + data[1] % 32;
  size_t at = 2;
  if (size < at + 3 * points) return 0;
  hdt::TriangleMesh mesh;
  for (size_t i = 0; i < 3 * points; ++i) mesh.points.push_back(double(int8_t(data[at++])));
  for (int t = 0; t < 64 && at + 3 <= size; ++t)
    for (int k = 0; k < 3; ++k) mesh.triangles.push_back(uint32_t(data[at++] % points));

  hdt::PreparedMesh prepared;
  try {
    prepared = hdt::prepareMesh(mesh, config);
  } catch (const hdt::Error& e) {
    if (e.kind() != hdt::ErrorKind::BadInput && e.kind() != hdt::ErrorKind::InvalidArgument) std::abort();
    return 0; // no triangles, all degenerate, zero extent, resolution not R 2^h L
  }
  hdt::BuildOptions options;
  options.backend = hdt::Backend::Cpu;
  options.threads = 1 + pick % 3;
  const hdt::Volume volume = hdt::buildCpu(prepared, options);

  const ::testing::AssertionResult same =
      winding ? hdt::test::volumeMatchesWinding(volume, prepared) : matchesParityReference(volume, prepared);
  if (!same) {
    std::fprintf(stderr, "the build differs from the brute-force reference: %s\n", same.message());
    std::abort();
  }
  const std::vector<uint8_t> bytes = hdt::serializeHdt(volume);
  if (hdt::serializeHdt(hdt::deserializeHdt(bytes.data(), bytes.size())) != bytes) std::abort();
  return 0;
}
