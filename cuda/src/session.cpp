#include "session.hpp"

#include "hdt/error.hpp"

#include <algorithm>
#include <map>
#include <mutex>
#include <string>

namespace hdt {
namespace cuda {
namespace {

int checkedDevice(int requested) {
  int count = 0;
  HDT_CUDA_CHECK(cudaGetDeviceCount(&count));
  if (requested < 0 || requested >= count) {
    throw Error(ErrorKind::InvalidArgument, "CUDA device " + std::to_string(requested) + " does not exist (" +
                                                std::to_string(count) + " device(s) present)");
  }
  return requested;
}

// cudaGetDeviceProperties reads every attribute (slow): once per device.
std::string nameOf(int device) {
  static std::mutex mutex;
  static std::map<int, std::string> names;
  std::lock_guard<std::mutex> lock(mutex);
  auto it = names.find(device);
  if (it == names.end()) {
    cudaDeviceProp prop;
    HDT_CUDA_CHECK(cudaGetDeviceProperties(&prop, device));
    it = names.emplace(device, prop.name).first;
  }
  return it->second;
}

} // namespace

// ---- HostScalars ----------------------------------------------------------------------
HostScalars::HostScalars() {
  HDT_CUDA_CHECK(cudaMallocHost(&host_, 16 * sizeof(uint64_t)));
  HDT_CUDA_CHECK(cudaMalloc(&device_, 16 * sizeof(uint64_t)));
}
HostScalars::~HostScalars() {
  cudaFreeHost(host_);
  cudaFree(device_);
}
void HostScalars::fetch(cudaStream_t stream, int n) {
  HDT_CUDA_CHECK(cudaMemcpyAsync(host_, device_, n * sizeof(uint64_t), cudaMemcpyDeviceToHost, stream));
  HDT_CUDA_CHECK(cudaStreamSynchronize(stream));
}

// ---- PhaseClock -------------------------------------------------------------------------
PhaseClock::~PhaseClock() {
  for (auto& m : marks_) cudaEventDestroy(m.first);
  for (cudaEvent_t e : spare_) cudaEventDestroy(e);
}
cudaEvent_t PhaseClock::next() {
  if (!spare_.empty()) {
    cudaEvent_t e = spare_.back();
    spare_.pop_back();
    return e;
  }
  cudaEvent_t e;
  HDT_CUDA_CHECK(cudaEventCreate(&e));
  return e;
}
void PhaseClock::start() {
  cudaEvent_t e = next();
  HDT_CUDA_CHECK(cudaEventRecord(e, stream_));
  marks_.emplace_back(e, -1);
}
void PhaseClock::mark(Phase p) {
  cudaEvent_t e = next();
  HDT_CUDA_CHECK(cudaEventRecord(e, stream_));
  marks_.emplace_back(e, int(p));
}
void PhaseClock::collect(double (&ms)[kPhaseCount]) {
  for (size_t i = 1; i < marks_.size(); ++i) {
    if (marks_[i].second < 0) continue; // a new start: the gap before it is nobody's
    float t = 0;
    HDT_CUDA_CHECK(cudaEventElapsedTime(&t, marks_[i - 1].first, marks_[i].first));
    ms[marks_[i].second] += t;
  }
  for (auto& m : marks_) spare_.push_back(m.first);
  marks_.clear();
}

// ---- DeviceGuard, Stream -------------------------------------------------------------------
DeviceGuard::DeviceGuard(int device) {
  HDT_CUDA_CHECK(cudaGetDevice(&previous_));
  HDT_CUDA_CHECK(cudaSetDevice(device));
}
DeviceGuard::~DeviceGuard() {
  if (previous_ >= 0) cudaSetDevice(previous_);
}
Stream::Stream() { HDT_CUDA_CHECK(cudaStreamCreateWithFlags(&s_, cudaStreamNonBlocking)); }
Stream::~Stream() {
  if (s_) cudaStreamDestroy(s_);
}

// ---- Session ------------------------------------------------------------------------------
uint64_t deviceBudget(int device, uint64_t requested) {
  const uint64_t obtainable = DeviceMemory::obtainable(device);
  return requested == 0 ? obtainable : std::min(requested, obtainable);
}

Session::Session(const PreparedMesh& m, const BuildOptions& o)
    : mesh(m), options(o), grid(m.grid), device(checkedDevice(o.device)), guard(device), stream(),
      memory(device, stream.get(), deviceBudget(device, o.deviceMemoryBudget)), scalars(), clock(stream.get()) {
  deviceName = nameOf(device);
}

void uploadTriangles(Session& s) {
  s.clock.start();
  const uint32_t triangleCount = uint32_t(s.mesh.triangles.size());
  try {
    s.triangles = DeviceBuffer<LatticeTriangle>(s.memory, triangleCount);
  } catch (const DeviceMemoryExhausted& e) {
    const auto mib = [](uint64_t bytes) { return std::to_string((bytes + (uint64_t(1) << 20) - 1) >> 20); };
    throw Error(ErrorKind::OutOfResources, "the mesh needs " + mib(e.neededBytes()) +
                                               " MiB of device memory for its triangles, " + mib(s.memory.budget()) +
                                               " MiB available");
  }
  HDT_CUDA_CHECK(cudaMemcpyAsync(s.triangles.data(), s.mesh.triangles.data(), s.triangles.bytes(),
                                 cudaMemcpyHostToDevice, s.stream.get()));
  s.clock.mark(kUpload);
  s.deviceMesh = DeviceMesh{s.triangles.data(), triangleCount};
}

void Session::progress(double fraction, const char* phase) const {
  if (options.progress && !options.progress(fraction * progressShare, phase)) {
    throw Error(ErrorKind::Aborted, std::string("build aborted during ") + phase);
  }
}

} // namespace cuda
} // namespace hdt
