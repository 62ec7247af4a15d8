// Procedural test meshes: indexed (shared vertices), consistently oriented
// (outward normals, counter-clockwise seen from outside), generated in code so
// the unit tests never depend on files.
//
// Two placement styles:
//   * free shapes are placed by the library from their bounding box (voxel
//     size = longest extent / (N - 2), centred);
//   * lattice shapes come with explicit bounds [-B, B]^3, B = (N - 2) / 2,
//     which makes the voxel size exactly 1 and the grid origin exactly -N/2.
//     In that "unit-voxel frame" voxel i spans [i - N/2, i + 1 - N/2], so
//     integer coordinates are voxel planes and half-integers voxel centres,
//     and the snapped lattice coordinates are exact (multiples of 256 or
//     256 k + 128). That is how the tie cases are built on purpose.
#pragma once

#include "hdt/config.hpp"
#include "hdt/mesh.hpp"
#include "hdt/volume.hpp"

#include <array>
#include <functional>
#include <ostream>
#include <string>
#include <vector>

namespace hdt {
namespace test {

using Vec3 = std::array<double, 3>;
using Mat3 = std::array<Vec3, 3>; // rows

// ---- primitives ---------------------------------------------------------------

// Icosahedron subdivided `subdivisions` times, projected onto the sphere.
TriangleMesh icosphere(int subdivisions, double radius, const Vec3& centre = {0, 0, 0});

// Upper half (z >= centre z) of a UV sphere; open along the rim.
TriangleMesh uvHemisphere(int rings, int segments, double radius, const Vec3& centre = {0, 0, 0});

// Torus around the z axis: major radius R, tube radius r.
TriangleMesh torus(double majorRadius, double minorRadius, int majorSegments, int minorSegments,
                   const Vec3& centre = {0, 0, 0});

// Axis-aligned box [lo, hi], 8 points, 12 triangles.
TriangleMesh box(const Vec3& lo, const Vec3& hi);

// Octahedron with vertices centre +- radius along each axis.
TriangleMesh octahedron(const Vec3& centre, double radius);

// ---- operations -----------------------------------------------------------------

void append(TriangleMesh& to, const TriangleMesh& from);
void flipOrientation(TriangleMesh& mesh);
// p -> rotation * (p - pivot) + pivot + translation
void transform(TriangleMesh& mesh, const Mat3& rotation, const Vec3& pivot = {0, 0, 0},
               const Vec3& translation = {0, 0, 0});
Mat3 rotationXYZ(double ax, double ay, double az); // Rz(az) * Ry(ay) * Rx(ax), radians
// Signed volume by the divergence theorem: positive for a closed, outward mesh.
double signedVolume(const TriangleMesh& mesh);

// ---- unit-voxel frame (explicit bounds, voxel size 1) -----------------------------
double voxelPlane(int resolution, int i);  // coordinate of the plane between voxels i - 1 and i
double voxelCentre(int resolution, int i); // coordinate of the centre of voxel i

// ---- named test shapes ------------------------------------------------------------

struct Shape {
  std::string name;
  TriangleMesh mesh;
  bool expectClosed = true;           // PreparedMesh::closed must come out like this
  size_t expectedDegenerate = 0;      // PreparedMesh::degenerateTriangles
  bool hasBounds = false;             // unit-voxel frame: explicit bounds
  Vec3 boundsMin{0, 0, 0}, boundsMax{0, 0, 0};
  // Every snapped coordinate must be 256 k (voxel plane) / 256 k + 128 (voxel
  // centre): checked by the shape sanity test, so the tie cases stay ties.
  enum class LatticeCheck { None, VoxelPlanes, VoxelCentres } latticeCheck = LatticeCheck::None;

  BuildConfig config(int resolution, int rootGrid, int leafSize, bool surfaceOnly) const;
};

// Shape factories: some shapes depend on N (those in the unit-voxel frame).
struct ShapeFactory {
  std::string name;
  std::function<Shape(int resolution)> make;
};

// The shapes the reference comparison runs, in a fixed order.
const std::vector<ShapeFactory>& standardShapes();
Shape makeShape(const std::string& name, int resolution); // throws std::out_of_range

// Individual shapes (resolution only matters for the unit-voxel-frame ones).
Shape sphereShape();
Shape torusShape();
Shape gridAlignedBoxShape(int resolution);   // faces on voxel planes, some on leaf planes
Shape centreBoxShape(int resolution);        // corners on voxel centres: faces through centres
Shape centreOpenBoxShape(int resolution);    // centre box without its +z face: open
Shape centreOctahedronShape(int resolution); // vertices on voxel centres
Shape centreSnappedSphereShape(int resolution); // icosphere, vertices rounded to voxel centres
Shape openTiePlatesShape(int resolution);    // open: rays through plate edges decide the vote
Shape rotatedCubeShape();
Shape thinPlateShape(int resolution);        // axis-aligned, 0.3 voxel thick, straddles a centre plane
Shape tiltedThinPlateShape(int resolution);  // 0.3 voxel thick, tilted 10 degrees about x
Shape twoBodiesShape();                      // sphere + torus, disjoint
Shape hollowSphereShape();                   // outer shell + inward inner shell
Shape openHemisphereShape();                 // open mesh
Shape singleTriangleShape();                 // open mesh
Shape degenerateMixShape(int resolution);    // a closed sphere plus 5 degenerate triangles

// ---- parameterised tests over shapes ------------------------------------------------

// One build of a named shape: N, R, L and the mode.
struct ShapeCase {
  std::string shape;
  int n, r, l;
  bool surfaceOnly;
};
void PrintTo(const ShapeCase& c, std::ostream* os);        // GoogleTest's parameter text
std::string shapeCaseName(const ShapeCase& c);             // a test name: sphere_N128_R4_L8_solid
PreparedMesh prepareShapeCase(const ShapeCase& c);         // the shape, prepared for its N, R, L, mode

// Where two volumes first differ (levels, elements, leaf words, structural
// statistics), or "" when they are the same bytes.
std::string firstDifference(const Volume& a, const Volume& b);

} // namespace test
} // namespace hdt
