// One long computation's progress reports and abort requests, as
// BuildOptions::progress asks for them: the CPU driver's phases and the
// winding-number pass that may follow them share one poll each, so a build
// reports one rising fraction from 0 to 1 and can be stopped in any phase.
#pragma once

#include <atomic>
#include <chrono>
#include <functional>
#include <thread>

namespace hdt {

class ProgressPoll {
public:
  using Callback = std::function<bool(double fraction, const char* phase)>;

  // Fractions given to report() are this step's own, 0 to 1; the callback
  // sees them mapped into [from, to], the step's share of the whole build.
  // The poll belongs to the thread that makes it: the callback is asked only
  // there. `callback` may be empty: nothing is reported, nothing aborts.
  explicit ProgressPoll(Callback callback, double from = 0.0, double to = 1.0);

  // Between steps: reports `fraction` of this step and `phase`; throws
  // Error(Aborted) when the callback answers false, or when it already did
  // during the step that just ended (abortRequested).
  void report(double fraction, const char* phase);

  // Inside long parallel loops, from any thread: true once the caller asked
  // to stop (the loop body then returns at once and the next report()
  // throws). On the poll's own thread, which works in the loops too, the
  // callback is asked again at most every 50 ms with the last fraction.
  bool abortRequested();

private:
  const Callback callback_;
  const double from_, to_;
  std::atomic<bool> stop_{false};
  const std::thread::id owner_ = std::this_thread::get_id();
  std::chrono::steady_clock::time_point lastAsked_ = std::chrono::steady_clock::now();
  double fraction_;
  const char* phase_ = "";
};

// The share of a build's progress that the CPU driver's phases report into
// when the winding-number pass follows (hdt::applyInsideTest, after the join:
// on the CPU it takes two to four times as long as they do,
// bench/results/winding.md); the pass reports the rest.
constexpr double kCpuPhasesShareBeforeWinding = 0.3;

// abortRequested() of an optional poll (null: never).
inline bool abortRequested(ProgressPoll* poll) { return poll && poll->abortRequested(); }

} // namespace hdt
