#include "support/winding_reference.hpp"

#include "support/reference_voxelizer.hpp"
#include "support/shapes.hpp"

#include <tbb/parallel_for.h>

#include <atomic>
#include <cmath>
#include <sstream>

namespace hdt {
namespace test {

double referenceWinding(const PreparedMesh& mesh, int x, int y, int z) {
  const double p[3] = {x + 0.5, y + 0.5, z + 0.5};
  double sum = 0;
  for (const LatticeTriangle& t : mesh.triangles) {
    double v[3][3], len[3];
    for (int j = 0; j < 3; ++j) {
      for (int a = 0; a < 3; ++a) v[j][a] = t.v[j][a] / 256.0 - p[a];
      len[j] = std::sqrt(v[j][0] * v[j][0] + v[j][1] * v[j][1] + v[j][2] * v[j][2]);
    }
    auto dot = [&](int i, int j) { return v[i][0] * v[j][0] + v[i][1] * v[j][1] + v[i][2] * v[j][2]; };
    const double det = v[0][0] * (v[1][1] * v[2][2] - v[1][2] * v[2][1]) -
                            v[0][1] * (v[1][0] * v[2][2] - v[1][2] * v[2][0]) +
                            v[0][2] * (v[1][0] * v[2][1] - v[1][1] * v[2][0]);
    const double den = len[0] * len[1] * len[2] + dot(0, 1) * len[2] + dot(0, 2) * len[1] + dot(1, 2) * len[0];
    sum += 2 * std::atan2(det, den);
  }
  return sum / (4 * 3.14159265358979323846);
}

namespace {

// Drops the triangles whose three corners satisfy `cut`.
template <class Cut>
TriangleMesh withoutTriangles(const TriangleMesh& m, Cut cut) {
  TriangleMesh out;
  out.points = m.points;
  for (size_t t = 0; t < m.triangleCount(); ++t) {
    bool all = true;
    for (int j = 0; j < 3; ++j) {
      const uint32_t i = m.triangles[3 * t + j];
      all = all && cut(m.points[3 * i], m.points[3 * i + 1], m.points[3 * i + 2]);
    }
    if (!all) out.triangles.insert(out.triangles.end(), &m.triangles[3 * t], &m.triangles[3 * t + 3]);
  }
  return out;
}

TriangleMesh openCube() {
  return withoutTriangles(box({-1, -1, -1}, {1, 1, 1}), [](double, double, double z) { return z > 0.5; });
}

// The open cube with its +x face turned inward: the face's edges shared
// with its neighbours run the same way as theirs (the boundary 1-chain
// counts them twice), and w there is neither 0 nor 1.
TriangleMesh openCubeOneFaceFlipped() {
  TriangleMesh m = openCube();
  for (size_t t = 0; t < m.triangleCount(); ++t) {
    bool plusX = true;
    for (int j = 0; j < 3; ++j) plusX = plusX && m.points[3 * m.triangles[3 * t + j]] > 0.5;
    if (plusX) std::swap(m.triangles[3 * t + 1], m.triangles[3 * t + 2]);
  }
  return m;
}

} // namespace

BuildConfig windingShapesConfig() {
  BuildConfig config;
  config.resolution = 64;
  config.rootGrid = 4;
  config.leafSize = 8;
  config.insideTest = InsideTest::WindingNumber;
  return config;
}

std::vector<WindingShape> windingShapes() {
  std::vector<WindingShape> out;
  out.push_back({"open_cube", openCube()});
  out.push_back({"cut_sphere", withoutTriangles(icosphere(2, 1.0), [](double, double, double z) { return z > 0.6; })});
  TriangleMesh two = icosphere(2, 1.0, {-0.45, 0, 0});
  append(two, icosphere(2, 1.0, {0.45, 0.05, 0.02}));
  out.push_back({"overlapping_spheres", two});
  TriangleMesh nested = icosphere(2, 1.0);
  TriangleMesh inner = icosphere(2, 0.5, {0.05, 0.02, 0});
  flipOrientation(inner);
  append(nested, inner);
  out.push_back({"nested_shells", nested});
  TriangleMesh folded = icosphere(2, 1.0);
  for (size_t i = 0; i < folded.pointCount(); ++i) { // the cap x > 0.3 folded back through the body
    double& x = folded.points[3 * i];
    if (x > 0.3) x = 0.3 - 2.5 * (x - 0.3);
  }
  out.push_back({"folded_sphere", folded});
  TriangleMesh doubled = openCube();
  const std::vector<uint32_t> once = doubled.triangles;
  doubled.triangles.insert(doubled.triangles.end(), once.begin(), once.end());
  out.push_back({"doubled_open_cube", doubled});
  TriangleMesh partly = icosphere(2, 1.0);
  partly.triangles.insert(partly.triangles.end(), partly.triangles.begin(), partly.triangles.begin() + 3 * 40);
  out.push_back({"sphere_some_doubled", partly});
  TriangleMesh degenerate = openCube();
  degenerate.triangles.insert(degenerate.triangles.end(), {0, 0, 1, 2, 2, 2, 0, 1, 0});
  out.push_back({"open_cube_zero_area", degenerate});
  out.push_back({"open_cube_one_face_flipped", openCubeOneFaceFlipped()});
  return out;
}

::testing::AssertionResult volumeMatchesWinding(const Volume& volume, const PreparedMesh& mesh, uint64_t* ties,
                                                int stride) {
  const TreeView view = walkVolume(volume);
  if (!view.problems.empty()) return ::testing::AssertionFailure() << "tree: " << view.problems.front();
  const ReferenceVoxels surface = referenceVoxelize(mesh, true);
  const int n = view.n;
  std::atomic<uint64_t> wrong{0}, tie{0};
  std::atomic<size_t> first{SIZE_MAX};
  tbb::parallel_for(0, n, [&](int z) {
    for (int y = 0; y < n; ++y)
      for (int x = (y + z) % stride; x < n; x += stride) {
        const size_t i = surface.index(x, y, z);
        const VoxelState got = VoxelState(view.dense[i]);
        VoxelState want = surface.at(x, y, z);
        if (want != VoxelState::Surface) {
          const double w = referenceWinding(mesh, x, y, z);
          if (std::fabs(w - 0.5) < 1e-9) {
            ++tie;
            continue;
          }
          want = w >= 0.5 ? VoxelState::Inside : VoxelState::Outside;
        }
        if (got != want) {
          ++wrong;
          size_t f = first.load();
          while (i < f && !first.compare_exchange_weak(f, i)) {
          }
        }
      }
  });
  if (ties) *ties = tie.load();
  if (wrong.load() == 0) return ::testing::AssertionSuccess();
  const size_t f = first.load();
  const int x = int(f % size_t(n)), y = int((f / size_t(n)) % size_t(n)), z = int(f / (size_t(n) * size_t(n)));
  std::ostringstream os;
  os << wrong.load() << " voxels differ from the brute-force winding number; first (" << x << "," << y << "," << z
     << "): built " << stateName(VoxelState(view.dense[f])) << ", w = " << double(referenceWinding(mesh, x, y, z))
     << ", at " << describeVoxel(volume, x, y, z);
  return ::testing::AssertionFailure() << os.str();
}

} // namespace test
} // namespace hdt
