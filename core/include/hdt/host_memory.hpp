// Host memory figures for refusing oversized work before allocating it (the
// CPU driver's build, the VTK layer's hyper tree grid) and for statistics.
#pragma once

#include <cstdint>

namespace hdt {

// MemAvailable from /proc/meminfo, or 0 when unknown.
uint64_t availableHostBytes();

// Peak resident set size of this process so far (getrusage).
uint64_t peakResidentBytes();

} // namespace hdt
