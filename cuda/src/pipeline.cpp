#include "pipeline.hpp"

#include "host_copy.hpp"
#include "voxel_counts.hpp"

#include "hdt/error.hpp"

#include <chrono>
#include <string>

namespace hdt {
namespace cuda {
namespace {

int axesFor(const PreparedMesh& mesh) { return mesh.closed ? 1 : 3; }

// Into pageable memory (the Volume's vectors) through the pinned ring of
// host_copy.cpp, after the work queued before it: the wait for that work is
// not copy-back time, the copy itself is (Session::copyBackMs).
template <class T>
void download(Session& s, T* host, const DeviceBuffer<T>& d, size_t count, const CopiedPrefix& copied = {}) {
  if (count == 0) return;
  s.sync();
  const auto t0 = std::chrono::steady_clock::now();
  copyToHost(s.stream.get(), host, d.data(), count * sizeof(T), copied);
  s.copyBackMs += std::chrono::duration<double, std::milli>(std::chrono::steady_clock::now() - t0).count();
  s.copyBackBytes += count * sizeof(T);
}

template <class T>
void upload(Session& s, DeviceBuffer<T>& d, const T* host, size_t count) {
  if (count) HDT_CUDA_CHECK(cudaMemcpyAsync(d.data(), host, count * sizeof(T), cudaMemcpyHostToDevice, s.stream.get()));
}

std::function<void(int)> branchingProgress(Session& s) {
  return [&s](int level) { s.progress(0.1 + 0.3 * double(level + 1) / double(s.grid.height + 1), "branching"); };
}

// Classification buffers of `perLeaf` words a leaf for the ray axes
// [firstAxis, axes); ptr[a] is null for the others.
struct AxisBuffers {
  DeviceBuffer<uint32_t> buffer[3];
  uint32_t* ptr[3] = {nullptr, nullptr, nullptr};
  AxisBuffers(Session& s, uint32_t leaves, size_t perLeaf, int firstAxis, int axes) {
    for (int a = firstAxis; a < axes; ++a) {
      buffer[a] = DeviceBuffer<uint32_t>(s.memory, leaves * perLeaf);
      ptr[a] = buffer[a].data();
    }
  }
};

// Pass 1's row parities (exit parities after the line step), one bit a row.
AxisBuffers parityBuffers(Session& s, uint32_t leaves, int axes) {
  return AxisBuffers(s, leaves, size_t(rowWordsFor(s.grid.leafSize)), 0, axes);
}

// Pass 1's before-masks that pass 2 reads, one word a row: y and z of open
// meshes (T3 puts axis 0's in plane 0 of the leaf words).
AxisBuffers maskBuffers(Session& s, uint32_t leaves, int axes) {
  return AxisBuffers(s, leaves, size_t(s.grid.leafSize) * s.grid.leafSize, 1, axes);
}

// Pass 1 of the axes T3 did not run (y and z of open meshes), lines, pass 2
// and the uniform elements, all on the device.
void classifyWhole(Session& s, const DeviceMesh& mesh, int axes, Tree& tree, AxisBuffers& parity, uint32_t* words) {
  uint32_t* const* p = parity.ptr;
  AxisBuffers masks = maskBuffers(s, tree.leaves.count, axes);
  leafCrossings(s.memory, mesh, s.grid, tree.leaves, 1, axes, p, masks.ptr);
  LineTable tables[3];
  for (int a = 0; a < axes; ++a) {
    tables[a] = lineParity(s.memory, s.grid, tree.leaves, a, p[a]);
    s.progress(0.7 + 0.1 * double(a + 1) / axes, "classification");
  }
  const uint32_t* exitParity[3] = {p[0], p[1], p[2]};
  const uint32_t* m[3] = {masks.ptr[0], masks.ptr[1], masks.ptr[2]};
  writeLeafInside(s.memory, s.grid, tree.leaves, axes, exitParity, m, words);
  const LineTable* t[3] = {&tables[0], &tables[1], &tables[2]};
  for (size_t level = 0; level < tree.levels.size(); ++level)
    classifyUniform(s.memory, s.grid, int(level), tree.levels[level], axes, t, tree.leaves.count);
}

} // namespace

DeviceVolume buildOnDevice(Session& s, const DeviceMesh& mesh, bool closed, bool classify, RootMapping root) {
  const GridSpec& g = s.grid;
  const uint64_t cells = uint64_t(g.rootGrid) * g.rootGrid * g.rootGrid;
  s.clock.mark(kMapping);
  s.progress(0.1, "branching");
  DeviceVolume d;
  d.tree = buildTree(s.memory, s.scalars, mesh, g, 0, cells, std::move(root.pairs), true, branchingProgress(s));
  s.clock.mark(kBranching);

  s.progress(0.4, "leaf processing");
  const size_t wordCount = size_t(d.tree.leaves.count) * leafWordCount(g.leafSize);
  d.words = DeviceBuffer<uint32_t>(s.memory, wordCount);
  const int axes = closed ? 1 : 3;
  AxisBuffers parity = parityBuffers(s, d.tree.leaves.count, classify ? axes : 0);
  // Classified builds: T3 runs pass 1 along x too (its time counts as T3).
  writeLeafSurfaces(s.memory, s.scalars, mesh, g, d.tree.leaves, d.words.data(), classify, parity.ptr[0]);
  s.clock.mark(kLeaf);

  s.progress(0.7, "classification");
  if (classify) classifyWhole(s, mesh, axes, d.tree, parity, d.words.data());
  s.clock.mark(kClassify);
  return d;
}

Volume buildWhole(Session& s, RootMapping root, bool keepResult, DeviceBuffer<uint32_t>* deviceLeafWords) {
  const GridSpec& g = s.grid;
  DeviceVolume d = buildOnDevice(s, s.deviceMesh, s.mesh.closed, s.parityClassification(), std::move(root));
  const Tree& tree = d.tree;
  const DeviceBuffer<uint32_t>& words = d.words;
  const size_t wordCount = words.size();

  Volume v;
  const SinkAbandonGuard abandonOnError(s.options.leafSink);
  v.grid = g;
  v.surfaceOnly = s.mesh.surfaceOnly;
  v.closedMesh = s.mesh.closed;
  if (!keepResult) {
    s.sync();
    s.clock.collect(s.ms);
    return v;
  }
  uint64_t total = 0;
  for (const Level& lv : tree.levels) {
    v.levelStart.push_back(total);
    total += lv.count;
  }
  v.levelStart.push_back(total);
  v.elements.resize(total);
  // The statistics' voxel counts, on the device while the copy back runs;
  // the winding-number pass rewrites the volume on the host, which counts it then.
  const bool countHere = s.mesh.insideTest != InsideTest::WindingNumber;
  DeviceBuffer<unsigned long long> voxelCounts(s.memory, 2); // surface, inside
  if (countHere) {
    HDT_CUDA_CHECK(cudaMemsetAsync(voxelCounts.data(), 0, voxelCounts.bytes(), s.stream.get()));
    for (size_t k = 0; k < tree.levels.size(); ++k) {
      const uint64_t edge = uint64_t(g.elementVoxels(int(k)));
      countFullVoxels(s.stream.get(), tree.levels[k].words.data(), tree.levels[k].count, edge * edge * edge,
                      voxelCounts.data());
    }
    countLeafVoxels(s.stream.get(), words.data(), wordCount, voxelCounts.data());
  }
  for (size_t k = 0; k < tree.levels.size(); ++k)
    download(s, v.elements.data() + v.levelStart[k], tree.levels[k].words, tree.levels[k].count);
  v.leafWords.resize(wordCount);
  // The leaf grids' consumer (the .hdt writer's zstd blocks) starts on each
  // piece as it lands, unless the host rewrites them (the winding number).
  LeafArrivalSink* sink = s.mesh.insideTest == InsideTest::WindingNumber ? nullptr : s.options.leafSink;
  CopiedPrefix copied;
  if (sink) {
    sink->begin(v.leafWords.data(), wordCount);
    copied = [sink](size_t bytes) { sink->arrived(bytes / sizeof(uint32_t)); };
  }
  if (deviceLeafWords) {
    *deviceLeafWords = std::move(d.words); // the winding leaf pass's input, in place
  } else {
    download(s, v.leafWords.data(), words, wordCount, copied);
  }
  if (sink && wordCount == 0) sink->arrived(0);
  if (countHere) {
    unsigned long long counts[2] = {0, 0};
    download(s, counts, voxelCounts, 2);
    computeStructureStatistics(v, counts[0], counts[1]);
  }
  s.clock.mark(kDownload);
  s.sync();
  s.clock.collect(s.ms);
  return v;
}

void copyLeafWordsBack(Session& s, Volume& v, const DeviceBuffer<uint32_t>& words) {
  download(s, v.leafWords.data(), words, words.size());
}

namespace {

// T1 and T2 of the root cells [firstCell, endCell), timed: both chunk phases
// start from the same tree (phase B rebuilds it rather than keeping it).
Tree buildChunkStructure(Session& s, uint64_t firstCell, uint64_t endCell) {
  s.clock.start();
  RootMapping root = mapTrianglesToRootCells(s.memory, s.scalars, s.deviceMesh, s.grid, firstCell, endCell, false);
  s.clock.mark(kMapping);
  Tree tree = buildTree(s.memory, s.scalars, s.deviceMesh, s.grid, firstCell, endCell, std::move(root.pairs), false, {});
  s.clock.mark(kBranching);
  return tree;
}

} // namespace

ChunkTree buildChunkTree(Session& s, uint64_t firstCell, uint64_t endCell) {
  const GridSpec& g = s.grid;
  Tree tree = buildChunkStructure(s, firstCell, endCell);

  ChunkTree out;
  const uint32_t leaves = tree.leaves.count;
  const size_t wordCount = size_t(leaves) * leafWordCount(g.leafSize);
  if (!s.parityClassification()) {
    // Phase B writes the leaf grids straight into the volume (one host
    // copy, no chunk-sized staging on the host); their room is reserved here
    // as for classified builds.
    Reservation room(s.memory, wordCount * sizeof(uint32_t));
  } else {
    // Phase B allocates the leaf grids and the open-mesh masks for real.
    const int axes = axesFor(s.mesh);
    Reservation room(s.memory, (wordCount + size_t(axes - 1) * leaves * g.leafSize * g.leafSize) * sizeof(uint32_t));
    const size_t rowWords = size_t(rowWordsFor(g.leafSize));
    AxisBuffers parity = parityBuffers(s, leaves, axes);
    uint32_t* const noMasks[3] = {nullptr, nullptr, nullptr};
    leafCrossings(s.memory, s.deviceMesh, g, tree.leaves, 0, axes, parity.ptr, noMasks);
    s.clock.mark(kClassify);
    for (int a = 0; a < axes; ++a) {
      out.parity[a].resize(leaves * rowWords);
      download(s, out.parity[a].data(), parity.buffer[a], leaves * rowWords);
    }
  }
  out.leafCoord.resize(leaves);
  download(s, out.leafCoord.data(), tree.leaves.coord, leaves);
  out.levelWords.resize(tree.levels.size());
  for (size_t k = 0; k < tree.levels.size(); ++k) {
    out.levelWords[k].resize(tree.levels[k].count);
    download(s, out.levelWords[k].data(), tree.levels[k].words, tree.levels[k].count);
  }
  s.clock.mark(kDownload);
  s.sync();
  s.clock.collect(s.ms);
  return out;
}

namespace {

// Pass 2 of a chunk's leaves with the exit parity joined over all chunks.
void classifyChunkLeaves(Session& s, Tree& tree, const uint32_t* const exitParity[3], uint32_t* words) {
  const GridSpec& g = s.grid;
  const uint32_t leafCount = tree.leaves.count;
  const int axes = axesFor(s.mesh);
  const size_t rowWords = size_t(rowWordsFor(g.leafSize));
  AxisBuffers exitBuf = parityBuffers(s, leafCount, axes);
  for (int a = 0; a < axes; ++a) upload(s, exitBuf.buffer[a], exitParity[a], leafCount * rowWords);
  s.clock.mark(kUpload);
  AxisBuffers masks = maskBuffers(s, leafCount, axes);
  uint32_t* const noParity[3] = {nullptr, nullptr, nullptr};
  leafCrossings(s.memory, s.deviceMesh, g, tree.leaves, 1, axes, noParity, masks.ptr);
  const uint32_t* e[3] = {exitBuf.ptr[0], exitBuf.ptr[1], exitBuf.ptr[2]};
  const uint32_t* m[3] = {masks.ptr[0], masks.ptr[1], masks.ptr[2]};
  writeLeafInside(s.memory, g, tree.leaves, axes, e, m, words);
  s.clock.mark(kClassify);
}

} // namespace

void buildChunkLeaves(Session& s, uint64_t firstCell, uint64_t endCell, uint32_t leafCount,
                      const uint32_t* const exitParity[3], uint32_t* leafWords) {
  const GridSpec& g = s.grid;
  Tree tree = buildChunkStructure(s, firstCell, endCell);
  if (tree.leaves.count != leafCount) {
    throw Error(ErrorKind::OutOfResources, "CUDA driver: chunk rebuilt with " + std::to_string(tree.leaves.count) +
                                               " leaves instead of " + std::to_string(leafCount));
  }
  const size_t wordCount = size_t(leafCount) * leafWordCount(g.leafSize);
  DeviceBuffer<uint32_t> words(s.memory, wordCount);
  // Classified builds: pass 1 along x with T3 (the parities came from phase A).
  const bool classify = s.parityClassification();
  writeLeafSurfaces(s.memory, s.scalars, s.deviceMesh, g, tree.leaves, words.data(), classify, nullptr);
  s.clock.mark(kLeaf);
  if (classify) classifyChunkLeaves(s, tree, exitParity, words.data());
  download(s, leafWords, words, wordCount);
  s.clock.mark(kDownload);
  s.sync();
  s.clock.collect(s.ms);
}

} // namespace cuda
} // namespace hdt
