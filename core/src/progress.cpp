#include "hdt/progress.hpp"

#include "hdt/error.hpp"

#include <string>
#include <utility>

namespace hdt {

ProgressPoll::ProgressPoll(Callback callback, double from, double to)
    : callback_(std::move(callback)), from_(from), to_(to), fraction_(from) {}

void ProgressPoll::report(double fraction, const char* phase) {
  if (stop_.load(std::memory_order_relaxed)) // asked inside the step that just ended
    throw Error(ErrorKind::Aborted, std::string("build aborted during ") + phase_);
  fraction_ = from_ + (to_ - from_) * fraction;
  phase_ = phase;
  lastAsked_ = std::chrono::steady_clock::now();
  if (callback_ && !callback_(fraction_, phase_)) {
    stop_.store(true, std::memory_order_relaxed);
    throw Error(ErrorKind::Aborted, std::string("build aborted during ") + phase_);
  }
}

bool ProgressPoll::abortRequested() {
  if (stop_.load(std::memory_order_relaxed)) return true;
  if (!callback_ || std::this_thread::get_id() != owner_) return false;
  const auto now = std::chrono::steady_clock::now();
  if (now - lastAsked_ < std::chrono::milliseconds(50)) return false;
  lastAsked_ = now;
  if (!callback_(fraction_, phase_)) stop_.store(true, std::memory_order_relaxed);
  return stop_.load(std::memory_order_relaxed);
}

} // namespace hdt
