// Warm pages (warm_pages.hpp): large arrays of the huge-page and default-init
// allocators take reserved memory where it fits and give it back when freed
// (free ranges merged again), nothing else changes: contents survive growth,
// prepareMesh gives the same bytes, trimWarmPages unmaps what no array holds,
// and a large array that fits nowhere does not leave an unused reservation
// resident beside it.
#include "hdt/huge_pages.hpp"
#include "hdt/mesh.hpp"
#include "hdt/volume.hpp"
#include "hdt/warm_pages.hpp"
#include "support/shapes.hpp"

#include <gtest/gtest.h>
#include <tbb/task_arena.h>

#include <chrono>
#include <cstdint>
#include <ctime>
#include <cstring>
#include <numeric>
#include <thread>
#include <vector>

namespace hdt {
namespace test {
namespace {

constexpr size_t kMiB = size_t(1) << 20;

// Every test starts and ends with nothing reserved (the pool is process-wide).
class WarmPages : public ::testing::Test {
protected:
  void SetUp() override {
    trimWarmPages();
    ASSERT_EQ(warmPagesState().reserved, 0u);
  }
  void TearDown() override {
    trimWarmPages();
    EXPECT_EQ(warmPagesState().reserved, 0u);
  }
};

TEST_F(WarmPages, LargeArraysTakeAndGiveBackReservedMemory) {
  reserveWarmPages(16 * kMiB);
  const WarmPagesState start = warmPagesState();
  ASSERT_EQ(start.reserved, 16 * kMiB);
  ASSERT_EQ(start.free, 16 * kMiB);
  {
    LeafWordVector words(kMiB); // 4 MiB
    std::vector<int32_t, HugePageScratchAllocator<int32_t>> scratch(kMiB / 2); // 2 MiB
    EXPECT_EQ(warmPagesState().free, 10 * kMiB);
    std::vector<uint8_t, HugePageScratchAllocator<uint8_t>> small(1000); // below the pool's minimum
    EXPECT_EQ(warmPagesState().free, 10 * kMiB);
    LeafWordVector tooLarge(8 * kMiB); // 32 MiB: fits nowhere, allocated as before
    EXPECT_EQ(warmPagesState().free, 10 * kMiB);
    // Written through, the arrays hold what they were given.
    std::iota(words.begin(), words.end(), 7u);
    std::iota(scratch.begin(), scratch.end(), -3);
    EXPECT_EQ(words[12345], 7u + 12345);
    EXPECT_EQ(scratch.back(), int32_t(kMiB / 2) - 4);
  }
  // Freed in another order than taken: the free ranges merge into one.
  EXPECT_EQ(warmPagesState().free, 16 * kMiB);
  LeafWordVector whole(4 * kMiB); // the whole reservation again
  EXPECT_EQ(warmPagesState().free, 0u);
  whole = LeafWordVector();
  EXPECT_EQ(warmPagesState().free, 16 * kMiB);
}

TEST_F(WarmPages, GrowingVectorsKeepTheirContents) {
  reserveWarmPages(8 * kMiB);
  std::vector<uint64_t, HugePageAllocator<uint64_t>> v;
  for (uint64_t i = 0; i < kMiB / 4; ++i) v.push_back(i * 3); // reallocates through pool sizes
  for (uint64_t i = 0; i < v.size(); i += 997) ASSERT_EQ(v[i], i * 3);
  EXPECT_LT(warmPagesState().free, 8 * kMiB);
  v = std::vector<uint64_t, HugePageAllocator<uint64_t>>(); // frees (an assignment of {} would keep the capacity)
  EXPECT_EQ(warmPagesState().free, 8 * kMiB);
}

TEST_F(WarmPages, TrimUnmapsWhatNoArrayHolds) {
  reserveWarmPages(4 * kMiB);
  reserveWarmPages(6 * kMiB);
  EXPECT_EQ(warmPagesState().reserved, 10 * kMiB);
  LeafWordVector held(kMiB / 4); // 1 MiB of the first region that fits
  trimWarmPages();               // the other region goes; the held one stays, its free pages dropped
  const WarmPagesState s = warmPagesState();
  EXPECT_GE(s.reserved, 4 * kMiB);
  EXPECT_LE(s.reserved, 6 * kMiB);
  std::iota(held.begin(), held.end(), 1u);
  EXPECT_EQ(held.back(), kMiB / 4);
}

TEST_F(WarmPages, AnArrayThatFitsNowhereDropsUnusedReservations) {
  reserveWarmPages(4 * kMiB);
  LeafWordVector large(32 * kMiB); // 128 MiB: fresh memory, and the unused 4 MiB go
  EXPECT_EQ(warmPagesState().reserved, 0u);
}

TEST_F(WarmPages, PrepareMeshGivesTheSameBytes) {
  const TriangleMesh mesh = icosphere(5, 1.0); // 20480 triangles
  BuildConfig config;
  config.resolution = 1024;
  const PreparedMesh cold = prepareMesh(mesh, config);
  reserveWarmPages(prepareMeshWarmBytes(mesh.triangleCount(), mesh.pointCount()));
  const size_t reserved = warmPagesState().reserved;
  const PreparedMesh warm = prepareMesh(mesh, config);
  // The lattice triangles live in the reservation; the scratch went back.
  EXPECT_EQ(warmPagesState().free, reserved - detail::warmRounded(warm.triangles.size() * sizeof(LatticeTriangle)));
  ASSERT_EQ(warm.triangles.size(), cold.triangles.size());
  EXPECT_EQ(std::memcmp(warm.triangles.data(), cold.triangles.data(), cold.triangles.size() * sizeof(LatticeTriangle)), 0);
  EXPECT_EQ(warm.closed, cold.closed);
  EXPECT_EQ(warm.duplicateTriangles, cold.duplicateTriangles);
}

bool sameTriangles(const PreparedMesh& a, const PreparedMesh& b) {
  return a.triangles.size() == b.triangles.size() &&
         std::memcmp(a.triangles.data(), b.triangles.data(), a.triangles.size() * sizeof(LatticeTriangle)) == 0 &&
         a.closed == b.closed && a.duplicateTriangles == b.duplicateTriangles;
}

// prepareMesh runs in the arena startHostThreads fills, whichever thread
// started it; a caller in a one-thread arena runs it there instead. The
// same preparation every way.
TEST_F(WarmPages, PrepareMeshGivesTheSameBytesInEveryArena) {
  const TriangleMesh mesh = icosphere(5, 1.0); // 20480 triangles: several blocks a pass
  BuildConfig config;
  config.resolution = 1024;
  const PreparedMesh first = prepareMesh(mesh, config);
  std::thread([] { startHostThreads(); }).join();
  const PreparedMesh afterStart = prepareMesh(mesh, config);
  PreparedMesh single;
  tbb::task_arena one(1);
  one.execute([&] { single = prepareMesh(mesh, config); });
  EXPECT_TRUE(sameTriangles(first, afterStart));
  EXPECT_TRUE(sameTriangles(first, single));
  EXPECT_EQ(first.triangles.size(), mesh.triangleCount());
}

double processCpuMs() {
  timespec t{};
  clock_gettime(CLOCK_PROCESS_CPUTIME_ID, &t);
  return double(t.tv_sec) * 1e3 + double(t.tv_nsec) * 1e-6;
}

// keepHostThreadsAwake's workers spin until prepareMesh comes (a minute at
// most here): it gives the same bytes, and afterwards the process uses no CPU
// time while this thread sleeps (spinning workers would use a core each).
TEST_F(WarmPages, WorkersKeptAwakeStopAtPrepareMesh) {
  const TriangleMesh mesh = icosphere(5, 1.0);
  BuildConfig config;
  config.resolution = 1024;
  const PreparedMesh first = prepareMesh(mesh, config);
  startHostThreads();
  keepHostThreadsAwake(60000);
  const PreparedMesh awake = prepareMesh(mesh, config);
  EXPECT_TRUE(sameTriangles(first, awake));
  std::this_thread::sleep_for(std::chrono::milliseconds(20)); // the spinning tasks see the flag down
  const double before = processCpuMs();
  std::this_thread::sleep_for(std::chrono::milliseconds(100));
  if (std::thread::hardware_concurrency() > 1) EXPECT_LT(processCpuMs() - before, 40.0);
}

TEST_F(WarmPages, StartHostThreadsReturns) {
  startHostThreads();
  startHostThreads(); // again, with the workers up
  SUCCEED();
}

} // namespace
} // namespace test
} // namespace hdt
