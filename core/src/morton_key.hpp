// The Morton key of a lattice cell: interleaves the low 21 bits of x, y, z
// (x lowest), the order in which the winding tree groups its boundary edges
// and the winding pass lists its blocks.
#pragma once

#include <cstdint>

namespace hdt {

inline uint64_t mortonKey(uint64_t x, uint64_t y, uint64_t z) {
  uint64_t key = 0;
  for (int b = 0; b < 21; ++b)
    key |= (((x >> b) & 1) << (3 * b)) | (((y >> b) & 1) << (3 * b + 1)) | (((z >> b) & 1) << (3 * b + 2));
  return key;
}

} // namespace hdt
