// libFuzzer harness: the .hdt reader on arbitrary bytes (from memory).
// Accepted files must survive a write/read round trip bit for bit; refusals
// must be hdt::Error. Anything else (crash, sanitizer report, other exception)
// is a finding.
#include "hdt/error.hpp"
#include "hdt/hdt_file.hpp"

#include <cstdint>
#include <cstdlib>
#include <vector>

extern "C" int LLVMFuzzerTestOneInput(const uint8_t* data, size_t size) {
  hdt::Volume v;
  try {
    v = hdt::deserializeHdt(data, size, "fuzz.hdt");
  } catch (const hdt::Error&) {
    return 0;
  }
  hdt::HdtWriteOptions raw;
  raw.compressLeaves = false;
  const std::vector<uint8_t> once = hdt::serializeHdt(v, raw);
  const hdt::Volume again = hdt::deserializeHdt(once.data(), once.size(), "round-trip");
  if (hdt::serializeHdt(again, raw) != once) std::abort(); // a lossy round trip
  return 0;
}
