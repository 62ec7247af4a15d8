// How much device memory the CUDA driver keeps between builds.
#pragma once

#include <cstdint>

namespace hdt {

// Device memory the CUDA driver's pool keeps after a build, for the next one
// (default 2 GiB; beyond that it goes back to the driver as the build ends).
// A process whose releaseCuda (hdt/builder.hpp) follows its one build keeps it
// all: giving memory back as the build ends only lengthens the build
// (hdt-voxelize). Benchmarks of large builds raise it so that warm runs do not
// grow the pool again. Does nothing without the CUDA driver.
void setCudaPoolRetention(uint64_t bytes);

} // namespace hdt
