// Host memory figures for refusing oversized work before allocating it (the
// CPU driver's build, the VTK layer's hyper tree grid) and for statistics.
#pragma once

#include <cstdint>
#include <string>

namespace hdt {

// What this process may still allocate: MemAvailable from /proc/meminfo,
// capped by the room left under its cgroup memory limit (v2 memory.max, v1
// memory.limit_in_bytes); 0 when unknown.
uint64_t availableHostBytes();

// Room left under the cgroup memory limits named by `procSelfCgroup` (the
// contents of /proc/self/cgroup) with the hierarchy mounted at `cgroupRoot`
// (normally /sys/fs/cgroup): the smallest limit minus usage over the v2 cgroup
// and its ancestors (memory.max, memory.current) and the v1 memory controller
// (memory/<path>/memory.limit_in_bytes, memory.usage_in_bytes); at least 1
// when a limit is reached. 0 means no limit: "max", v1's ~2^63 "unlimited",
// missing files and contents that do not start with a number all count as no
// limit (a missing or unreadable usage counts as 0). Separate from
// availableHostBytes so tests can point it at fake cgroup files.
uint64_t cgroupRoomFrom(const std::string& procSelfCgroup, const std::string& cgroupRoot);

// Peak resident set size of this process so far (getrusage).
uint64_t peakResidentBytes();

} // namespace hdt
