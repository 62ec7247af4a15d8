// The device pipeline, put together: the whole grid in one piece, or one
// chunk of root cells at a time (chunked.cpp joins the chunks).
#pragma once

#include "phases.hpp"
#include "session.hpp"

#include "hdt/builder.hpp"
#include "hdt/volume.hpp"

#include <cstdint>
#include <exception>
#include <vector>

namespace hdt {
namespace cuda {

// T2..classification of the whole grid for `mesh` (the session's or another
// on the same grid: a part of a labelled build), left on the device.
struct DeviceVolume {
  Tree tree;
  DeviceBuffer<uint32_t> words; // leaf words, leaves.count * leafWordCount(L)
};
DeviceVolume buildOnDevice(Session& s, const DeviceMesh& mesh, bool closed, bool classify, RootMapping root);

// T2..classification and the download for the whole grid, continuing from
// the root pairs of T1. Throws DeviceMemoryExhausted when it does not fit.
// keepResult = false skips the copy back (timing runs).
// Tells the build's LeafArrivalSink that the words it was given go away when
// an exception leaves the scope: declare it after the Volume whose leaf
// words it guards (it is destroyed first).
class SinkAbandonGuard {
public:
  explicit SinkAbandonGuard(LeafArrivalSink* sink) : sink_(sink), exceptions_(std::uncaught_exceptions()) {}
  ~SinkAbandonGuard() {
    if (sink_ && std::uncaught_exceptions() > exceptions_) sink_->abandon();
  }
  SinkAbandonGuard(const SinkAbandonGuard&) = delete;
  SinkAbandonGuard& operator=(const SinkAbandonGuard&) = delete;

private:
  LeafArrivalSink* const sink_;
  const int exceptions_;
};

// deviceLeafWords (a winding-number build, whose leaf pass rewrites every
// leaf's inside plane on the device): the leaf words stay on the device there
// instead of coming back (v.leafWords is sized, unwritten); the leaf pass
// reads them in place and copies the final words back once.
Volume buildWhole(Session& s, RootMapping root, bool keepResult, DeviceBuffer<uint32_t>* deviceLeafWords = nullptr);

// Copies leaf words kept on the device (buildWhole's deviceLeafWords) to
// v.leafWords: the host pass's input when the device leaf pass cannot run.
void copyLeafWordsBack(Session& s, Volume& v, const DeviceBuffer<uint32_t>& words);

// Phase A of a chunk [firstCell, endCell): its tree (chunk-local payloads),
// leaf coordinates and, for solid builds, the pass-1 row parity of its leaves
// (with room for its leaf grids reserved, so that phase B will fit).
struct ChunkTree {
  std::vector<std::vector<ElementWord>> levelWords; // per level
  std::vector<uint64_t> leafCoord;
  std::vector<uint32_t> parity[3];                  // solid: leaves * rowWords per axis
};
ChunkTree buildChunkTree(Session& s, uint64_t firstCell, uint64_t endCell);

// Phase B of a chunk: rebuilds its tree on the device (cheaper than moving
// it), writes its leaf grids (solid builds: with the exit parity the host
// joined over all chunks, exitParity[a]: the chunk's leaves * rowWords), and
// copies them to `leafWords`, their place in the volume.
void buildChunkLeaves(Session& s, uint64_t firstCell, uint64_t endCell, uint32_t leafCount,
                      const uint32_t* const exitParity[3], uint32_t* leafWords);

} // namespace cuda
} // namespace hdt
