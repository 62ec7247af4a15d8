// Procedural meshes: closed, watertight (points shared by index), oriented
// outwards (counter-clockwise seen from outside), with no self-intersections.
// They let the demo and the tests run without any file.
#include "hdt/error.hpp"
#include "hdt/mesh_io.hpp"

#include <algorithm>
#include <array>
#include <cmath>
#include <cstdint>
#include <map>
#include <utility>

namespace hdt {
namespace {

using Vec = std::array<double, 3>;

Vec operator+(const Vec& a, const Vec& b) { return {a[0] + b[0], a[1] + b[1], a[2] + b[2]}; }
Vec operator*(double s, const Vec& a) { return {s * a[0], s * a[1], s * a[2]}; }
Vec cross(const Vec& a, const Vec& b) {
  return {a[1] * b[2] - a[2] * b[1], a[2] * b[0] - a[0] * b[2], a[0] * b[1] - a[1] * b[0]};
}
Vec normalized(const Vec& a) { return (1.0 / std::sqrt(a[0] * a[0] + a[1] * a[1] + a[2] * a[2])) * a; }

constexpr double kPi = 3.14159265358979323846;

uint32_t addPoint(TriangleMesh& mesh, const Vec& p) {
  mesh.points.insert(mesh.points.end(), p.begin(), p.end());
  return uint32_t(mesh.pointCount() - 1);
}
void addTriangle(TriangleMesh& mesh, uint32_t a, uint32_t b, uint32_t c) {
  mesh.triangles.insert(mesh.triangles.end(), {a, b, c});
}

// A point of a closed curve with a frame: tangent T and normal N (unit, T ⟂ N).
struct CurveSample {
  Vec point, tangent, normal;
};

// A tube of `radius` around a closed curve given at `rings` samples, with
// `sides` points around each ring. The frame must be periodic (the sample
// after the last is the first), so the tube closes by index.
template <class Curve>
TriangleMesh tube(Curve curve, int rings, int sides, double radius) {
  TriangleMesh mesh;
  for (int i = 0; i < rings; ++i) {
    const CurveSample s = curve(2 * kPi * i / rings);
    const Vec b = cross(s.tangent, s.normal);
    for (int j = 0; j < sides; ++j) {
      const double a = 2 * kPi * j / sides;
      addPoint(mesh, s.point + radius * (std::cos(a) * s.normal + std::sin(a) * b));
    }
  }
  auto at = [&](int i, int j) { return uint32_t((i % rings) * sides + (j % sides)); };
  // Around the ring (j) then along the curve (i): (d/dj x d/di) points out of
  // the tube, since T x (-sin N + cos B) = -(cos N + sin B).
  for (int i = 0; i < rings; ++i)
    for (int j = 0; j < sides; ++j) {
      addTriangle(mesh, at(i, j), at(i, j + 1), at(i + 1, j));
      addTriangle(mesh, at(i + 1, j), at(i, j + 1), at(i + 1, j + 1));
    }
  return mesh;
}

// Unit icosphere: the icosahedron with every triangle split in four,
// `levels` times, new points pushed onto the sphere. 20 * 4^levels triangles.
TriangleMesh icosphere(int levels) {
  const double t = (1 + std::sqrt(5.0)) / 2;
  const Vec corners[12] = {{-1, t, 0}, {1, t, 0}, {-1, -t, 0}, {1, -t, 0}, {0, -1, t}, {0, 1, t},
                           {0, -1, -t}, {0, 1, -t}, {t, 0, -1}, {t, 0, 1}, {-t, 0, -1}, {-t, 0, 1}};
  TriangleMesh mesh;
  for (const Vec& c : corners) addPoint(mesh, normalized(c));
  mesh.triangles = {0, 11, 5, 0, 5,  1,  0, 1, 7, 0, 7,  10, 0, 10, 11, 1, 5, 9, 5, 11,
                    4, 11, 10, 2, 10, 7, 6, 7, 1, 8, 3,  9,  4, 3, 4,  2,  3, 2, 6, 3,
                    6, 8,  3, 8, 9,  4, 9, 5, 2, 4, 11, 6,  2, 10, 8, 6, 7, 9, 8, 1};
  for (int level = 0; level < levels; ++level) {
    std::map<std::pair<uint32_t, uint32_t>, uint32_t> midpoints; // shared by the two triangles of an edge
    auto midpoint = [&](uint32_t a, uint32_t b) {
      const std::pair<uint32_t, uint32_t> key{std::min(a, b), std::max(a, b)};
      auto it = midpoints.find(key);
      if (it != midpoints.end()) return it->second;
      const Vec pa{mesh.points[3 * a], mesh.points[3 * a + 1], mesh.points[3 * a + 2]};
      const Vec pb{mesh.points[3 * b], mesh.points[3 * b + 1], mesh.points[3 * b + 2]};
      const uint32_t m = addPoint(mesh, normalized(pa + pb));
      midpoints.emplace(key, m);
      return m;
    };
    std::vector<uint32_t> finer;
    finer.reserve(mesh.triangles.size() * 4);
    for (size_t f = 0; f < mesh.triangles.size(); f += 3) {
      const uint32_t a = mesh.triangles[f], b = mesh.triangles[f + 1], c = mesh.triangles[f + 2];
      const uint32_t ab = midpoint(a, b), bc = midpoint(b, c), ca = midpoint(c, a);
      finer.insert(finer.end(), {a, ab, ca, b, bc, ab, c, ca, bc, ab, bc, ca});
    }
    mesh.triangles.swap(finer);
  }
  return mesh;
}

// Torus: ring of radius 1 in the xy plane, tube radius 0.4.
TriangleMesh torus() {
  auto ring = [](double u) {
    const Vec radial{std::cos(u), std::sin(u), 0};
    return CurveSample{radial, {-std::sin(u), std::cos(u), 0}, radial};
  };
  return tube(ring, 128, 64, 0.4);
}

// Trefoil as the (2,3) torus knot on a torus of radii 1 and 0.5:
//   c(u) = ((1 + 0.5 cos 3u) cos 2u, (1 + 0.5 cos 3u) sin 2u, 0.5 sin 3u).
// Frenet frame (periodic, and the curvature never vanishes). The strands come
// no closer than 0.83 and the curvature radius stays above 0.71, so a tube of
// radius 0.3 neither touches itself nor folds.
TriangleMesh knot() {
  auto curve = [](double u) {
    const double R = 1, r = 0.5;
    const double c2 = std::cos(2 * u), s2 = std::sin(2 * u), c3 = std::cos(3 * u), s3 = std::sin(3 * u);
    const double w = R + r * c3, dw = -3 * r * s3, ddw = -9 * r * c3;
    const Vec p{w * c2, w * s2, r * s3};
    const Vec d1{dw * c2 - 2 * w * s2, dw * s2 + 2 * w * c2, 3 * r * c3};
    const Vec d2{ddw * c2 - 4 * dw * s2 - 4 * w * c2, ddw * s2 + 4 * dw * c2 - 4 * w * s2, -9 * r * s3};
    const Vec t = normalized(d1);
    const Vec b = normalized(cross(d1, d2));
    return CurveSample{p, t, cross(b, t)};
  };
  return tube(curve, 512, 40, 0.3);
}

} // namespace

std::vector<std::string> builtinMeshNames() { return {"sphere", "torus", "knot"}; }

TriangleMesh builtinMesh(const std::string& name) {
  if (name == "sphere") return icosphere(5);
  if (name == "torus") return torus();
  if (name == "knot") return knot();
  std::string names;
  for (const std::string& n : builtinMeshNames()) names += (names.empty() ? "" : ", ") + n;
  throw Error(ErrorKind::InvalidArgument, "unknown built-in mesh '" + name + "' (available: " + names + ")");
}

} // namespace hdt
