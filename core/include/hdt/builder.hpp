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

struct BuildOptions {
  Backend backend = Backend::Auto;
  int threads = 0;     // CPU threads; 0 = all cores
  int device = 0;      // CUDA device ordinal
  // Device memory budget in bytes for the CUDA driver (0 = what is free).
  // Smaller budgets make it build the root grid in chunks.
  uint64_t deviceMemoryBudget = 0;
  // Called between steps with a fraction in [0, 1] and the phase name, and
  // (CPU driver) about every 50 ms inside long phases; always on the thread
  // that called build().
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

// Readies the CUDA driver for builds like `config` on options.device (the
// context, the kernels such builds launch, the memory pool and the pinned
// copy-back staging), so that the first build of a process is as fast as a
// warm one. Takes tens of milliseconds: call it early, e.g. on a thread while
// the mesh is read. Does nothing without a usable device; never throws.
void prepareCuda(const BuildConfig& config, const BuildOptions& options);

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
