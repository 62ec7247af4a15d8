// Part labels on voxels (issue 17).
//
// A labelled build voxelizes each part (the triangles of one label) alone, on
// the grid placed around the whole mesh, with the unchanged drivers, and
// combines the part volumes (combineLabelledParts):
//   * a voxel is Surface when it is a surface voxel of any part, else Inside
//     when it is inside any part (each part classified as its own solid by the
//     volume's inside test), else Outside: the union of the parts;
//   * its label is that of the parts claiming it in its state (surface: the
//     parts whose triangles touch it; inside: the parts containing its
//     centre), one chosen by the overlap policy: the lowest label (default),
//     the highest, or the first of a priority list. Two parts sharing a face
//     thus give the face's voxels to the winner of the policy (the lowest
//     label by default).
// For parts that neither overlap nor nest, the union is exactly the
// unlabelled build of the whole mesh (same elements, same leaf words); where
// parts nest or overlap, the whole mesh's parity would cancel their common
// inside, the labelled build keeps it (each part is a solid).
// Both drivers give identical part volumes, and the combination is a fixed
// function of them, so labelled volumes are identical bytes too, whatever the
// backend and the thread count.
#pragma once

#include "hdt/builder.hpp"
#include "hdt/label_field.hpp"
#include "hdt/volume.hpp"

#include <cstdint>
#include <functional>
#include <map>
#include <string>
#include <utility>
#include <vector>

