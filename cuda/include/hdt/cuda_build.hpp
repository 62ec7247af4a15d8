// The CUDA driver's extra report, for benchmarks and diagnostics. The build
// itself is hdt::buildCuda (builder.hpp); this adds what Statistics has no
// field for.
#pragma once

#include "hdt/builder.hpp"
#include "hdt/device_pool.hpp" // setCudaPoolRetention

#include <cstdint>
#include <string>

namespace hdt {

struct CudaBuildReport {
  std::string deviceName;
  int device = 0;
  // Stream time of the copies around the build (Statistics::time covers the
  // device phases T1..classification only).
  double uploadMs = 0;   // triangles to the device
  double downloadMs = 0; // elements and leaf grids back (host wall time of the copies)
  uint64_t downloadBytes = 0;
  double hostMs = 0;     // host work after the device: joining chunks, statistics
  double wallMs = 0;     // the whole call, as the caller sees it
  int chunks = 1;        // root-grid chunks the build was split into (1 = in one piece)
  uint64_t budgetBytes = 0;    // the device memory budget the build ran under
  uint64_t estimatedBytes = 0; // the estimate the chunking decision was based on
};

// buildCuda with a report; `report` may be null. keepResult = false is for
// timing runs: the device work is the same, but nothing is copied back (the
// Volume holds the grid and Statistics::time only) unless the build had to
// be chunked.
Volume buildCudaWithReport(const PreparedMesh& mesh, const BuildOptions& options, CudaBuildReport* report,
                           bool keepResult = true);

} // namespace hdt
