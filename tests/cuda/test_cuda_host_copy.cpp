// The copy back through the pinned staging ring (cuda/src/host_copy.cpp):
// every byte arrives, at any host alignment and size, through rings whose
// slots are reused many times, on one host thread or several; the copied
// prefix is reported growing, in whole pieces, ending at the size.
#include "cuda_compare.hpp"

#include "host_copy.hpp"

#include <cuda_runtime.h>
#include <gtest/gtest.h>
#include <tbb/task_arena.h>

#include <cstdint>
#include <string>
#include <vector>

namespace hdt {
namespace test {
namespace {

void ok(cudaError_t e) { ASSERT_EQ(e, cudaSuccess) << cudaGetErrorString(e); }

std::vector<uint8_t> pattern(size_t bytes) {
  std::vector<uint8_t> p(bytes);
  uint32_t x = 12345;
  for (uint8_t& b : p) b = uint8_t((x = x * 1664525u + 1013904223u) >> 24);
  return p;
}

struct Prefixes {
  std::vector<size_t> seen;
  cuda::CopiedPrefix callback() {
    return [this](size_t n) { seen.push_back(n); };
  }
  void expectGrowingTo(size_t bytes, size_t piece, const std::string& what) const {
    ASSERT_FALSE(seen.empty()) << what;
    EXPECT_EQ(seen.back(), bytes) << what;
    for (size_t i = 0; i < seen.size(); ++i) {
      if (i > 0) EXPECT_GT(seen[i], seen[i - 1]) << what;
      if (seen[i] != bytes) EXPECT_EQ(seen[i] % piece, 0u) << what;
    }
  }
};

TEST(CudaHostCopy, EveryByteArrivesThroughSmallRings) {
  HDT_REQUIRE_CUDA();
  const size_t bytes = (size_t(9) << 20) + 12345; // odd: pieces and pages end mid-way
  const std::vector<uint8_t> src = pattern(bytes);
  uint8_t* device = nullptr;
  ok(cudaMalloc(reinterpret_cast<void**>(&device), bytes));
  ok(cudaMemcpy(device, src.data(), bytes, cudaMemcpyHostToDevice));
  cudaStream_t stream;
  ok(cudaStreamCreate(&stream));
  for (int slots : {1, 2, 3}) {
    for (size_t piece : {size_t(1) << 20, (size_t(3) << 20) + 4096}) {
      std::vector<uint8_t*> slot(static_cast<size_t>(slots), nullptr);
      std::vector<cudaEvent_t> arrived(static_cast<size_t>(slots));
      for (int i = 0; i < slots; ++i) {
        ok(cudaMallocHost(reinterpret_cast<void**>(&slot[size_t(i)]), piece));
        ok(cudaEventCreateWithFlags(&arrived[size_t(i)], cudaEventDisableTiming));
      }
      const cuda::StagingRing ring{slots, piece, slot.data(), arrived.data()};
      for (int threads : {1, 3, 16}) {
        for (size_t offset : {size_t(0), size_t(5)}) {
          const std::string what = std::to_string(slots) + " slots of " + std::to_string(piece) + " bytes, " +
                                   std::to_string(threads) + " threads, host offset " + std::to_string(offset);
          std::vector<uint8_t> host(bytes + offset, 0);
          Prefixes prefixes;
          tbb::task_arena arena(threads);
          arena.execute([&] { cuda::copyThroughRing(ring, stream, host.data() + offset, device, bytes, prefixes.callback()); });
          EXPECT_TRUE(std::equal(src.begin(), src.end(), host.begin() + long(offset))) << what;
          prefixes.expectGrowingTo(bytes, piece, what);
        }
      }
      for (int i = 0; i < slots; ++i) {
        ok(cudaFreeHost(slot[size_t(i)]));
        ok(cudaEventDestroy(arrived[size_t(i)]));
      }
    }
  }
  // The process-wide ring and the driver's pageable path for small copies.
  for (size_t size : {size_t(1000), bytes}) {
    std::vector<uint8_t> host(size + 3, 0);
    Prefixes prefixes;
    cuda::copyToHost(stream, host.data() + 3, device, size, prefixes.callback());
    EXPECT_TRUE(std::equal(src.begin(), src.begin() + long(size), host.begin() + 3)) << size;
    ASSERT_FALSE(prefixes.seen.empty());
    EXPECT_EQ(prefixes.seen.back(), size);
  }
  ok(cudaStreamDestroy(stream));
  ok(cudaFree(device));
}

} // namespace
} // namespace test
} // namespace hdt
