// libFuzzer harness: read-prepare-build at N = 32 or 64 on small arbitrary
// meshes, checked voxel by voxel against the tests' brute-force reference
// voxelizer (tests/support/reference_voxelizer.hpp, the comparison the unit
// tests run), and through a .hdt round trip.
//
// Input: byte 0 picks R, L, N and surface-only; byte 1 the number of points
// (3..34); then 3 signed bytes a point; then index triples (mod the point
// count), at most 64 triangles.
#include "hdt/builder.hpp"
#include "hdt/error.hpp"
#include "hdt/hdt_file.hpp"
#include "hdt/mesh.hpp"
#include "support/reference_voxelizer.hpp"

#include <cstdint>
#include <cstdio>
#include <cstdlib>

extern "C" int LLVMFuzzerTestOneInput(const uint8_t* data, size_t size) {
  if (size < 2) return 0;
  hdt::BuildConfig config;
  const uint8_t pick = data[0];
  config.rootGrid = 1 << (pick & 3) % 3;       // 1, 2, 4
  config.leafSize = (pick & 4) ? 16 : 8;
  config.resolution = (pick & 8) ? 64 : 32;
  config.surfaceOnly = (pick & 16) != 0;
  // The reference voxelizer follows the parity rules (Auto, the default, would
  // take the winding number on open meshes; its brute-force check is
  // tests/test_winding.cpp's).
  config.insideTest = hdt::InsideTest::Parity;
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

  const hdt::test::ReferenceVoxels ref = hdt::test::referenceVoxelize(prepared, config.surfaceOnly);
  const hdt::test::TreeView tree = hdt::test::walkVolume(volume);
  if (!tree.problems.empty()) {
    std::fprintf(stderr, "malformed tree: %s\n", tree.problems.front().c_str());
    std::abort();
  }
  // The tests' comparison: every voxel for closed meshes; for open ones (where
  // the three ray axes may disagree inside a uniform element) every leaf voxel
  // and each uniform element's corner.
  const ::testing::AssertionResult same = hdt::test::volumeMatchesReference(volume, tree, ref);
  if (!same) {
    std::fprintf(stderr, "the build differs from the reference voxelizer: %s\n", same.message());
    std::abort();
  }
  const std::vector<uint8_t> bytes = hdt::serializeHdt(volume);
  if (hdt::serializeHdt(hdt::deserializeHdt(bytes.data(), bytes.size())) != bytes) std::abort();
  return 0;
}
