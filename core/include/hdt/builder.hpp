// Building an HDT from a prepared mesh: the driver interface.
//
// Both drivers (CPU here, CUDA in cuda/) follow the paper's phases and return
// the same Volume, byte for byte, for the same input.
#pragma once

#include "hdt/mesh.hpp"
#include "hdt/volume.hpp"

#include <atomic>
#include <functional>
#include <string>

namespace hdt {

enum class Backend { Auto, Cpu, Cuda };

// The most CPU threads a build may ask for: oneTBB caps its workers near
// max(256, 4 x cores) anyway, and far larger counts crash its arena set-up.
constexpr int kMaxCpuThreads = 256;

// Throws Error(InvalidArgument) unless 0 <= threads <= kMaxCpuThreads.
void validateThreads(int threads);

struct BuildOptions {
  Backend backend = Backend::Auto;
  int threads = 0;     // CPU threads, 0 to kMaxCpuThreads; 0 = what oneTBB sees (cores, affinity)
  int device = 0;      // CUDA device ordinal
  // Device memory budget in bytes for the CUDA driver (0 = what is free).
  // Smaller budgets make it build the root grid in chunks.
  uint64_t deviceMemoryBudget = 0;
  // Called between steps with a fraction in [0, 1] and the phase name.
  // Returning false aborts the build (Error with ErrorKind::Aborted).
  std::function<bool(double fraction, const char* phase)> progress;
  // Informational messages (backend fallback and the like).
  std::function<void(const std::string&)> log;
};

// CPU driver (oneTBB).
Volume buildCpu(const PreparedMesh& mesh, const BuildOptions& options);

// True when this build has the CUDA driver and a usable device is present;
// `why` receives the reason when not.
bool cudaAvailable(std::string* why = nullptr);

// CUDA driver; throws Error(OutOfResources) on device failures.
Volume buildCuda(const PreparedMesh& mesh, const BuildOptions& options);

// Dispatches on options.backend. Auto runs CUDA when available and the CPU
// driver otherwise (saying so once through options.log), and falls back to
// the CPU driver if the device fails.
Volume build(const PreparedMesh& mesh, const BuildOptions& options);

// Convenience: prepare + build.
Volume voxelize(const TriangleMesh& mesh, const BuildConfig& config, const BuildOptions& options);

// Host memory the CPU driver is expected to need at most, from the mesh's
// surface area; used to refuse absurd resolutions before allocating.
uint64_t estimateHostBytes(const PreparedMesh& mesh);

} // namespace hdt
