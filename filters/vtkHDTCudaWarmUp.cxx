#include "vtkHDTCudaWarmUp.h"

#include "vtkHDTDistributedBuild.h"

#include "hdt/builder.hpp"
#include "hdt/config.hpp"
#include "hdt/warm_pages.hpp"

#include <mutex>
#include <thread>

namespace
{
// Joined at exit at the latest, so that no thread uses CUDA while the
// process tears it down.
struct WarmUpThread
{
  std::mutex Mutex;
  std::thread Thread;
  ~WarmUpThread()
  {
    if (this->Thread.joinable())
    {
      this->Thread.join();
    }
  }
};

WarmUpThread& State()
{
  static WarmUpThread state;
  return state;
}
}

void vtkHDTCudaWarmUp::Start()
{
  static std::once_flag once;
  std::call_once(once, [] {
    if (vtkHDTDistributed::Controller())
    {
      return;
    }
    WarmUpThread& s = State();
    std::lock_guard<std::mutex> lock(s.Mutex);
    // oneTBB's workers first (the first Apply's prepareMesh then does not
    // create them), then the device. The filter's defaults (root grid, leaf
    // size, device 0): the kernels are the same for every configuration.
    // prepareCuda never throws.
    s.Thread = std::thread([] {
      hdt::startHostThreads();
      hdt::prepareCuda(hdt::BuildConfig{}, hdt::BuildOptions{});
    });
  });
}

void vtkHDTCudaWarmUp::Wait()
{
  WarmUpThread& s = State();
  std::lock_guard<std::mutex> lock(s.Mutex);
  if (s.Thread.joinable())
  {
    s.Thread.join();
  }
}
