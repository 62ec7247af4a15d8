// Does keepHostThreadsAwake slow CUDA's set-up beside the read? As hdt-voxelize: a thread creates
// the context and pins 256 MiB (the staging ring's kind of work), a thread starts the host
// workers and reserves warm pages (then keeps the workers awake, or not), the main thread reads
// and subdivides the mesh, prepares it, then waits for the CUDA thread.
//   cuda_beside MESH.ply K awake|sleep|after|none
// after: as awake, but prepareMesh only once the CUDA thread is done; none: no CUDA thread.
// Built on the development machine beside prepare_first (not a CMake target):
//   g++ -O3 -DNDEBUG -std=c++17 -Icore/include -Ibench/gpu -I.devdeps/include -I/usr/local/cuda/include \
//     bench/gpu/cuda_beside.cpp build-device/core/libhdt_core.a -L.devdeps/lib/x86_64-linux-gnu \
//     -L/usr/local/cuda/lib64 -lcudart -ltbb -lzstd -lz -lpthread -o DIR/cuda-beside
// and run on the GPU machine with libcudart.so.13 beside it (LD_LIBRARY_PATH); one process a run.
#include "hdt/mesh.hpp"
#include "hdt/mesh_io.hpp"
#include "hdt/warm_pages.hpp"
#include "subdivide.hpp"
#include <cuda_runtime.h>
#include <chrono>
#include <cstdio>
#include <cstring>
#include <filesystem>
#include <thread>
using namespace hdt;
using Clock = std::chrono::steady_clock;
static double ms(Clock::time_point a, Clock::time_point b) { return std::chrono::duration<double, std::milli>(b - a).count(); }
int main(int argc, char** argv) {
  const int k = atoi(argv[2]);
  const bool after = !strcmp(argv[3], "after"), none = !strcmp(argv[3], "none");
  const bool awake = !strcmp(argv[3], "awake") || after || none;
  const Clock::time_point start = Clock::now();
  double contextMs = 0, pinMs = 0;
  Clock::time_point cudaDone;
  std::thread cuda([&] {
    if (none) return;
    const Clock::time_point a = Clock::now();
    cudaSetDevice(0);
    cudaFree(nullptr);
    const Clock::time_point b = Clock::now();
    void* p = nullptr;
    cudaMallocHost(&p, size_t(256) << 20);
    cudaDone = Clock::now();
    contextMs = ms(a, b), pinMs = ms(b, cudaDone);
    cudaFreeHost(p);
  });
  const uint64_t bytes = 4 * (uint64_t(std::filesystem::file_size(argv[1])) << (2 * k)) + (uint64_t(8) << 20);
  std::thread warm([bytes, awake] {
    startHostThreads();
    reserveWarmPages(bytes);
    if (awake) keepHostThreadsAwake(1000);
  });
  TriangleMesh m = readMesh(argv[1]);
  for (int i = 0; i < k; ++i) m = subdivide(m);
  const Clock::time_point read = Clock::now();
  warm.join();
  if (after) cuda.join();
  BuildConfig c;
  c.resolution = 8192;
  const Clock::time_point t0 = Clock::now();
  PreparedMesh p = prepareMesh(m, c);
  const Clock::time_point t1 = Clock::now();
  if (cuda.joinable()) cuda.join();
  printf("{\"mode\": \"%s\", \"read_ms\": %.2f, \"prepare_ms\": %.3f, \"context_ms\": %.2f, \"pin_ms\": %.2f, \"cuda_done_ms\": %.2f, \"prepared_ms\": %.2f}\n",
         argv[3], ms(start, read), ms(t0, t1), contextMs, pinMs, ms(start, cudaDone), ms(start, t1));
}
