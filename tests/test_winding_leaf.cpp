// windingDecideLeaf (core/include/hdt/winding_leaf.hpp) on its own: every
// leaf of a parity build (for its surface plane) decided again from crossing
// counts taken one voxel at a time (windingRayCrossings, independent of the
// CPU driver's line sums), every non-surface voxel against the brute-force
// winding number. Shapes whose open rims and strip sheets run through leaves,
// a flat sheet (w close to 1/2 beside it), nested outward shells (N = 2) and
// an inverted inner shell; the shared open meshes when present.
#include "hdt/builder.hpp"
#include "hdt/mesh_io.hpp"
#include "hdt/volume_walk.hpp"
#include "hdt/winding_far.hpp"
#include "hdt/winding_leaf.hpp"
#include "hdt/winding_tree.hpp"
#include "support/mesh_files.hpp"
#include "support/shapes.hpp"
#include "support/winding_reference.hpp"

#include <gtest/gtest.h>

#include <algorithm>
#include <cmath>
#include <string>
#include <utility>
#include <vector>

namespace hdt {
namespace test {
namespace {

struct LeafCheck {
  uint64_t leaves = 0, judged = 0, wrong = 0, ties = 0, inside = 0, outside = 0;
};

// A CPU build with Parity (the surface plane is the same under either test)
// and the winding tree of its triangles.
struct ParityBuild {
  PreparedMesh mesh;
  Volume volume;
  WindingTree tree;
};

ParityBuild parityBuild(const TriangleMesh& mesh, int n, int leafSize) {
  BuildConfig c;
  c.resolution = n;
  c.rootGrid = 4;
  c.leafSize = leafSize;
  c.insideTest = InsideTest::Parity;
  ParityBuild b;
  b.mesh = prepareMesh(mesh, c);
  BuildOptions o;
  o.backend = Backend::Cpu;
  b.volume = buildCpu(b.mesh, o);
  b.tree = buildWindingTree(b.mesh.triangles);
  return b;
}

// Decides every leaf of a parity build by windingDecideLeaf with per-voxel
// ray counts. Judges the voxels whose x + y + z is a multiple of `stride`
// (large meshes).
LeafCheck checkLeaves(const TriangleMesh& mesh, int n, int leafSize, int stride = 1, bool linear = false) {
  const ParityBuild b = parityBuild(mesh, n, leafSize);
  const PreparedMesh& m = b.mesh;
  const Volume& v = b.volume;
  const WindingTreeView t = b.tree.view();
  const int L = v.grid.leafSize;
  LeafCheck out;
  std::vector<int16_t> counts(size_t(L) * L * L);
  std::vector<uint32_t> words(leafWordCount(L));
  walkVolume(v, int(v.levelStart.size()) - 2, [&](const WalkedElement& e) {
    if (e.state() != ElementState::Boundary) return true;
    ++out.leaves;
    const uint32_t* surface = v.leafWords.data() + leafWordOffset(e.payload(), L);
    const LeafView view{surface, L};
    for (int z = 0; z < L; ++z)
      for (int y = 0; y < L; ++y)
        for (int x = 0; x < L; ++x) {
          const int64_t P[3] = {latticeOfVoxelCentre(e.origin[0] + x), latticeOfVoxelCentre(e.origin[1] + y),
                                latticeOfVoxelCentre(e.origin[2] + z)};
          int N = 0;
          if (view.voxel(x, y, z) != VoxelState::Surface) EXPECT_TRUE(windingRayCrossings(t, P, N));
          counts[size_t(x + L * (y + L * z))] = int16_t(N);
        }
    if (linear) {
      windingDecideLeafLinear(t, L, e.origin.data(), surface, counts.data(), words.data());
    } else {
      windingDecideLeaf(t, L, e.origin.data(), surface, counts.data(), words.data());
    }
    const LeafView decided{words.data(), L};
    for (int z = 0; z < L; ++z)
      for (int y = 0; y < L; ++y)
        for (int x = 0; x < L; ++x) {
          const VoxelState s = decided.voxel(x, y, z);
          EXPECT_EQ(s == VoxelState::Surface, view.voxel(x, y, z) == VoxelState::Surface);
          if (s == VoxelState::Surface || (e.origin[0] + x + e.origin[1] + y + e.origin[2] + z) % stride != 0) continue;
          const double w = referenceWinding(m, e.origin[0] + x, e.origin[1] + y, e.origin[2] + z);
          if (std::fabs(w - 0.5) < 1e-9) {
            ++out.ties;
            continue;
          }
          ++out.judged;
          const bool inside = s == VoxelState::Inside;
          out.inside += inside;
          out.outside += !inside;
          if (inside != (w >= 0.5)) {
            if (out.wrong++ < 5)
              ADD_FAILURE() << "voxel (" << e.origin[0] + x << "," << e.origin[1] + y << "," << e.origin[2] + z
                            << "): decided " << (inside ? "inside" : "outside") << ", w = " << w;
          }
        }
    return true;
  });
  return out;
}

void expectAllMatch(const LeafCheck& c, const char* what) {
  EXPECT_EQ(c.wrong, 0u) << what;
  EXPECT_GT(c.leaves, 0u) << what;
  EXPECT_GT(c.inside, 0u) << what;
  EXPECT_LT(c.ties, 64u) << what;
}

TriangleMesh flatSquare() {
  TriangleMesh m;
  m.points = {-0.7, -0.6, 0.05, 0.8, -0.5, -0.1, 0.7, 0.7, 0.1, -0.6, 0.6, 0.0};
  m.triangles = {0, 1, 2, 0, 2, 3};
  return m;
}

// The far part's gradient bound (windingPartGradientBound) against K_far
// itself: over every anchor box the near/far split serves, K_far at each voxel
// centre stays within the bound times the distance from the box centre, plus
// both rounding bounds. Returns the number of voxel centres compared.
uint64_t checkFarGradientBounds(const TriangleMesh& mesh, int n, int leafSize) {
  const ParityBuild b = parityBuild(mesh, n, leafSize);
  const Volume& v = b.volume;
  const WindingTreeView t = b.tree.view();
  const int L = v.grid.leafSize, M = kWindingAnchorBox;
  uint64_t compared = 0;
  walkVolume(v, int(v.levelStart.size()) - 2, [&](const WalkedElement& e) {
    if (e.state() != ElementState::Boundary) return true;
    double lo[3], hi[3];
    windingBoxCentres(e.origin.data(), VoxelBox{{0, 0, 0}, {L, L, L}}, lo, hi);
    WindingLeafSplit split;
    if (!windingSplitEdges(t, lo, hi, L, split) || 4 * uint32_t(split.nearCount) >= t.edgeCount) return true;
    for (int az = 0; az < L; az += M)
      for (int ay = 0; ay < L; ay += M)
        for (int ax = 0; ax < L; ax += M) {
          double alo[3], ahi[3], ac[3];
          windingBoxCentres(e.origin.data(), VoxelBox{{ax, ay, az}, {ax + M, ay + M, az + M}}, alo, ahi);
          for (int a = 0; a < 3; ++a) ac[a] = 0.5 * (alo[a] + ahi[a]);
          const double G = windingPartGradientBound(t, split, false, alo, ahi);
          double Kc = 0, errorC = 0;
          if (!(G < INFINITY) || !windingPartStripSum(t, split, false, ac, Kc, errorC)) continue;
          for (int z = 0; z < M; ++z)
            for (int y = 0; y < M; ++y)
              for (int x = 0; x < M; ++x) {
                const double p[3] = {alo[0] + x, alo[1] + y, alo[2] + z};
                double K = 0, error = 0;
                if (!windingPartStripSum(t, split, false, p, K, error)) continue;
                const double r = std::sqrt((p[0] - ac[0]) * (p[0] - ac[0]) + (p[1] - ac[1]) * (p[1] - ac[1]) +
                                           (p[2] - ac[2]) * (p[2] - ac[2]));
                EXPECT_LE(std::fabs(K - Kc), G * r + error + errorC + 1e-12)
                    << "leaf at " << e.origin[0] << "," << e.origin[1] << "," << e.origin[2] << ", voxel "
                    << p[0] << "," << p[1] << "," << p[2];
                ++compared;
              }
        }
    return true;
  });
  return compared;
}

// The far part to first order (winding_far.hpp) against K_far itself: over
// every anchor box, K_far at each voxel centre lies within the expansion's
// stray of K_far(c) + g . (p - c). Pins the field's sign (kWindingFieldSign):
// with the other sign the linear term points the wrong way. Returns the
// number of voxel centres compared.
uint64_t checkFarExpansions(const TriangleMesh& mesh, int n, int leafSize) {
  const ParityBuild b = parityBuild(mesh, n, leafSize);
  const Volume& v = b.volume;
  const WindingTreeView t = b.tree.view();
  const int L = v.grid.leafSize, M = std::min(kWindingLinearAnchorBox, L);
  uint64_t compared = 0;
  double worst = 0; // the largest |error| / stray seen
  walkVolume(v, int(v.levelStart.size()) - 2, [&](const WalkedElement& e) {
    if (e.state() != ElementState::Boundary) return true;
    double lo[3], hi[3];
    windingBoxCentres(e.origin.data(), VoxelBox{{0, 0, 0}, {L, L, L}}, lo, hi);
    WindingLeafSplit split;
    WindingFarLeaf far;
    if (!windingSplitEdges(t, lo, hi, L, split) || 4 * uint32_t(split.nearCount) >= t.edgeCount ||
        !windingFarLeaf(t, split, lo, hi, far))
      return true;
    for (int az = 0; az < L; az += M)
      for (int ay = 0; ay < L; ay += M)
        for (int ax = 0; ax < L; ax += M) {
          double alo[3], ahi[3];
          windingBoxCentres(e.origin.data(), VoxelBox{{ax, ay, az}, {ax + M, ay + M, az + M}}, alo, ahi);
          WindingFarExpansion x;
          if (!windingFarExpansion(t, split, far, alo, ahi, x)) continue;
          for (int z = 0; z < M; ++z)
            for (int y = 0; y < M; ++y)
              for (int xx = 0; xx < M; ++xx) {
                const double p[3] = {alo[0] + xx, alo[1] + y, alo[2] + z};
                double K = 0, error = 0;
                if (!windingPartStripSum(t, split, false, p, K, error)) continue;
                double value = 0, stray = 0;
                windingFarOverBox(x, p, p, value, stray);
                EXPECT_LE(std::fabs(K - value), stray + error)
                    << "leaf at " << e.origin[0] << "," << e.origin[1] << "," << e.origin[2] << ", voxel " << p[0]
                    << "," << p[1] << "," << p[2];
                worst = std::max(worst, std::fabs(K - value) / (stray + error));
                ++compared;
              }
        }
    return true;
  });
  ::testing::Test::RecordProperty("worst_error_over_stray", std::to_string(worst));
  return compared;
}

class WindingLeafShape : public ::testing::TestWithParam<int> {};

// The generated shapes of the winding suites (open rims through leaves,
// overlaps, an inward inner shell, doubled and flipped faces), leaves of 8 at
// 64^3.
TEST_P(WindingLeafShape, EveryLeafVoxelMatchesBruteForce) {
  const WindingShape s = windingShapes()[size_t(GetParam())];
  expectAllMatch(checkLeaves(s.mesh, 64, 8), s.name.c_str());
}

INSTANTIATE_TEST_SUITE_P(Shapes, WindingLeafShape, ::testing::Range(0, int(windingShapes().size())),
                         [](const ::testing::TestParamInfo<int>& i) { return windingShapes()[size_t(i.param)].name; });

// Leaves of 16 at 128^3 on the open cube: larger boxes, so the threshold and
// the halving both run across the hole's w = 1/2 sheet.
TEST(WindingLeaf, OpenCubeLeavesOf16At128) {
  const LeafCheck c = checkLeaves(windingShapes()[0].mesh, 128, 16);
  expectAllMatch(c, "open cube");
  EXPECT_GT(c.outside, 0u);
}

// A hemisphere of 12 rings and 96 segments (a rim of more edges than a leaf
// keeps near) whose opening faces along `axis`, towards - when `flip`.
TriangleMesh turnedHemisphere(int axis, bool flip) {
  TriangleMesh h = uvHemisphere(12, 96, 1.0);
  for (size_t i = 0; i < h.pointCount(); ++i) {
    double* q = &h.points[3 * i];
    std::swap(q[2], q[axis]);
    if (flip) q[axis] = -q[axis];
  }
  return h;
}

// The whole chain's K to first order over sheet-free boxes of M^3 voxels
// (windingChainExpansion, the device's leaf boxes): K at every voxel centre
// lies within the expansion's stray of K(c) + g . (p - c), and every verdict
// windingLinearVerdict certifies at a non-surface voxel (N from a ray walk)
// equals the brute-force sum's. Pins the bounds and the field's sign.
struct ChainCheck {
  uint64_t boxes = 0, compared = 0, certified = 0, unsure = 0, judged = 0, wrong = 0;
};

ChainCheck checkChainExpansions(const TriangleMesh& mesh, int n, int leafSize, int M) {
  const ParityBuild b = parityBuild(mesh, n, leafSize);
  const Volume& v = b.volume;
  const WindingTreeView t = b.tree.view();
  const int L = v.grid.leafSize;
  ChainCheck out;
  walkVolume(v, int(v.levelStart.size()) - 2, [&](const WalkedElement& e) {
    if (e.state() != ElementState::Boundary) return true;
    const LeafView view{v.leafWords.data() + leafWordOffset(e.payload(), L), L};
    for (int az = 0; az < L; az += M)
      for (int ay = 0; ay < L; ay += M)
        for (int ax = 0; ax < L; ax += M) {
          double lo[3], hi[3];
          windingBoxCentres(e.origin.data(), VoxelBox{{ax, ay, az}, {ax + M, ay + M, az + M}}, lo, hi);
          WindingFarExpansion x;
          if (windingSheetsMeetBox(t, lo, hi) || !windingChainExpansion(t, lo, hi, x)) continue;
          ++out.boxes;
          for (int z = 0; z < M; ++z)
            for (int y = 0; y < M; ++y)
              for (int xx = 0; xx < M; ++xx) {
                const double p[3] = {lo[0] + xx, lo[1] + y, lo[2] + z};
                double K = 0, error = 0, value = 0, stray = 0;
                windingFarOverBox(x, p, p, value, stray);
                if (windingStripSum(t, p, K, error)) {
                  EXPECT_LE(std::fabs(K - value), stray + error) << "voxel " << p[0] << "," << p[1] << "," << p[2];
                  ++out.compared;
                }
                if (view.voxel(ax + xx, ay + y, az + z) == VoxelState::Surface) continue;
                const int gx = e.origin[0] + ax + xx, gy = e.origin[1] + ay + y, gz = e.origin[2] + az + z;
                const int64_t P[3] = {latticeOfVoxelCentre(gx), latticeOfVoxelCentre(gy), latticeOfVoxelCentre(gz)};
                int N = 0;
                if (!windingRayCrossings(t, P, N)) continue;
                const int verdict = windingLinearVerdict(t, x, p, N);
                if (verdict == kWindingUnsure) {
                  ++out.unsure;
                  continue;
                }
                ++out.certified;
                // The brute force where w is near 1/2 by the expansion's own
                // estimate (where a wrong bound would show), and at every 16th
                // voxel elsewhere (K's check above covers every one).
                const double nearHalf = std::fabs(N + value / (4.0 * kWindingPi) - 0.5);
                if (nearHalf > 0.25 && (gx + gy + gz) % 16 != 0) continue;
                ++out.judged;
                const double w = referenceWinding(b.mesh, gx, gy, gz);
                if ((verdict == kWindingInside) != (w >= 0.5) && out.wrong++ < 5)
                  ADD_FAILURE() << "voxel (" << gx << "," << gy << "," << gz << "): certified "
                                << (verdict == kWindingInside ? "inside" : "outside") << ", w = " << w;
              }
        }
    return true;
  });
  return out;
}

// Every generated shape, boxes of 4^3 and 2^3; the hemispheres whose rims
// pass beside many boxes; most voxels must be certified (not a vacuous pass).
TEST(WindingLeaf, ChainExpansionHoldsAndDecides) {
  ChainCheck all;
  auto add = [&](const ChainCheck& c) {
    all.boxes += c.boxes;
    all.compared += c.compared;
    all.certified += c.certified;
    all.unsure += c.unsure;
    all.judged += c.judged;
    all.wrong += c.wrong;
  };
  for (const WindingShape& s : windingShapes())
    for (int M : {4, 2}) add(checkChainExpansions(s.mesh, 64, 8, M));
  for (int axis = 0; axis < 3; ++axis) add(checkChainExpansions(turnedHemisphere(axis, axis == 1), 64, 8, 4));
  EXPECT_EQ(all.wrong, 0u);
  EXPECT_GT(all.boxes, 1000u);
  EXPECT_GT(all.compared, 10000u);
  EXPECT_GT(all.certified, 20u * all.unsure);
}

// Hemispheres whose rims have more edges than a leaf keeps near, so leaves
// split their edges: the rays at the near chain's open ends pass beside many
// anchor boxes (the bound must carry them), in every orientation of the rim.
TEST(WindingLeaf, FarGradientBoundHoldsBesideTheOpenEnds) {
  uint64_t compared = 0;
  for (int axis = 0; axis < 3; ++axis)
    for (int flip = 0; flip < 2; ++flip) {
      compared += checkFarGradientBounds(turnedHemisphere(axis, flip), 64, 8);
    }
  EXPECT_GT(compared, 1000u);
}

// The first-order far part on the same hemispheres, and leaves decided with
// it (windingDecideLeafLinear, the CPU driver's) against the brute force.
TEST(WindingLeaf, FarExpansionHoldsBesideTheOpenEnds) {
  uint64_t compared = 0;
  for (int axis = 0; axis < 3; ++axis)
    for (int flip = 0; flip < 2; ++flip) {
      const TriangleMesh h = turnedHemisphere(axis, flip);
      compared += checkFarExpansions(h, 64, 8);
      const LeafCheck c = checkLeaves(h, 64, 8, 1, true); // w = 1/2 exactly on the symmetry planes: ties
      EXPECT_EQ(c.wrong, 0u);
      EXPECT_GT(c.judged, 1000u);
    }
  EXPECT_GT(compared, 1000u);
}

// A single flat sheet: every voxel beside it has w within a few hundredths
// of 1/2 (the certified margins and the single-voxel fallbacks carry it), and
// its four rims' strip sheets cross many leaves.
TEST(WindingLeaf, FlatSheet) {
  const LeafCheck c = checkLeaves(flatSquare(), 64, 8);
  EXPECT_EQ(c.wrong, 0u);
  EXPECT_GT(c.inside, 100u); // the side the normal points away from
  EXPECT_GT(c.outside, 100u);
  EXPECT_GT(c.judged, 1000u);
  EXPECT_LT(c.ties, 64u);
}

// The flat sheet above an open dome whose 96 rim edges lie far from the
// sheet's leaves: those leaves take the near / far split, and their voxels,
// w within hundredths of 1/2, are where the far part's bound is too coarse
// and a single voxel takes K_far summed at its centre. Every voxel judged.
// The dome either way round: its w beside the sheet is a little below or a
// little above 0, so voxels lie on both sides of 1/2 there.
TEST(WindingLeaf, FlatSheetAboveFarRims) {
  for (const bool flipped : {false, true}) {
    TriangleMesh dome = uvHemisphere(6, 96, 0.5, {0.0, 0.05, -0.9});
    if (flipped) flipOrientation(dome);
    TriangleMesh m = flatSquare();
    append(m, dome);
    const char* what = flipped ? "dome inward" : "dome outward";
    const LeafCheck c = checkLeaves(m, 64, 8);
    EXPECT_EQ(c.wrong, 0u) << what;
    EXPECT_GT(c.inside, 100u) << what;
    EXPECT_GT(c.outside, 100u) << what;
    EXPECT_LT(c.ties, 64u) << what;
    EXPECT_EQ(checkLeaves(m, 64, 8, 1, true).wrong, 0u) << what;
  }
}

// Two nested outward shells: w = 2 inside the inner one (N = 2 there, the
// threshold still 1), 1 between; with the inner one inward, a cavity (w = 0).
TEST(WindingLeaf, NestedShellsBothWays) {
  TriangleMesh outward = icosphere(2, 1.0);
  append(outward, icosphere(2, 0.5, {0.05, 0.02, 0}));
  expectAllMatch(checkLeaves(outward, 64, 8), "nested outward");
  TriangleMesh cavity = icosphere(2, 1.0);
  TriangleMesh inner = icosphere(2, 0.5, {0.05, 0.02, 0});
  flipOrientation(inner);
  append(cavity, inner);
  expectAllMatch(checkLeaves(cavity, 64, 8), "inner inward");
  // An open outer shell around a closed inner one: rims beside an N = 2 region.
  TriangleMesh open = windingShapes()[1].mesh; // the sphere with a cut cap
  append(open, icosphere(2, 0.4, {0.0, 0.0, 0.3}));
  expectAllMatch(checkLeaves(open, 64, 8), "open outer, closed inner");
}

// The teapot at 256^3 with leaves of 8: most of its 160 boundary edges lie
// far from any one leaf, so the leaves along its rims take the near / far
// split (windingDecideAnchored); every 41st voxel judged.
TEST(WindingLeaf, TeapotAt256NearAndFarEdges) {
  std::string why;
  const std::string path = sharedMeshPath("teapot.obj", &why);
  if (path.empty()) GTEST_SKIP() << why;
  expectAllMatch(checkLeaves(readMesh(path), 256, 8, 41), "teapot 256");
  expectAllMatch(checkLeaves(readMesh(path), 256, 8, 41, true), "teapot 256, first order");
  EXPECT_GT(checkFarExpansions(readMesh(path), 256, 8), 1000u);
}

class WindingLeafSharedMesh : public ::testing::TestWithParam<const char*> {};

TEST_P(WindingLeafSharedMesh, EveryLeafVoxelMatchesBruteForce) {
  std::string why;
  const std::string path = sharedMeshPath(GetParam(), &why);
  if (path.empty()) GTEST_SKIP() << why;
  const bool large = std::string(GetParam()) == "ogre.obj"; // 10x the teapot's triangles
  expectAllMatch(checkLeaves(readMesh(path), 64, 8, large ? 17 : 1), GetParam());
  expectAllMatch(checkLeaves(readMesh(path), 64, 8, large ? 17 : 1, true), GetParam());
}

INSTANTIATE_TEST_SUITE_P(Files, WindingLeafSharedMesh, ::testing::Values("teapot.obj", "ogre.obj"),
                         [](const ::testing::TestParamInfo<const char*>& i) {
                           return std::string(i.param).substr(0, std::string(i.param).find('.'));
                         });

} // namespace
} // namespace test
} // namespace hdt
