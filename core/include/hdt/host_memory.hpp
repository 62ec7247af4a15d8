// Host memory figures for refusing oversized work before allocating it (the
// CPU driver's build, the VTK layer's hyper tree grid) and for statistics.
#pragma once

#include <cstdint>

namespace hdt {

// What this process may still allocate: MemAvailable from /proc/meminfo,
// capped by the room left under its cgroup memory limit (v2 memory.max, v1
// memory.limit_in_bytes); 0 when unknown.
uint64_t availableHostBytes();

// Peak resident set size of this process so far (getrusage).
uint64_t peakResidentBytes();

} // namespace hdt
