#include "support/shapes.hpp"

#include <algorithm>
#include <cmath>
#include <map>
#include <sstream>
#include <stdexcept>
#include <utility>

namespace hdt {
namespace test {
namespace {

constexpr double kPi = 3.14159265358979323846;

uint32_t addPoint(TriangleMesh& m, double x, double y, double z) {
  m.points.push_back(x);
  m.points.push_back(y);
  m.points.push_back(z);
  return uint32_t(m.pointCount() - 1);
}

void addTriangle(TriangleMesh& m, uint32_t a, uint32_t b, uint32_t c) {
  m.triangles.push_back(a);
  m.triangles.push_back(b);
  m.triangles.push_back(c);
}

// Explicit bounds [-B, B]^3 with B = (N - 2) / 2: voxel size exactly 1.
void useUnitVoxelFrame(Shape& s, int resolution) {
  const double b = 0.5 * double(resolution - 2);
  s.hasBounds = true;
  s.boundsMin = {-b, -b, -b};
  s.boundsMax = {b, b, b};
}

} // namespace

// ---- primitives -------------------------------------------------------------------

TriangleMesh icosphere(int subdivisions, double radius, const Vec3& centre) {
  const double t = (1.0 + std::sqrt(5.0)) / 2.0;
  std::vector<Vec3> p = {{-1, t, 0}, {1, t, 0}, {-1, -t, 0}, {1, -t, 0}, {0, -1, t}, {0, 1, t},
                         {0, -1, -t}, {0, 1, -t}, {t, 0, -1}, {t, 0, 1}, {-t, 0, -1}, {-t, 0, 1}};
  std::vector<std::array<uint32_t, 3>> f = {
      {0, 11, 5}, {0, 5, 1},  {0, 1, 7},   {0, 7, 10}, {0, 10, 11}, {1, 5, 9}, {5, 11, 4},
      {11, 10, 2}, {10, 7, 6}, {7, 1, 8},  {3, 9, 4},  {3, 4, 2},   {3, 2, 6}, {3, 6, 8},
      {3, 8, 9},  {4, 9, 5},  {2, 4, 11}, {6, 2, 10}, {8, 6, 7},   {9, 8, 1}};
  auto normalise = [](Vec3 v) {
    const double l = std::sqrt(v[0] * v[0] + v[1] * v[1] + v[2] * v[2]);
    return Vec3{v[0] / l, v[1] / l, v[2] / l};
  };
  for (Vec3& v : p) v = normalise(v);
  for (int s = 0; s < subdivisions; ++s) {
    // Midpoints are shared between the two faces of an edge (keyed by the
    // sorted index pair), so the mesh stays indexed and closed.
    std::map<std::pair<uint32_t, uint32_t>, uint32_t> mid;
    auto midpoint = [&](uint32_t a, uint32_t b) {
      const auto key = std::make_pair(std::min(a, b), std::max(a, b));
      auto it = mid.find(key);
      if (it != mid.end()) return it->second;
      p.push_back(normalise({p[a][0] + p[b][0], p[a][1] + p[b][1], p[a][2] + p[b][2]}));
      const uint32_t i = uint32_t(p.size() - 1);
      mid.emplace(key, i);
      return i;
    };
    std::vector<std::array<uint32_t, 3>> next;
    next.reserve(f.size() * 4);
    for (const auto& tri : f) {
      const uint32_t a = midpoint(tri[0], tri[1]), b = midpoint(tri[1], tri[2]), c = midpoint(tri[2], tri[0]);
      next.push_back({tri[0], a, c});
      next.push_back({tri[1], b, a});
      next.push_back({tri[2], c, b});
      next.push_back({a, b, c});
    }
    f.swap(next);
  }
  TriangleMesh m;
  for (const Vec3& v : p)
    addPoint(m, centre[0] + radius * v[0], centre[1] + radius * v[1], centre[2] + radius * v[2]);
  for (const auto& tri : f) addTriangle(m, tri[0], tri[1], tri[2]);
  return m;
}

TriangleMesh uvHemisphere(int rings, int segments, double radius, const Vec3& centre) {
  TriangleMesh m;
  const uint32_t pole = addPoint(m, centre[0], centre[1], centre[2] + radius);
  // ring k (1..rings) at polar angle k * (pi/2) / rings; ring `rings` is the rim.
  auto ringPoint = [&](int k, int j) { return uint32_t(1 + (k - 1) * segments + (j % segments)); };
  for (int k = 1; k <= rings; ++k) {
    const double theta = double(k) * 0.5 * kPi / double(rings);
    for (int j = 0; j < segments; ++j) {
      const double phi = 2.0 * kPi * double(j) / double(segments);
      addPoint(m, centre[0] + radius * std::sin(theta) * std::cos(phi),
               centre[1] + radius * std::sin(theta) * std::sin(phi), centre[2] + radius * std::cos(theta));
    }
  }
  for (int j = 0; j < segments; ++j) addTriangle(m, pole, ringPoint(1, j), ringPoint(1, j + 1));
  for (int k = 1; k < rings; ++k)
    for (int j = 0; j < segments; ++j) {
      const uint32_t a = ringPoint(k, j), b = ringPoint(k, j + 1), c = ringPoint(k + 1, j),
                     d = ringPoint(k + 1, j + 1);
      addTriangle(m, a, c, d);
      addTriangle(m, a, d, b);
    }
  return m;
}

TriangleMesh torus(double majorRadius, double minorRadius, int majorSegments, int minorSegments,
                   const Vec3& centre) {
  TriangleMesh m;
  for (int i = 0; i < majorSegments; ++i) {
    const double u = 2.0 * kPi * double(i) / double(majorSegments);
    for (int j = 0; j < minorSegments; ++j) {
      const double v = 2.0 * kPi * double(j) / double(minorSegments);
      const double r = majorRadius + minorRadius * std::cos(v);
      addPoint(m, centre[0] + r * std::cos(u), centre[1] + r * std::sin(u), centre[2] + minorRadius * std::sin(v));
    }
  }
  auto at = [&](int i, int j) { return uint32_t((i % majorSegments) * minorSegments + (j % minorSegments)); };
  // dP/du x dP/dv points outward, so (i, j) -> (i+1, j) -> (i+1, j+1) is counter-clockwise.
  for (int i = 0; i < majorSegments; ++i)
    for (int j = 0; j < minorSegments; ++j) {
      addTriangle(m, at(i, j), at(i + 1, j), at(i + 1, j + 1));
      addTriangle(m, at(i, j), at(i + 1, j + 1), at(i, j + 1));
    }
  return m;
}

TriangleMesh box(const Vec3& lo, const Vec3& hi) {
  TriangleMesh m;
  for (int c = 0; c < 8; ++c)
    addPoint(m, (c & 1) ? hi[0] : lo[0], (c & 2) ? hi[1] : lo[1], (c & 4) ? hi[2] : lo[2]);
  const uint32_t faces[12][3] = {{0, 4, 6}, {0, 6, 2}, {1, 3, 7}, {1, 7, 5}, {0, 1, 5}, {0, 5, 4},
                                 {2, 6, 7}, {2, 7, 3}, {0, 2, 3}, {0, 3, 1}, {4, 5, 7}, {4, 7, 6}};
  for (const auto& f : faces) addTriangle(m, f[0], f[1], f[2]);
  return m;
}

TriangleMesh octahedron(const Vec3& c, double r) {
  TriangleMesh m;
  // 0: +x, 1: -x, 2: +y, 3: -y, 4: +z, 5: -z
  for (int a = 0; a < 3; ++a)
    for (int s = 0; s < 2; ++s) {
      Vec3 p = c;
      p[a] += s == 0 ? r : -r;
      addPoint(m, p[0], p[1], p[2]);
    }
  for (int sx = 0; sx < 2; ++sx)
    for (int sy = 0; sy < 2; ++sy)
      for (int sz = 0; sz < 2; ++sz) {
        const uint32_t x = uint32_t(sx), y = uint32_t(2 + sy), z = uint32_t(4 + sz);
        // (X, Y, Z) faces the octant (+,+,+); each sign flip mirrors it.
        if ((sx + sy + sz) % 2 == 0)
          addTriangle(m, x, y, z);
        else
          addTriangle(m, x, z, y);
      }
  return m;
}

// ---- operations -------------------------------------------------------------------

void append(TriangleMesh& to, const TriangleMesh& from) {
  const uint32_t base = uint32_t(to.pointCount());
  to.points.insert(to.points.end(), from.points.begin(), from.points.end());
  for (uint32_t i : from.triangles) to.triangles.push_back(base + i);
}

void flipOrientation(TriangleMesh& mesh) {
  for (size_t t = 0; t < mesh.triangleCount(); ++t) std::swap(mesh.triangles[3 * t + 1], mesh.triangles[3 * t + 2]);
}

void transform(TriangleMesh& mesh, const Mat3& rot, const Vec3& pivot, const Vec3& translation) {
  for (size_t p = 0; p < mesh.pointCount(); ++p) {
    double* x = &mesh.points[3 * p];
    const Vec3 d = {x[0] - pivot[0], x[1] - pivot[1], x[2] - pivot[2]};
    for (int a = 0; a < 3; ++a)
      x[a] = rot[a][0] * d[0] + rot[a][1] * d[1] + rot[a][2] * d[2] + pivot[a] + translation[a];
  }
}

Mat3 rotationXYZ(double ax, double ay, double az) {
  const double cx = std::cos(ax), sx = std::sin(ax), cy = std::cos(ay), sy = std::sin(ay), cz = std::cos(az),
               sz = std::sin(az);
  const Mat3 rx = {{{1, 0, 0}, {0, cx, -sx}, {0, sx, cx}}};
  const Mat3 ry = {{{cy, 0, sy}, {0, 1, 0}, {-sy, 0, cy}}};
  const Mat3 rz = {{{cz, -sz, 0}, {sz, cz, 0}, {0, 0, 1}}};
  auto mul = [](const Mat3& a, const Mat3& b) {
    Mat3 r{};
    for (int i = 0; i < 3; ++i)
      for (int j = 0; j < 3; ++j) r[i][j] = a[i][0] * b[0][j] + a[i][1] * b[1][j] + a[i][2] * b[2][j];
    return r;
  };
  return mul(rz, mul(ry, rx));
}

double signedVolume(const TriangleMesh& m) {
  double v = 0;
  for (size_t t = 0; t < m.triangleCount(); ++t) {
    const double* a = &m.points[3 * size_t(m.triangles[3 * t])];
    const double* b = &m.points[3 * size_t(m.triangles[3 * t + 1])];
    const double* c = &m.points[3 * size_t(m.triangles[3 * t + 2])];
    v += a[0] * (b[1] * c[2] - b[2] * c[1]) - a[1] * (b[0] * c[2] - b[2] * c[0]) +
         a[2] * (b[0] * c[1] - b[1] * c[0]);
  }
  return v / 6.0;
}

double voxelPlane(int resolution, int i) { return double(i) - 0.5 * double(resolution); }
double voxelCentre(int resolution, int i) { return double(i) + 0.5 - 0.5 * double(resolution); }

// ---- named shapes -------------------------------------------------------------------

BuildConfig Shape::config(int resolution, int rootGrid, int leafSize, bool surfaceOnly) const {
  BuildConfig c;
  c.resolution = resolution;
  c.rootGrid = rootGrid;
  c.leafSize = leafSize;
  c.surfaceOnly = surfaceOnly;
  // The shapes' references (reference_voxelizer) follow the parity rules, and
  // open shapes would take the winding number under the default (Auto).
  c.insideTest = InsideTest::Parity;
  c.hasBounds = hasBounds;
  c.boundsMin = boundsMin;
  c.boundsMax = boundsMax;
  return c;
}

Shape sphereShape() {
  Shape s;
  s.name = "sphere";
  s.mesh = icosphere(3, 1.0, {0.1, -0.2, 0.3});
  return s;
}

Shape torusShape() {
  Shape s;
  s.name = "torus";
  s.mesh = torus(1.0, 0.35, 48, 20);
  transform(s.mesh, rotationXYZ(0.4, 0.2, 0.0));
  return s;
}

Shape gridAlignedBoxShape(int n) {
  Shape s;
  s.name = "grid_aligned_box";
  useUnitVoxelFrame(s, n);
  // x faces on multiples of N/4 (leaf and element planes for every config),
  // y and z faces on voxel planes that are not leaf planes; unequal extents
  // so an axis mix-up cannot cancel out.
  const Vec3 lo = {voxelPlane(n, n / 4), voxelPlane(n, n / 8 + 1), voxelPlane(n, 3 * n / 16)};
  const Vec3 hi = {voxelPlane(n, 3 * n / 4), voxelPlane(n, 5 * n / 8 + 1), voxelPlane(n, 13 * n / 16 - 1)};
  s.mesh = box(lo, hi);
  s.latticeCheck = Shape::LatticeCheck::VoxelPlanes;
  return s;
}

Shape centreBoxShape(int n) {
  Shape s;
  s.name = "centre_box";
  useUnitVoxelFrame(s, n);
  const Vec3 lo = {voxelCentre(n, n / 4), voxelCentre(n, n / 8 + 1), voxelCentre(n, 3 * n / 16)};
  const Vec3 hi = {voxelCentre(n, 3 * n / 4), voxelCentre(n, 5 * n / 8 + 1), voxelCentre(n, 13 * n / 16 - 1)};
  s.mesh = box(lo, hi);
  s.latticeCheck = Shape::LatticeCheck::VoxelCentres;
  return s;
}

Shape centreOpenBoxShape(int n) {
  Shape s = centreBoxShape(n);
  s.name = "centre_open_box";
  // Without its +z face: an open mesh whose rim runs along rows of voxel
  // centres, so the open-mesh vote sees rays through rim edges and vertices,
  // where only the exact perturbation rule decides.
  s.mesh.triangles.resize(s.mesh.triangles.size() - 6);
  s.expectClosed = false;
  return s;
}

Shape centreOctahedronShape(int n) {
  Shape s;
  s.name = "centre_octahedron";
  useUnitVoxelFrame(s, n);
  // Radius an integer number of voxels: every vertex is a voxel centre, and
  // every edge passes through voxel centres (its direction is (1, -1, 0)-like).
  const int c = n / 2 - 1;
  s.mesh = octahedron({voxelCentre(n, c), voxelCentre(n, c), voxelCentre(n, c)}, double(n / 2 - 4));
  s.latticeCheck = Shape::LatticeCheck::VoxelCentres;
  return s;
}

Shape centreSnappedSphereShape(int n) {
  Shape s;
  s.name = "centre_snapped_sphere";
  useUnitVoxelFrame(s, n);
  const int sub = n < 64 ? 1 : (n < 256 ? 2 : 3);
  s.mesh = icosphere(sub, 0.4 * double(n - 2), {0.3, -0.2, 0.1});
  // Round every vertex to the nearest voxel centre (half-integer).
  for (double& x : s.mesh.points) x = std::floor(x) + 0.5;
  s.latticeCheck = Shape::LatticeCheck::VoxelCentres;
  return s;
}

Shape openTiePlatesShape(int n) {
  Shape s;
  s.name = "open_tie_plates";
  useUnitVoxelFrame(s, n);
  // Four query voxel centres Q on a diagonal. Each has three small square
  // plates, one across each of its +x, +y, +z rays, 3 voxels ahead, placed so
  // that the ray passes exactly through a plate edge or corner (all vertices
  // on voxel centres). In the ray's (u, w) plane the plate covers:
  //   Q0: u in [Qu, Qu+2], w in [Qw-2, Qw+2]   low u edge  -> counted (u + eps)
  //   Q1: u in [Qu-2, Qu+2], w in [Qw, Qw+2]   low w edge  -> counted (w + eps^2)
  //   Q2: u in [Qu, Qu+2], w in [Qw, Qw+2]     low corner  -> counted
  //   Q3: u in [Qu-2, Qu], w in [Qw-2, Qw]     high corner -> not counted
  // so by the majority vote Q0..Q2 are Inside and Q3 Outside, and a flipped
  // perturbation sign turns some of them around. The plates are disjoint and
  // at least 2.5 voxels from every Q's voxel box.
  const int lo[4][2] = {{0, -2}, {-2, 0}, {0, 0}, {-2, -2}};
  const int hi[4][2] = {{2, 2}, {2, 2}, {2, 2}, {0, 0}};
  for (int q = 0; q < 4; ++q) {
    const double c = voxelCentre(n, n / 2 - 9 + 6 * q);
    for (int axis = 0; axis < 3; ++axis) {
      const int U = (axis + 1) % 3, W = (axis + 2) % 3;
      auto corner = [&](int du, int dw) {
        Vec3 p{c, c, c};
        p[axis] = c + 3;
        p[U] = c + du;
        p[W] = c + dw;
        return addPoint(s.mesh, p[0], p[1], p[2]);
      };
      const uint32_t a = corner(lo[q][0], lo[q][1]), b = corner(hi[q][0], lo[q][1]), d = corner(hi[q][0], hi[q][1]),
                     e = corner(lo[q][0], hi[q][1]);
      addTriangle(s.mesh, a, b, d);
      addTriangle(s.mesh, a, d, e);
    }
  }
  s.expectClosed = false;
  s.latticeCheck = Shape::LatticeCheck::VoxelCentres;
  return s;
}

Shape rotatedCubeShape() {
  Shape s;
  s.name = "rotated_cube";
  s.mesh = box({-1, -1, -1}, {1, 1, 1});
  transform(s.mesh, rotationXYZ(0.3, 0.7, 0.5));
  return s;
}

Shape thinPlateShape(int n) {
  Shape s;
  s.name = "thin_plate";
  useUnitVoxelFrame(s, n);
  // 0.3 voxel thick, straddling the centre plane z = 0.5 (voxel N/2): the two
  // large faces cut the same voxel layer.
  const double e = double(n - 2);
  s.mesh = box({-0.3 * e, -0.25 * e, 0.35}, {0.3 * e, 0.2 * e, 0.65});
  return s;
}

Shape tiltedThinPlateShape(int n) {
  Shape s;
  s.name = "thin_plate_tilted";
  useUnitVoxelFrame(s, n);
  const double e = double(n - 2);
  s.mesh = box({-0.3 * e, -0.25 * e, 0.1}, {0.3 * e, 0.2 * e, 0.4});
  transform(s.mesh, rotationXYZ(10.0 * kPi / 180.0, 0.0, 0.0));
  return s;
}

Shape twoBodiesShape() {
  Shape s;
  s.name = "two_bodies";
  s.mesh = icosphere(3, 0.4, {-0.55, 0.0, 0.05});
  TriangleMesh t = torus(0.3, 0.1, 32, 12, {0.0, 0.0, 0.0});
  transform(t, rotationXYZ(1.1, 0.3, 0.0), {0, 0, 0}, {0.5, 0.1, 0.0});
  append(s.mesh, t);
  return s;
}

Shape hollowSphereShape() {
  Shape s;
  s.name = "hollow_sphere";
  s.mesh = icosphere(3, 1.0);
  TriangleMesh inner = icosphere(2, 0.55, {0.05, 0.02, -0.03});
  flipOrientation(inner); // normals point into the cavity, i.e. out of the solid
  append(s.mesh, inner);
  return s;
}

Shape openHemisphereShape() {
  Shape s;
  s.name = "open_hemisphere";
  s.mesh = uvHemisphere(12, 32, 1.0);
  transform(s.mesh, rotationXYZ(0.2, -0.1, 0.05));
  s.expectClosed = false;
  return s;
}

Shape singleTriangleShape() {
  Shape s;
  s.name = "single_triangle";
  s.mesh.points = {0.1, 0.2, 0.3, 1.0, 0.35, 0.5, 0.4, 0.95, 0.1};
  s.mesh.triangles = {0, 1, 2};
  s.expectClosed = false;
  return s;
}

Shape degenerateMixShape(int n) {
  Shape s;
  s.name = "degenerate_mix";
  useUnitVoxelFrame(s, n);
  s.mesh = icosphere(2, 0.4 * double(n - 2), {0.2, 0.1, -0.3});
  TriangleMesh& m = s.mesh;
  // Integer coordinates (voxel planes): exact after snapping, so collinear
  // stays collinear.
  const double k = double(n / 16);
  const uint32_t p0 = addPoint(m, -3 * k, -2 * k, -1 * k);
  const uint32_t p1 = addPoint(m, -2 * k, 0 * k, 1 * k);  // p0 + d
  const uint32_t p2 = addPoint(m, 0 * k, 4 * k, 5 * k);   // p0 + 3d
  const uint32_t q0 = addPoint(m, 1, 2, 3);
  const uint32_t q1 = addPoint(m, 1, 2, 3);               // same position, another index
  const uint32_t q2 = addPoint(m, 1, 2, 3);
  // Distinct positions that round to one lattice point (1e-4 voxel apart).
  const uint32_t r0 = addPoint(m, 2, -1, 0);
  const uint32_t r1 = addPoint(m, 2 + 1e-4, -1, 0);
  const uint32_t r2 = addPoint(m, 2, -1 + 1e-4, 0);
  addTriangle(m, 0, 0, 1);    // repeated index
  addTriangle(m, p0, p1, p2); // collinear
  addTriangle(m, p2, p0, p1); // collinear, other order
  addTriangle(m, q0, q1, q2); // coincident
  addTriangle(m, r0, r1, r2); // zero area only after snapping
  s.expectedDegenerate = 5;
  return s;
}

const std::vector<ShapeFactory>& standardShapes() {
  static const std::vector<ShapeFactory> shapes = {
      {"sphere", [](int) { return sphereShape(); }},
      {"torus", [](int) { return torusShape(); }},
      {"grid_aligned_box", gridAlignedBoxShape},
      {"centre_box", centreBoxShape},
      {"centre_open_box", centreOpenBoxShape},
      {"centre_octahedron", centreOctahedronShape},
      {"centre_snapped_sphere", centreSnappedSphereShape},
      {"open_tie_plates", openTiePlatesShape},
      {"rotated_cube", [](int) { return rotatedCubeShape(); }},
      {"thin_plate", thinPlateShape},
      {"thin_plate_tilted", tiltedThinPlateShape},
      {"two_bodies", [](int) { return twoBodiesShape(); }},
      {"hollow_sphere", [](int) { return hollowSphereShape(); }},
      {"open_hemisphere", [](int) { return openHemisphereShape(); }},
      {"single_triangle", [](int) { return singleTriangleShape(); }},
      {"degenerate_mix", degenerateMixShape},
  };
  return shapes;
}

Shape makeShape(const std::string& name, int resolution) {
  for (const ShapeFactory& f : standardShapes())
    if (f.name == name) return f.make(resolution);
  throw std::out_of_range("no test shape named " + name);
}

void PrintTo(const ShapeCase& c, std::ostream* os) {
  *os << c.shape << " N=" << c.n << " R=" << c.r << " L=" << c.l << (c.surfaceOnly ? " surface-only" : " solid");
}

PreparedMesh prepareShapeCase(const ShapeCase& c) {
  const Shape shape = makeShape(c.shape, c.n);
  return prepareMesh(shape.mesh, shape.config(c.n, c.r, c.l, c.surfaceOnly));
}

std::string shapeCaseName(const ShapeCase& c) {
  return c.shape + "_N" + std::to_string(c.n) + "_R" + std::to_string(c.r) + "_L" + std::to_string(c.l) +
         (c.surfaceOnly ? "_surface" : "_solid");
}

// Where two volumes first differ, or "" when they are the same bytes.
std::string firstDifference(const Volume& a, const Volume& b) {
  std::ostringstream s;
  if (a.levelStart != b.levelStart) {
    s << "levelStart differs (" << a.levelStart.size() << " vs " << b.levelStart.size() << " entries)";
    return s.str();
  }
  if (a.elements.size() != b.elements.size()) {
    s << "element count " << a.elements.size() << " vs " << b.elements.size();
    return s.str();
  }
  auto e = std::mismatch(a.elements.begin(), a.elements.end(), b.elements.begin());
  if (e.first != a.elements.end()) {
    s << "element #" << (e.first - a.elements.begin()) << ": 0x" << std::hex << *e.first << " vs 0x" << *e.second;
    return s.str();
  }
  if (a.leafWords.size() != b.leafWords.size()) {
    s << "leaf word count " << a.leafWords.size() << " vs " << b.leafWords.size();
    return s.str();
  }
  auto w = std::mismatch(a.leafWords.begin(), a.leafWords.end(), b.leafWords.begin());
  if (w.first != a.leafWords.end()) {
    const size_t i = size_t(w.first - a.leafWords.begin());
    s << "leaf word #" << i << " (leaf " << i / leafWordCount(a.grid.leafSize) << "): 0x" << std::hex << *w.first
      << " vs 0x" << *w.second;
    return s.str();
  }
  const Statistics &sa = a.stats, &sb = b.stats;
  if (sa.activeVoxels != sb.activeVoxels || sa.insideVoxels != sb.insideVoxels || sa.leafGrids != sb.leafGrids ||
      sa.treeElements != sb.treeElements)
    return "structural statistics differ";
  return "";
}

} // namespace test
} // namespace hdt
