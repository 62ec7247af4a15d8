// What a build spread over processes sends between them, and the pieces a
// process keeps: host only, VTK-free and MPI-free (the transport is the
// caller's: the VTK modules use ParaView's controller, the CLI MPI directly).
//
// A distributed build (docs/design.md, "run a build as ranges in several
// processes") gives each process one range of root cells (root_ranges.hpp,
// planRootRanges with align = R). The processes exchange their RangeBoundary
// (packBoundary) between the two stages of CpuRangeBuild; afterwards each
// holds its RangeTree. A process shows its range as a "piece volume": the
// whole root grid where the cells of other processes are Empty placeholders
// (pieceVolume), and a file writer joins the ranges' trees (packRangeLevels
// and PlacedGather, the leaf words sent straight into place). sliceVolume cuts a range out of a whole volume (the reader's
// share of a file, a driver that built everything).
#pragma once

#include "hdt/root_ranges.hpp"
#include "hdt/volume.hpp"

#include <cstdint>
#include <vector>

namespace hdt {

struct PreparedMesh;

// Byte buffers between processes of one job (same machine byte order). The
// unpackers check sizes and throw Error(BadInput) on a damaged buffer.
std::vector<uint8_t> packBoundary(const RangeBoundary& boundary, int rowWords);
RangeBoundary unpackBoundary(const uint8_t* data, size_t size, int rowWords);

// Levels and leaf words (no leaf coordinates: the join does not need them).
std::vector<uint8_t> packRangeTree(const RangeTree& tree);
RangeTree unpackRangeTree(const uint8_t* data, size_t size, const GridSpec& grid);

// A range's levels alone (its leaf words travel on their own, straight into
// their place: PlacedGather). The unpacker checks the grid's level count.
std::vector<uint8_t> packRangeLevels(const RangeTree& tree);
RangeTree unpackRangeLevels(const uint8_t* data, size_t size, const GridSpec& grid);

// The gathering process's side of joining every range into one volume with
// no pass over the leaves after they arrive: the joined leaf words are
// allocated once (unwritten, advised for huge pages, faulted in by all cores
// of the calling oneTBB arena), each range's words are received (or, for the
// process's own range, copied in parallel) into their place, and join() only
// renumbers the levels. The transport is the caller's.
class PlacedGather {
public:
  // Every range's leaf-word count, in range (root-cell) order. Throws
  // Error(BadInput) when a count is not whole leaves or the sum overflows.
  PlacedGather(const GridSpec& grid, const std::vector<uint64_t>& leafWordCounts);

  // Where range r's leaf words go, and how many.
  uint32_t* wordsOf(size_t r);
  uint64_t wordCountOf(size_t r) const { return start_.at(r + 1) - start_.at(r); }

  // Range r's levels; its leaf words must be in wordsOf(r) by join().
  void addLevels(size_t r, RangeTree&& levels);
  // The gathering process's own range, leaf words included (copied into place).
  void addOwn(size_t r, RangeTree&& own);

  // The joined volume (joinRanges: checks each range's leaves against its
  // Boundary elements). Throws Error(InvalidArgument) when a range is missing.
  // Flags and statistics are left to the caller.
  Volume join();

private:
  GridSpec grid_;
  std::vector<uint64_t> start_; // range r's words: [start_[r], start_[r + 1])
  std::vector<RangeTree> ranges_;
  std::vector<bool> added_;
  LeafWordVector words_;
};

// The piece of `cells` of a volume (or of a range's tree that holds
// `cells`), with range-local payloads as a build of that range gives them.
// Throws Error(InvalidArgument) when `cells` is not inside the source.
RangeTree sliceVolume(const Volume& volume, RootRange cells);
RangeTree sliceRangeTree(const GridSpec& grid, const RangeTree& tree, RootRange cells);

// The volume of the whole root grid made of the given ranges (in root-cell
// order, not overlapping); root cells no range covers are Empty. Flags and
// statistics are left to the caller.
Volume pieceVolume(const GridSpec& grid, std::vector<RangeTree>&& ranges);

// The structural statistics of a range's piece (what computeStructureStatistics
// gives, restricted to the range): they add up over ranges (addStructure)
// to the whole volume's; finishStructure then derives the paper's bits.
Statistics rangeStructure(const GridSpec& grid, const RangeTree& tree);
void addStructure(Statistics& sum, const Statistics& part);
void finishStructure(Statistics& s);

// The structural statistics as numbers, for a sum over processes.
constexpr int kStructureFields = 6;
void structureToArray(const Statistics& s, uint64_t out[kStructureFields]);
void structureFromArray(const uint64_t in[kStructureFields], Statistics& s);

} // namespace hdt
