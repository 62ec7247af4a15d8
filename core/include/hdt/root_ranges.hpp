// Building the HDT as ranges of root cells, and joining the pieces.
//
// Why ranges of root cells work: elements are stored level by level, and
// inside a level in the order of their parents, so the level-k elements of
// the whole tree are the concatenation, in root-cell order, of the level-k
// elements of contiguous root-cell ranges. A range is built with range-local
// payloads; the join renumbers Branch payloads by the level offsets of the
// range and Boundary payloads by its first leaf.
//
// Classification is not range-local (rays leave the range), but along a
// line of rays the root-cell index grows in the ray's direction, so what lies
// beyond a range on a line is the later ranges' part of it. A build runs in
// two stages per range:
//   1. tree, leaf surfaces and classification pass 1; per axis and line of
//      leaves, the XOR of the pass-1 parities of the range's leaves on it
//      (LineParities: the range's boundary parities);
//   2. with the parity beyond the range on each line (the XOR of the later
//      ranges' boundary parities, parityBeyondRanges), pass 2 and the uniform
//      elements.
// Nothing else crosses ranges, so ranges can live in different processes:
// they exchange boundary parities between the stages and send their
// RangeTree to the join. Both drivers build a range in these two stages
// (RootRangeBuild: CpuRangeBuild, makeCudaRangeBuild; makeRangeBuild picks
// one by backend); the CUDA driver's chunked path builds its chunks as ranges.
//
// Host only; VTK-free and MPI-free.
#pragma once

#include "hdt/builder.hpp"
#include "hdt/classify_steps.hpp"
#include "hdt/volume.hpp"

#include <cstdint>
#include <functional>
#include <memory>
#include <utility>
#include <vector>

