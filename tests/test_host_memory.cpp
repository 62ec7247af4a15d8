// The cgroup memory limit parsing behind availableHostBytes, against fake
// cgroup hierarchies written into a temporary directory.
#include "hdt/host_memory.hpp"

#include <gtest/gtest.h>

#include <filesystem>
#include <fstream>
#include <string>

#include "support/format_volumes.hpp"

namespace fs = std::filesystem;

namespace {

class CgroupRoom : public ::testing::Test {
protected:
  void SetUp() override {
    root_ = hdt::test::tempPath(std::string("cgroup_") +
                                ::testing::UnitTest::GetInstance()->current_test_info()->name());
    fs::remove_all(root_);
    fs::create_directories(root_);
  }
  void TearDown() override { fs::remove_all(root_); }

  // Writes `contents` to root/relative, creating the directories.
  void write(const std::string& relative, const std::string& contents) {
    const fs::path path = fs::path(root_) / relative;
    fs::create_directories(path.parent_path());
    std::ofstream(path) << contents;
  }
  uint64_t room(const std::string& procSelfCgroup) { return hdt::cgroupRoomFrom(procSelfCgroup, root_); }

  std::string root_;
};

constexpr uint64_t GiB = uint64_t(1) << 30;

TEST_F(CgroupRoom, V2MaxMeansNoLimit) {
  write("user.slice/memory.max", "max\n");
  write("user.slice/memory.current", "123456\n");
  EXPECT_EQ(room("0::/user.slice\n"), 0u);
}

TEST_F(CgroupRoom, V2LimitMinusUsage) {
  write("box/memory.max", std::to_string(8 * GiB) + "\n");
  write("box/memory.current", std::to_string(3 * GiB) + "\n");
  EXPECT_EQ(room("0::/box\n"), 5 * GiB);
}

TEST_F(CgroupRoom, V2TightestAncestorWins) {
  write("memory.max", std::to_string(64 * GiB) + "\n"); // the root cgroup
  write("memory.current", "0\n");
  write("a/memory.max", std::to_string(4 * GiB) + "\n");
  write("a/memory.current", std::to_string(1 * GiB) + "\n");
  write("a/b/memory.max", "max\n");
  write("a/b/memory.current", std::to_string(1 * GiB) + "\n");
  EXPECT_EQ(room("0::/a/b\n"), 3 * GiB);
}

TEST_F(CgroupRoom, V2OverLimitLeavesOneByte) {
  write("box/memory.max", "1000\n");
  write("box/memory.current", "5000\n");
  EXPECT_EQ(room("0::/box\n"), 1u); // 1, not 0: 0 would read as "no limit"
}

TEST_F(CgroupRoom, V1LimitMinusUsage) {
  write("memory/docker/abc/memory.limit_in_bytes", std::to_string(2 * GiB) + "\n");
  write("memory/docker/abc/memory.usage_in_bytes", std::to_string(GiB / 2) + "\n");
  EXPECT_EQ(room("12:cpu,cpuacct:/docker/abc\n11:memory:/docker/abc\n"), 2 * GiB - GiB / 2);
}

TEST_F(CgroupRoom, V1HugeLimitMeansNoLimit) {
  write("memory/memory.limit_in_bytes", "9223372036854771712\n");
  write("memory/memory.usage_in_bytes", "1000\n");
  EXPECT_EQ(room("5:memory:/\n"), 0u);
}

TEST_F(CgroupRoom, V1AndV2BothCountTheSmallerWins) {
  write("memory/job/memory.limit_in_bytes", std::to_string(6 * GiB));
  write("memory/job/memory.usage_in_bytes", "0");
  write("job/memory.max", std::to_string(2 * GiB));
  write("job/memory.current", "0");
  EXPECT_EQ(room("7:memory:/job\n0::/job\n"), 2 * GiB);
}

TEST_F(CgroupRoom, AbsentFilesMeanNoLimit) {
  EXPECT_EQ(room("0::/nowhere\n"), 0u);
  EXPECT_EQ(room("3:memory:/nowhere\n"), 0u);
  EXPECT_EQ(room(""), 0u);
  // A limit without a usage file: the usage counts as 0.
  write("box/memory.max", "4096\n");
  EXPECT_EQ(room("0::/box\n"), 4096u);
}

TEST_F(CgroupRoom, GarbageMeansNoLimit) {
  write("box/memory.max", "lots\n");
  write("box/memory.current", "100\n");
  write("memory/box/memory.limit_in_bytes", "\x01\x02\xff");
  write("memory/box/memory.usage_in_bytes", "");
  EXPECT_EQ(room("0::/box\n4:memory:/box\n"), 0u);
  // Garbage usage under a real limit counts as no usage.
  write("box/memory.max", "4096\n");
  write("box/memory.current", "-");
  EXPECT_EQ(room("0::/box\n"), 4096u);
  // Lines that are not "id:controllers:path" are skipped.
  EXPECT_EQ(room("garbage\n::\n:\n\n0::/box"), 4096u);
}

} // namespace