namespace hdt {

enum class OverlapPolicy : uint8_t { Lowest = 0, Highest = 1, Priority = 2 };

struct LabelOptions {
  OverlapPolicy overlap = OverlapPolicy::Lowest;
  // OverlapPolicy::Priority: earlier labels win; labels not listed come
  // after all listed ones, lowest first.
  std::vector<Label> priority;
};

// The overlap policy as a rank per label: the smallest rank wins.
class LabelRanking {
public:
  explicit LabelRanking(const LabelOptions& options);
  uint32_t rank(Label label) const { return rank_[label]; }
  Label best(Label a, Label b) const { return rank(a) <= rank(b) ? a : b; }

private:
  std::vector<uint32_t> rank_; // 65536 entries
};

// Builds a labelled volume from mesh.triangleLabels (one label >= 1 per
// triangle; throws Error(BadInput) otherwise). Labels' names are taken from
// mesh.labelNames. Progress is reported over all parts. With the CUDA
// backend (or Auto with a usable device) it runs buildLabelledCuda, else (or
// when that does not apply) it builds every part and combines them. A mesh
// of one label is built once, as an unlabelled build, and labelled by
// labelAsOnePart: the same volume without the parts' builds.
Volume voxelizeLabelled(const TriangleMesh& mesh, const BuildConfig& config, const BuildOptions& options,
                        const LabelOptions& labels = {});

// The one label of a mesh whose triangles all carry the same label >= 1;
// kOutsideLabel when they carry several, a label 0, or not one label per
// triangle (voxelizeLabelled's general path then decides, and refuses the
// bad ones).
Label onlyLabel(const TriangleMesh& mesh);

// The labelled volume of a one-part mesh from its plain build `v` (prepared
// from the mesh on the grid voxelizeLabelled places: the same config;
// without bounds, the mesh's own, which are the same), `label` >= 1 being
// its triangles' one label: what combineLabelledParts makes of that one
// part's volume, i.e. the same elements and leaf words, the label on every
// Full and Boundary element, no mixed leaf; and the label names.
// (voxelizeLabelled's one-part fast path; a caller that has the plain build
// already skips the parts.)
void labelAsOnePart(Volume& v, Label label, const std::map<Label, std::string>& names = {});

// The parts of a labelled mesh (its triangles split by label, each part's
// points renumbered in order of first use), ascending by label, each
// prepared on the grid voxelizeLabelled places; `log`: how long the split
// and the preparation took. Throws Error(BadInput) as voxelizeLabelled does.
struct LabelledParts {
  std::vector<PreparedMesh> meshes;
  std::vector<Label> labels;
  std::string log;
};
LabelledParts prepareLabelledParts(const TriangleMesh& mesh, const BuildConfig& config);

// voxelizeLabelled of a mesh whose parts were prepared beforehand
// (prepareLabelledParts with the same config), e.g. while a device gets
// ready: `whole` is the whole mesh prepared with that config (only its grid
// and triangles are read), `names` its labelNames. The same volume.
Volume voxelizeLabelled(const PreparedMesh& whole, const LabelledParts& parts,
                        const std::map<Label, std::string>& names, const BuildOptions& options,
                        const LabelOptions& labels = {});

// The CUDA driver's labelled build (cuda/src/labelled.cpp): `whole` is the
// whole mesh prepared on the parts' grid, built surface-only whatever its
// flags (only its grid and triangles are read; its tree is the union
// of theirs), parts[i] the prepared triangles of label partLabels[i]; each
// part is built on the device and combined there with the function of
// combineLabelledParts, one copy back at the end. stats.time.total is then
// the whole call as the caller waits (copy back included). Returns false,
// having set nothing, where it does not apply (a part classified by winding
// number, a part without triangles, not enough device memory for all parts
// at once, or, which one lattice rules out, part trees that are not subtrees
// of the whole's): the caller then combines per-part builds on the host.
// partsReady, when given, is called once the whole mesh's tree is built,
// before `parts` and `partLabels` are first read: the caller may prepare
// them meanwhile (it must wait for them itself too, as the call may end
// before, by an exception). Without the CUDA driver it always returns false.
bool buildLabelledCuda(const PreparedMesh& whole, const std::vector<PreparedMesh>& parts,
                       const std::vector<Label>& partLabels, const LabelOptions& labels, const BuildOptions& options,
                       Volume& out, const std::function<void()>& partsReady = {});

// The combination step on its own: `parts` are built on one grid (same
// GridSpec, surface-only flag), partLabels[i] >= 1 is the label of parts[i],
// all distinct.
Volume combineLabelledParts(const std::vector<Volume>& parts, const std::vector<Label>& partLabels,
                            const LabelOptions& options);

// Rebuilds LabelField::mixedIndex and ::mixedBlock from the element labels
// and the palettes (throws Error(InvalidArgument) when their counts disagree).
void indexMixedLeaves(Volume& volume);

// The labels of the voxels of Boundary element `element` (an indexed field).
LeafLabels leafLabels(const Volume& volume, uint64_t element);

// The compact form of one mixed leaf's voxel labels (`voxels`: L^3 labels, 0
// exactly on Outside voxels): its palette (ascending labels, unused entries
// 0; all 0 when the leaf has more than kPaletteSize labels: a wide leaf).
// `distinct` receives the number of distinct labels >= 1, counted up to
// kPaletteSize + 1.
LeafPalette paletteOfLeaf(const Label* voxels, uint32_t voxelCount, uint32_t& distinct);
// The 2-bit palette indices of a palette leaf: voxelCount / 16 words.
void packPaletteIndices(const Label* voxels, uint32_t voxelCount, const LeafPalette& palette, uint32_t* indexWords);

// Sets the mixed leaves' voxel labels (palettes, palette indices, wide
// labels, the index) of a volume whose element labels are set, from L^3
// labels per mixed leaf in leaf order (the layout of .hdt section 17, and of
// tests that write labels voxel by voxel); unpackVoxelLabels is its inverse.
void packVoxelLabels(Volume& volume, const Label* mixedLeafVoxels);
std::vector<Label> unpackVoxelLabels(const Volume& volume);

// Label of global voxel (x, y, z) (0 outside the grid or in an unlabelled
// volume). Slow: for tests and spot checks.
Label labelAt(const Volume& volume, int x, int y, int z);

// The label of a cell larger than a voxel (a refined or cut cell of the
// hyper tree grid, a coarse cell of the voxel surface): the majority label of
// the non-Outside voxels below it, ties to the lowest label, kOutsideLabel
// when all are outside. Histograms hold voxel counts of labels >= 1,
// ascending by label, so children's histograms add up to their parent's.
using LabelHistogram = std::vector<std::pair<Label, uint64_t>>;
void addToHistogram(LabelHistogram& histogram, Label label, uint64_t count);
Label majorityLabel(const LabelHistogram& histogram);
// The histogram of the cell [x, x + edge) x [y, y + edge) x [z, z + edge) of
// the grid (edge a power of two, the cell aligned to it).
LabelHistogram cellLabelHistogram(const Volume& volume, int x, int y, int z, int edge);

// Per-label figures of a labelled volume, for the labels that have a voxel
// or a name, ascending. Surface and inside voxels add up over the labels to
// Statistics::activeVoxels and ::insideVoxels.
struct LabelStatistics {
  Label label = 0;
  std::string name;
  uint64_t surfaceVoxels = 0;
  uint64_t insideVoxels = 0;
  double volume = 0;      // (inside + surface voxels) * s^3, mesh units cubed
  double surfaceArea = 0; // estimate: 2/3 * surface voxels * s^2 (a closed-box band of a
                          // plane of normal n holds |nx|+|ny|+|nz| voxels per s^2, 3/2 on average)
};
std::vector<LabelStatistics> labelStatistics(const Volume& volume);

// Bytes the label field takes in memory (element labels, palettes, palette
// indices, wide labels and the index).
uint64_t labelFieldBytes(const Volume& volume);

} // namespace hdt