namespace hdt {

// Root cells [first, end), x fastest. May be empty.
struct RootRange {
  uint64_t first = 0, end = 0;
  uint64_t size() const { return end - first; }
  bool operator==(const RootRange& o) const { return first == o.first && end == o.end; }
};

// ---- plan ------------------------------------------------------------------------
// One root cell's share of the mesh: its T1 pairs and the area (voxel^2) of
// its triangles, each triangle's area split evenly over the cells it meets.
struct CellLoad {
  uint64_t cell;
  uint64_t pairs;
  double area;
};

// The loads of the cells that have pairs, by cell, from the T1 pairs (cellOf,
// triOf: n pairs sorted by cell, then triangle).
std::vector<CellLoad> cellLoads(const PreparedMesh& mesh, const uint32_t* cellOf, const uint32_t* triOf, size_t n);

// The loads from the mesh, by T1 on the host.
std::vector<CellLoad> cellLoads(const PreparedMesh& mesh);

// `count` contiguous ranges covering all R^3 cells, balanced by T1 pairs.
// Range boundaries fall on multiples of `align` cells: 1 for any cell, R for
// whole rows of root cells along x (then every +x ray stays in one range).
// Ranges may be empty (more ranges than rows, or no triangles).
std::vector<RootRange> planRootRanges(const std::vector<CellLoad>& loads, uint64_t cells, int count,
                                      uint64_t align = 1);

// Greedy: contiguous ranges whose cost (the sum of cost(load) of their
// cells) stays within `capacity`, a range holding at least one loaded cell.
std::vector<RootRange> planRootRangesWithin(const std::vector<CellLoad>& loads, uint64_t cells,
                                            const std::function<uint64_t(const CellLoad&)>& cost,
                                            uint64_t capacity);

// A range that did not fit, in two halves of its cells.
std::pair<RootRange, RootRange> splitRootRange(const RootRange& r);

// ---- a range's piece ----------------------------------------------------------------
// Payloads are range-local: a Branch's is the index of its first child within
// the range's next level, a Boundary's the range's leaf index.
struct RangeTree {
  RootRange cells;
  std::vector<std::vector<ElementWord>> levels; // height + 1
  std::vector<uint64_t> leafCoord;              // packed leaf coordinates (leaf units, global)
  LeafWordVector leafWords;              // leafCoord.size() * leafWordCount(L)
};

// The tree is limited to 2^30 elements (30-bit payloads): refuses a level
// whose touched elements would need children (or leaves) beyond it. levelEnd:
// index one past the level's last element. Every driver's check and message.
void checkElementLimit(uint64_t levelEnd, uint64_t touched, int level);

// The element limit over the joined ranges (before the join allocates). A
// range's leaves: leafCoord.size(), or its leaf words' when it has no coordinates.
void checkJoinedElementLimit(const GridSpec& grid, const std::vector<RangeTree>& ranges);

// Joins the ranges (in root-cell order, together covering the root grid) into
// the volume's tree and leaves: renumbered payloads, concatenated leaves.
// Checks the element limit. Sets grid, elements, levelStart, leafWords.
// `leafWords`, when given, are all the leaves already in join order (a
// driver that wrote each range's leaves in place); the ranges carry none,
// and a range's leaves are counted from its leaf coordinates when it has
// them, else from its Boundary elements.
Volume joinRanges(const GridSpec& grid, std::vector<RangeTree>&& ranges, LeafWordVector&& leafWords = {});

// Contiguous ranges' pieces (in root-cell order, at least one, with their
// leaf coordinates) as the one piece of the cells they cover together,
// payloads local to it. `leafWords` as for joinRanges.
RangeTree joinRangeTrees(std::vector<RangeTree>&& ranges, LeafWordVector&& leafWords = {});

// ---- lines of leaves ---------------------------------------------------------------
// Per line of leaves along one axis, one parity word set (rowWords words,
// one bit per leaf row), sorted by line.
struct LineParities {
  std::vector<uint64_t> line;
  std::vector<uint32_t> words;
};
struct RangeBoundary {
  LineParities axis[3];
};

// A range's leaves along one axis sorted by line (LineKeys), with the entry
// parity (row 0) of every leaf: what the uniform elements read.
struct RangeLines {
  LineKeys keys{0};
  std::vector<uint64_t> key;  // sorted
  std::vector<uint32_t> leaf; // leaf of each key
  std::vector<uint8_t> entry; // per leaf
};

// Sorts the leaves by line and turns `parity` (pass 1, rowWords a leaf) into
// the exit parity within the range, in place. With `boundary`, also records
// per line the XOR of the pass-1 parities of the range's leaves on it.
RangeLines lineParity(const GridSpec& grid, const std::vector<uint64_t>& leafCoord, int axis, uint32_t* parity,
                      LineParities* boundary);

// Per range (in root-cell order), the parity beyond it on each line: the XOR
// of the boundary parities of the ranges after it.
std::vector<RangeBoundary> parityBeyondRanges(const std::vector<RangeBoundary>& boundaries, int axes, int rowWords);

// Adds the parity beyond the range to its leaves' exit parity and entry bits.
void stitchLineParity(RangeLines& lines, const LineParities& beyond, uint32_t* exitParity, int rowWords);

// Empty -> Full for the range's uniform elements whose lowest-corner voxel
// centre is inside (classify_steps.hpp): from the range's lines, or where no
// leaf of the range lies beyond the element, the parity beyond the range.
void classifyUniformElements(const GridSpec& grid, RangeTree& tree, int axes, const RangeLines* const lines[3],
                             const RangeBoundary* beyond);

// ---- a driver on a range -----------------------------------------------------------
// One range built in the two stages; every driver gives the same boundary
// parities and the same piece (bytes), so the ranges of one build may run on
// different drivers.
class RootRangeBuild {
public:
  virtual ~RootRangeBuild() = default;
  // Stage 1: tree, surfaces, pass 1; the range's boundary parities (solid builds).
  virtual const RangeBoundary& buildTree() = 0;
  // Stage 2: classification with the parity beyond the range (null: nothing
  // beyond, as for the whole grid); returns the range's piece.
  virtual RangeTree finish(const RangeBoundary* beyond) = 0;
  virtual const PhaseTimes& times() const = 0;
  // What built it: "cpu" or "cuda", and the CUDA device (-1 for the CPU).
  virtual const char* backend() const = 0;
  virtual int device() const = 0;
  // The device memory's high-water mark and the host wall time of the copies
  // back to the host, for the per-rank report (0 where nothing ran on a device).
  virtual uint64_t peakDeviceBytes() const { return 0; }
  virtual double copyBackMs() const { return 0; }
};

class CpuRangeBuild final : public RootRangeBuild {
public:
  CpuRangeBuild(const PreparedMesh& mesh, const BuildOptions& options, RootRange cells);
  ~CpuRangeBuild() override;
  CpuRangeBuild(const CpuRangeBuild&) = delete;
  CpuRangeBuild& operator=(const CpuRangeBuild&) = delete;

  const RangeBoundary& buildTree() override;
  RangeTree finish(const RangeBoundary* beyond) override;
  const PhaseTimes& times() const override;
  const char* backend() const override { return "cpu"; }
  int device() const override { return -1; }

private:
  struct Impl;
  std::unique_ptr<Impl> impl_;
};

// The CPU driver over the given ranges (in root-cell order, covering the
// root grid), all in this process, joined: the same bytes as buildCpu.
Volume buildCpuRanges(const PreparedMesh& mesh, const BuildOptions& options, const std::vector<RootRange>& ranges);

// The CUDA driver on a range, on options.device: the root cells of the range
// only (T1, T2, leaves and pass 1 on the device in chunks that fit its
// memory; lines and uniform elements on the host; pass 2 on the device).
// Error(InvalidArgument) without a CUDA driver or device, Error(OutOfResources)
// when a root cell does not fit. Holds the device from construction to
// destruction.
std::unique_ptr<RootRangeBuild> makeCudaRangeBuild(const PreparedMesh& mesh, const BuildOptions& options,
                                                   RootRange cells);

// The range build of options.backend: Cpu, Cuda, or Auto: the CUDA driver on
// options.device when it is usable, else (or when it fails in either stage,
// other than by an abort) the CPU driver, logged through options.log.
// backend()/device() say which ran.
std::unique_ptr<RootRangeBuild> makeRangeBuild(const PreparedMesh& mesh, const BuildOptions& options,
                                               RootRange cells);

} // namespace hdt
