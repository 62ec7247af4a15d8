// Aborting a CPU build from the progress callback: between phases, and inside
// a long phase (the driver asks the callback again from inside its parallel
// loops, on the calling thread, at most every 50 ms).
#include "hdt/builder.hpp"
#include "hdt/error.hpp"
#include "hdt/mesh.hpp"
#include "support/shapes.hpp"

#include <gtest/gtest.h>

#include <chrono>
#include <string>
#include <thread>

namespace hdt {
namespace test {
namespace {

BuildConfig sphereConfig() {
  BuildConfig c;
  c.resolution = 256;
  c.rootGrid = 4;
  c.leafSize = 8;
  return c;
}

TEST(Abort, BetweenPhases) {
  BuildOptions options;
  options.backend = Backend::Cpu;
  options.progress = [](double, const char* phase) { return std::string(phase) != "branching"; };
  try {
    voxelize(icosphere(3, 1.0), sphereConfig(), options);
    ADD_FAILURE() << "the build was not aborted";
  } catch (const Error& e) {
    EXPECT_EQ(e.kind(), ErrorKind::Aborted);
    EXPECT_NE(std::string(e.what()).find("branching"), std::string::npos) << e.what();
  }
}

// The callback answers "go on" when the leaf phase starts, waits long enough
// for the driver's next poll to be due, and answers "stop" when it is asked
// again during that same phase. A driver that only asked between phases would
// finish the build.
TEST(Abort, InsideALongPhase) {
  int leafCalls = 0;
  BuildOptions options;
  options.backend = Backend::Cpu;
  options.threads = 1; // the calling thread runs the loop itself
  options.progress = [&](double, const char* phase) {
    if (std::string(phase) != "leaf processing") return true;
    if (++leafCalls == 1) {
      std::this_thread::sleep_for(std::chrono::milliseconds(80));
      return true;
    }
    return false;
  };
  try {
    voxelize(icosphere(3, 1.0), sphereConfig(), options);
    ADD_FAILURE() << "the build was not aborted inside the leaf phase";
  } catch (const Error& e) {
    EXPECT_EQ(e.kind(), ErrorKind::Aborted);
    EXPECT_NE(std::string(e.what()).find("leaf processing"), std::string::npos) << e.what();
  }
  EXPECT_EQ(leafCalls, 2);
}

} // namespace
} // namespace test
} // namespace hdt
