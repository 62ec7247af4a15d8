// The host side of the winding-number inside test (winding.hpp): the tree
// over the triangles, built once per build on the host and used as is by
// both drivers, and the classification of a built volume by it.
#pragma once

#include "hdt/config.hpp"
#include "hdt/default_init_allocator.hpp"
#include "hdt/huge_pages.hpp"
#include "hdt/lattice.hpp"
#include "hdt/mesh.hpp" // LatticeTriangles
#include "hdt/progress.hpp"
#include "hdt/winding.hpp"

#include <array>
#include <cstdint>
#include <functional>
#include <future>
#include <string>
#include <vector>

namespace hdt {

struct Volume;
struct PreparedMesh;

// Nodes in a fixed layout (root 0, children contiguous) and triangles in
// tree order. A function of the triangles only: median splits on exact
// integer centroid keys with the triangle index as tie-break, triangles of
// a leaf in input order.
struct WindingTree {
  // The large arrays are sized, then written in parallel (first touch
  // there, on huge pages: fewer page faults), the nodes by the subtrees'
  // fills, each once, instead of zeroed by one thread before.
  template <class T> using PerTriangle = std::vector<T, HugePageScratchAllocator<T>>;
  PerTriangle<WindingNode> nodes;
  PerTriangle<WindingTriangle> triangles;
  std::vector<WindingEdge> edges;           // the boundary 1-chain, in groups
  std::vector<WindingEdgeGroup> edgeGroups; // of kWindingEdgeGroup consecutive edges
  PerTriangle<LatticeTriangle> lattice;     // the triangles in tree order, exact
  WindingTreeView view() const {
    return {nodes.data(),      triangles.data(), uint32_t(triangles.size()), edges.data(), edgeGroups.data(),
            uint32_t(edgeGroups.size()), lattice.data(), uint32_t(edges.size())};
  }
};

WindingTree buildWindingTree(const LatticeTriangles& triangles);

// FNV-1a over every byte the drivers read of a tree (nodes, triangles and
// lattice triangles in tree order, edges, edge groups; the structs have no
// padding): the tests and the benchmark pin the tree's build with it.
uint64_t windingTreeDigest(const WindingTree& tree);

constexpr uint32_t kWindingEdgeGroup = 16;

// The boundary 1-chain of the triangles (WindingEdge), sorted by the Morton
// key of the edges' midpoints (ties by corners) and cut into groups: a
// function of the triangles only.
void buildWindingEdges(const LatticeTriangles& triangles, WindingTree& tree);

// The test a build runs: Auto is Parity for closed meshes, WindingNumber for
// open ones; Parity and WindingNumber are taken as asked.
InsideTest resolveInsideTest(InsideTest requested, bool closedMesh);
const char* insideTestName(InsideTest test); // "auto", "parity", "winding"
// Why the test ran, one sentence: "Auto: the mesh is open", ...
std::string insideTestReason(InsideTest requested, InsideTest ran, bool closedMesh);

// What the classification met: uniform elements whose voxel centres lie on
// both sides of w = 1/2 (no triangle meets them, but the w = 1/2 surface
// spanning a hole does). Each is refined: a Branch of 8 children, or at the
// last level a Boundary with a leaf grid of decided voxels and no surface.
struct WindingOutcome {
  uint64_t refinedElements = 0;
};

// Rewrites the inside plane of every leaf word and the state of every uniform
// element of a solid volume from the winding number of the voxel centres,
// refining the elements that w = 1/2 crosses (then the tree is re-laid in
// canonical level order and the leaf grids copied once).
// Parallel (oneTBB) over leaves and elements; the result does not depend on
// the thread count.
WindingOutcome classifyByWindingNumber(const WindingTree& tree, Volume& volume);

// A leaf pass run elsewhere (the CUDA driver's, cuda/src/winding_device.hpp):
// decides the leaves at `origins` (leaf i's low corner, voxels) in
// volume.leafWords exactly like the host's pass and lists the leaves it left
// (counts that do not fit 16 bits), which the host then decides. Returns
// false when it could not run (device memory, ...): the host pass runs.
using WindingLeafPass = std::function<bool(const WindingTree& tree, Volume& volume,
                                           const std::vector<std::array<int, 3>>& origins,
                                           std::vector<uint32_t>& leftLeaves)>;
// A uniform element to decide elsewhere, and the pass that decides a list
// of them: verdicts[i] = bit 0 inside, bit 1 split (w = 1/2 crosses it),
// exactly classifyUniform's answer (core/src/winding.cpp). False when it could
// not run: the host decides them.
struct WindingUniformJob {
  uint64_t index; // into Volume::elements
  std::array<int, 3> origin;
  int edge;
};
using WindingUniformPass = std::function<bool(const WindingTree& tree, const std::vector<WindingUniformJob>& jobs,
                                              std::vector<uint8_t>& verdicts)>;
// The leaves that refinement creates (no surface voxel) decided elsewhere:
// words holds origins.size() leaves of zero words on entry, each decided
// leaf's inside plane on return; leftLeaves lists those it did not decide
// (the host then does). False when it could not run.
using WindingFreshLeafPass = std::function<bool(const WindingTree& tree, int L,
                                                const std::vector<std::array<int, 3>>& origins, uint32_t* words,
                                                std::vector<uint32_t>& leftLeaves)>;
// progress: the build's poll, or null. The pass reports its share of the
// build through it (phase "inside test: winding number"), polls it inside its
// loops and throws Error(Aborted) when the caller asked to stop.
WindingOutcome classifyByWindingNumber(const WindingTree& tree, Volume& volume, const WindingLeafPass& leafPass,
                                       const WindingUniformPass& uniformPass = WindingUniformPass(),
                                       const WindingFreshLeafPass& freshPass = WindingFreshLeafPass(),
                                       ProgressPoll* progress = nullptr);

// The drivers' last step of a solid build: when the mesh's test is
// WindingNumber, builds the tree and classifies the volume by it (the parity
// classification it replaces may have run or not); records the test that ran
// in volume.insideTest and the refined elements in its statistics. Returns the
// milliseconds spent (0 under Parity). Call before the statistics are computed.
//
// The tree depends on the triangles alone: a driver with device work to do
// first starts it early (WindingTreeInBackground) and hands it over here.
class WindingTreeInBackground;
double applyInsideTest(const PreparedMesh& mesh, Volume& volume);
double applyInsideTest(const PreparedMesh& mesh, Volume& volume, const WindingLeafPass& leafPass,
                        const WindingUniformPass& uniformPass = WindingUniformPass(),
                        const WindingFreshLeafPass& freshPass = WindingFreshLeafPass(),
                        WindingTreeInBackground* early = nullptr, ProgressPoll* progress = nullptr);

// applyInsideTest on the host over a volume the CPU phases built (the CPU
// driver, or a process that joined the ranks' surfaces), the pass reporting
// to `progress` (BuildOptions::progress, may be empty) the part of the build
// after those phases (kCpuPhasesShareBeforeWinding on) and then "done".
double applyInsideTestAfterCpuPhases(const PreparedMesh& mesh, Volume& volume, const ProgressPoll::Callback& progress);

// The winding tree of a mesh whose inside test is WindingNumber (solid),
// built on a host thread from construction on, so that it overlaps a
// driver's device work; nothing for other meshes. get() waits for it (and
// rethrows what the build threw); the destructor waits too, so the mesh
// must outlive this object.
class WindingTreeInBackground {
public:
  explicit WindingTreeInBackground(const PreparedMesh& mesh);
  bool started() const { return future_.valid() || ready_; }
  const WindingTree& get();

private:
  std::future<WindingTree> future_;
  WindingTree tree_;
  bool ready_ = false;
};

} // namespace hdt
