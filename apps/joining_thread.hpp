// A thread that is joined when its owner is destroyed or given another one
// (std::jthread without the stop token; the project builds as C++17), so that
// every path out of a scope waits for the work it started.
#pragma once

#include <thread>
#include <utility>

namespace hdt::cli {

class JoiningThread {
public:
  JoiningThread() = default;
  template <class F>
  explicit JoiningThread(F&& work) : thread_(std::forward<F>(work)) {}
  JoiningThread(JoiningThread&&) = default;
  JoiningThread& operator=(JoiningThread&& other) {
    join();
    thread_ = std::move(other.thread_);
    return *this;
  }
  ~JoiningThread() { join(); }
  void join() {
    if (thread_.joinable()) thread_.join();
  }

private:
  std::thread thread_;
};

} // namespace hdt::cli
