// Helpers of the CUDA driver tests: skip without a device, and compare a GPU
// volume with the CPU driver's byte for byte, saying where they first differ.
#pragma once

#include "hdt/builder.hpp"
#include "hdt/types.hpp"
#include "hdt/volume.hpp"
#include "support/reference_voxelizer.hpp" // stateName

#include <gtest/gtest.h>

#include <cstdlib>
#include <sstream>
#include <string>

// GTEST_SKIP with the reason when this machine has no usable CUDA device (CI).
#define HDT_REQUIRE_CUDA()                                                                         \
  do {                                                                                             \
    std::string why_;                                                                              \
    if (!hdt::cudaAvailable(&why_)) GTEST_SKIP() << "no CUDA device: " << why_;                    \
  } while (0)

namespace hdt {
namespace test {

inline std::string describeElement(const Volume& v, uint64_t index) {
  size_t level = 0;
  while (level + 1 < v.levelStart.size() && v.levelStart[level + 1] <= index) ++level;
  std::ostringstream os;
  const ElementWord w = v.elements[index];
  os << "level " << level << " element " << index - v.levelStart[level] << " (#" << index << "): "
     << stateName(elementState(w)) << " " << elementPayload(w);
  return os.str();
}

// Same bytes: elements, levelStart, leafWords, and the structure statistics.
inline ::testing::AssertionResult sameVolume(const Volume& gpu, const Volume& cpu) {
  if (gpu.levelStart != cpu.levelStart) {
    std::ostringstream os;
    os << "levelStart differs: gpu";
    for (uint64_t s : gpu.levelStart) os << " " << s;
    os << ", cpu";
    for (uint64_t s : cpu.levelStart) os << " " << s;
    return ::testing::AssertionFailure() << os.str();
  }
  if (gpu.elements.size() != cpu.elements.size())
    return ::testing::AssertionFailure() << "element count " << gpu.elements.size() << " vs " << cpu.elements.size();
  for (uint64_t i = 0; i < gpu.elements.size(); ++i) {
    if (gpu.elements[i] != cpu.elements[i]) {
      uint64_t count = 0;
      for (uint64_t j = i; j < gpu.elements.size(); ++j) count += gpu.elements[j] != cpu.elements[j];
      return ::testing::AssertionFailure() << count << " elements differ; first: gpu " << describeElement(gpu, i)
                                           << ", cpu " << describeElement(cpu, i);
    }
  }
  if (gpu.leafWords.size() != cpu.leafWords.size())
    return ::testing::AssertionFailure() << "leaf words " << gpu.leafWords.size() << " vs " << cpu.leafWords.size();
  const uint32_t perLeaf = leafWordCount(cpu.grid.leafSize);
  for (uint64_t i = 0; i < gpu.leafWords.size(); ++i) {
    if (gpu.leafWords[i] != cpu.leafWords[i]) {
      uint64_t count = 0;
      for (uint64_t j = i; j < gpu.leafWords.size(); ++j) count += gpu.leafWords[j] != cpu.leafWords[j];
      const int L = cpu.grid.leafSize;
      const uint64_t v = (i % perLeaf) * 16; // first voxel of the word
      std::ostringstream os;
      os << count << " leaf words differ; first: leaf " << i / perLeaf << " word " << i % perLeaf << " (voxels from ("
         << v % L << "," << (v / L) % L << "," << v / (L * L) << ")): gpu 0x" << std::hex << gpu.leafWords[i]
         << " cpu 0x" << cpu.leafWords[i];
      return ::testing::AssertionFailure() << os.str();
    }
  }
  const Statistics &a = gpu.stats, &b = cpu.stats;
#define HDT_SAME_STAT(f)                                                                           \
  if (a.f != b.f) return ::testing::AssertionFailure() << "statistic " #f ": gpu " << a.f << " cpu " << b.f;
  HDT_SAME_STAT(triangles)
  HDT_SAME_STAT(degenerateTriangles)
  HDT_SAME_STAT(treeElements)
  HDT_SAME_STAT(leafGrids)
  HDT_SAME_STAT(leafVoxels)
  HDT_SAME_STAT(activeVoxels)
  HDT_SAME_STAT(insideVoxels)
  HDT_SAME_STAT(paperBitsPerActiveVoxel)
  HDT_SAME_STAT(topologyBytes)
  HDT_SAME_STAT(leafBytes)
#undef HDT_SAME_STAT
  if (gpu.surfaceOnly != cpu.surfaceOnly || gpu.closedMesh != cpu.closedMesh)
    return ::testing::AssertionFailure() << "surfaceOnly/closedMesh flags differ";
  if (gpu.stats.backend != "cuda") return ::testing::AssertionFailure() << "backend " << gpu.stats.backend;
  return ::testing::AssertionSuccess();
}

inline BuildOptions cudaOptions() {
  BuildOptions o;
  o.backend = Backend::Cuda;
  return o;
}

inline BuildOptions cpuOptions() {
  BuildOptions o;
  o.backend = Backend::Cpu;
  return o;
}

} // namespace test
} // namespace hdt
