#include "hdt/host_memory.hpp"

#include <sys/resource.h>

#include <algorithm>
#include <fstream>
#include <sstream>
#include <string>

namespace hdt {
namespace {

// MemAvailable from /proc/meminfo, or 0.
uint64_t memAvailable() {
  std::ifstream in("/proc/meminfo");
  std::string key, unit;
  uint64_t value = 0;
  while (in >> key >> value >> unit) {
    if (key == "MemAvailable:") return value * 1024;
  }
  return 0;
}

// The first number in a file, or 0 when the file is missing, says "max" or
// does not start with a number.
uint64_t numberIn(const std::string& path) {
  std::ifstream in(path);
  uint64_t v = 0;
  return (in >> v) ? v : 0;
}

} // namespace

uint64_t cgroupRoomFrom(const std::string& procSelfCgroup, const std::string& cgroupRoot) {
  std::istringstream in(procSelfCgroup);
  std::string line;
  uint64_t room = 0;
  auto consider = [&](uint64_t limit, uint64_t usage) {
    // v1 reports "no limit" as a huge number (about 2^63).
    if (limit == 0 || limit >= (uint64_t(1) << 60)) return;
    const uint64_t left = limit > usage ? limit - usage : 0;
    room = room == 0 ? std::max<uint64_t>(left, 1) : std::min(room, std::max<uint64_t>(left, 1));
  };
  while (std::getline(in, line)) {
    // "0::/path" (v2) or "N:memory:/path" / "N:cpu,memory:/path" (v1).
    const size_t a = line.find(':'), b = line.find(':', a + 1);
    if (a == std::string::npos || b == std::string::npos) continue;
    const std::string controllers = line.substr(a + 1, b - a - 1), path = line.substr(b + 1);
    if (controllers.empty()) {
      // v2: the limit of this cgroup and of every ancestor applies.
      for (std::string p = path;; p = p.substr(0, p.find_last_of('/'))) {
        const std::string dir = cgroupRoot + (p == "/" ? std::string() : p);
        consider(numberIn(dir + "/memory.max"), numberIn(dir + "/memory.current"));
        if (p.empty() || p == "/" || p.find('/') == std::string::npos) break;
      }
    } else if (("," + controllers + ",").find(",memory,") != std::string::npos) {
      const std::string dir = cgroupRoot + "/memory" + (path == "/" ? std::string() : path);
      consider(numberIn(dir + "/memory.limit_in_bytes"), numberIn(dir + "/memory.usage_in_bytes"));
    }
  }
  return room;
}

namespace {

// Room left under this process's cgroup memory limit, or 0 when there is no
// limit. A container's limit can be far below what /proc/meminfo reports for
// the host.
uint64_t cgroupRoom() {
  std::ifstream in("/proc/self/cgroup");
  std::ostringstream contents;
  contents << in.rdbuf();
  return cgroupRoomFrom(contents.str(), "/sys/fs/cgroup");
}

} // namespace

uint64_t availableHostBytes() {
  const uint64_t host = memAvailable(), cgroup = cgroupRoom();
  if (host == 0) return cgroup;
  return cgroup == 0 ? host : std::min(host, cgroup);
}

uint64_t peakResidentBytes() {
  struct rusage usage {};
  if (getrusage(RUSAGE_SELF, &usage) != 0) return 0;
  return uint64_t(usage.ru_maxrss) * 1024; // Linux reports kilobytes
}

} // namespace hdt
