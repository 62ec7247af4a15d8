// What one buildCuda call holds on the device: the selected device (restored
// afterwards), a stream, the memory pool and budget, the triangles, the
// pinned scalars for read-backs and the phase clock.
#pragma once

#include "device_memory.hpp"
#include "phases.hpp"

#include "hdt/builder.hpp"

#include <cuda_runtime.h>

#include <string>
#include <utility>
#include <vector>

namespace hdt {
namespace cuda {

enum Phase { kUpload, kMapping, kBranching, kLeaf, kClassify, kDownload, kPhaseCount };

// Device time per phase from CUDA events on the build's stream. mark(p)
// attributes the time since the previous mark to p; read after a sync.
class PhaseClock {
public:
  explicit PhaseClock(cudaStream_t stream) : stream_(stream) {}
  ~PhaseClock();
  PhaseClock(const PhaseClock&) = delete;
  PhaseClock& operator=(const PhaseClock&) = delete;

  void start();        // the first mark
  void mark(Phase p);  // end of a stretch of phase p
  // Adds the marked stretches to ms[] (stream must be idle) and starts over.
  void collect(double (&ms)[kPhaseCount]);

private:
  cudaEvent_t next();
  cudaStream_t stream_;
  std::vector<std::pair<cudaEvent_t, int>> marks_; // event, phase ending there (-1: start)
  std::vector<cudaEvent_t> spare_;
};

class DeviceGuard {
public:
  explicit DeviceGuard(int device);
  ~DeviceGuard();
  DeviceGuard(const DeviceGuard&) = delete;
  DeviceGuard& operator=(const DeviceGuard&) = delete;

private:
  int previous_ = -1;
};

class Stream {
public:
  Stream();
  ~Stream();
  Stream(const Stream&) = delete;
  Stream& operator=(const Stream&) = delete;
  cudaStream_t get() const { return s_; }

private:
  cudaStream_t s_ = nullptr;
};

struct Session {
  Session(const PreparedMesh& mesh, const BuildOptions& options);

  // Reports fraction * progressShare of the whole build; throws Error(Aborted).
  void progress(double fraction, const char* phase) const;
  void sync() const { HDT_CUDA_CHECK(cudaStreamSynchronize(stream.get())); }
  // The parity classification runs: a solid build under the parity test.
  // Under the winding number its verdicts would be discarded (the winding
  // pass rewrites every uniform element and every leaf's inside plane), so
  // it is skipped, as the CPU driver does: the device builds the surface only.
  bool parityClassification() const { return !mesh.surfaceOnly && !windingPassFollows(mesh); }

  const PreparedMesh& mesh;
  const BuildOptions& options;
  const GridSpec& grid;
  int device;
  std::string deviceName;
  DeviceGuard guard;
  Stream stream;
  DeviceMemory memory;
  HostScalars scalars;
  PhaseClock clock;
  DeviceBuffer<LatticeTriangle> triangles;
  DeviceMesh deviceMesh;
  double ms[kPhaseCount] = {};
  // The part of the build's progress the device phases report into: all of
  // it, or under the winding number the part before its pass (driver.cpp).
  double progressShare = 1.0;
  double copyBackMs = 0;      // host wall time of the copies back (pipeline.cpp's download)
  uint64_t copyBackBytes = 0;
};

// The mesh's triangles to the device (s.triangles, s.deviceMesh), timed as
// the upload; Error(OutOfResources) when they do not fit.
void uploadTriangles(Session& s);

// The budget: BuildOptions::deviceMemoryBudget (0: no limit) capped by what
// the device can give right now.
uint64_t deviceBudget(int device, uint64_t requested);

} // namespace cuda
} // namespace hdt
