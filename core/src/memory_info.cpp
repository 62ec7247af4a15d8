#include "hdt/memory_info.hpp"

#include <sys/resource.h>

#include <fstream>
#include <string>

namespace hdt {

uint64_t availableHostBytes() {
  std::ifstream in("/proc/meminfo");
  std::string key;
  uint64_t value = 0;
  std::string unit;
  while (in >> key >> value >> unit) {
    if (key == "MemAvailable:") return value * 1024;
  }
  return 0;
}

uint64_t peakResidentBytes() {
  struct rusage usage {};
  if (getrusage(RUSAGE_SELF, &usage) != 0) return 0;
  return uint64_t(usage.ru_maxrss) * 1024; // Linux reports kilobytes
}

} // namespace hdt
