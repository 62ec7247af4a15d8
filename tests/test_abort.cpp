// Aborting a CPU build from the progress callback: between phases, and inside
// a long phase (the driver asks the callback again from inside its parallel
// loops, on the calling thread, at most every 50 ms); the winding-number
// pass that follows the phases of an open mesh's build reports and aborts
// the same way.
#include "hdt/builder.hpp"
#include "hdt/error.hpp"
#include "hdt/mesh.hpp"
#include "hdt/progress.hpp"
#include "support/shapes.hpp"
#include "support/winding_reference.hpp"

#include <gtest/gtest.h>

#include <chrono>
#include <string>
#include <thread>
#include <utility>
#include <vector>

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

// ---- the winding-number pass ---------------------------------------------------

constexpr const char* kWindingPhase = "inside test: winding number";

BuildConfig openCubeConfig(InsideTest test) {
  BuildConfig c = sphereConfig();
  c.resolution = 128;
  c.insideTest = test;
  return c;
}

struct ProgressCall {
  double fraction;
  std::string phase;
};

std::vector<ProgressCall> progressOf(InsideTest test) {
  std::vector<ProgressCall> calls;
  BuildOptions options;
  options.backend = Backend::Cpu;
  options.progress = [&](double fraction, const char* phase) {
    calls.push_back({fraction, phase});
    return true;
  };
  voxelize(windingShapes()[0].mesh, openCubeConfig(test), options);
  return calls;
}

// Under the winding number the build's phases take the first part of the
// bar and the pass the rest, one rising fraction ending at "done"; under
// parity the pass reports nothing.
TEST(Progress, TheWindingPassReportsItsShareOfTheBuild) {
  const std::vector<ProgressCall> winding = progressOf(InsideTest::WindingNumber);
  ASSERT_GE(winding.size(), 3u);
  double last = 0, firstWinding = -1;
  size_t windingCalls = 0;
  for (const ProgressCall& c : winding) {
    EXPECT_GE(c.fraction, last) << c.phase;
    last = c.fraction;
    if (c.phase == kWindingPhase) {
      if (firstWinding < 0) firstWinding = c.fraction;
      ++windingCalls;
    } else if (c.phase != "done") {
      EXPECT_LT(windingCalls, 1u) << "a build phase (" << c.phase << ") after the winding pass began";
    }
  }
  EXPECT_GE(windingCalls, 4u); // tree, walk, uniform elements, leaves
  EXPECT_GT(firstWinding, 0.1);
  EXPECT_LT(firstWinding, 0.9);
  EXPECT_EQ(winding.back().phase, "done");
  EXPECT_EQ(winding.back().fraction, 1.0);

  const std::vector<ProgressCall> parity = progressOf(InsideTest::Parity);
  for (const ProgressCall& c : parity) EXPECT_NE(c.phase, kWindingPhase);
  ASSERT_FALSE(parity.empty());
  EXPECT_EQ(parity.back().phase, "done");
  EXPECT_EQ(parity.back().fraction, 1.0);
}

// The open cube's winding-number build with these options ends in
// Error(Aborted) during the pass.
void expectAbortedInTheWindingPass(const BuildOptions& options) {
  try {
    voxelize(windingShapes()[0].mesh, openCubeConfig(InsideTest::WindingNumber), options);
    ADD_FAILURE() << "the build was not aborted in the winding pass";
  } catch (const Error& e) {
    EXPECT_EQ(e.kind(), ErrorKind::Aborted);
    EXPECT_NE(std::string(e.what()).find("winding number"), std::string::npos) << e.what();
  }
}

TEST(Abort, WhenTheWindingPassBegins) {
  BuildOptions options;
  options.backend = Backend::Cpu;
  options.progress = [](double, const char* phase) { return std::string(phase) != kWindingPhase; };
  expectAbortedInTheWindingPass(options);
}

// Each of the pass's reports takes 80 ms to answer "go on", so the first
// poll inside the loop that follows is due at once: it asks again with the
// same fraction and phase, and that second ask answers "stop". A pass that
// only reported between its steps would never be asked twice alike and
// would finish the build.
TEST(Abort, InsideTheWindingPassLoops) {
  BuildOptions options;
  options.backend = Backend::Cpu;
  options.threads = 1; // the calling thread runs the loops itself
  ProgressCall previous{-1, ""};
  bool askedAgain = false;
  options.progress = [&](double fraction, const char* phase) {
    if (std::string(phase) != kWindingPhase) return true;
    askedAgain = fraction == previous.fraction && previous.phase == phase;
    previous = {fraction, phase};
    if (askedAgain) return false;
    std::this_thread::sleep_for(std::chrono::milliseconds(80));
    return true;
  };
  expectAbortedInTheWindingPass(options);
  EXPECT_TRUE(askedAgain);
}

// The poll itself: fractions mapped into its share, the callback asked again
// only on its own thread and not before 50 ms, a "stop" kept.
TEST(Progress, PollMapsFractionsAndAsksOnlyOnItsThread) {
  std::vector<std::pair<double, std::string>> calls;
  bool goOn = true;
  ProgressPoll poll(
      [&](double f, const char* phase) {
        calls.emplace_back(f, phase);
        return goOn;
      },
      0.25, 0.75);
  poll.report(0.5, "half");
  ASSERT_EQ(calls.size(), 1u);
  EXPECT_DOUBLE_EQ(calls[0].first, 0.5);
  EXPECT_FALSE(poll.abortRequested()); // asked too recently: no call
  EXPECT_EQ(calls.size(), 1u);
  std::this_thread::sleep_for(std::chrono::milliseconds(60));
  bool otherThread = true;
  std::thread([&] { otherThread = poll.abortRequested(); }).join();
  EXPECT_FALSE(otherThread);
  EXPECT_EQ(calls.size(), 1u); // never asked from another thread
  goOn = false;
  EXPECT_TRUE(poll.abortRequested()); // due: asked again, with the last fraction
  ASSERT_EQ(calls.size(), 2u);
  EXPECT_DOUBLE_EQ(calls[1].first, 0.5);
  EXPECT_EQ(calls[1].second, "half");
  bool seenByOthers = false;
  std::thread([&] { seenByOthers = poll.abortRequested(); }).join();
  EXPECT_TRUE(seenByOthers);
  EXPECT_THROW(poll.report(1.0, "end"), Error);
  EXPECT_EQ(calls.size(), 2u); // a stopped poll throws without asking
}

} // namespace
} // namespace test
} // namespace hdt
