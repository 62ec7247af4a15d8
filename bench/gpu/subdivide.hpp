// Midpoint subdivision for the benchmarks: a >= 1 M-triangle mesh from the
// shared ones.
#pragma once

#include "hdt/mesh.hpp"

#include <algorithm>
#include <cstdint>
#include <unordered_map>

namespace hdt {

// Midpoint subdivision (each triangle into 4), midpoints shared per edge so
// that a closed mesh stays closed: the same surface with 4x the triangles.
inline TriangleMesh subdivide(const TriangleMesh& m) {
  TriangleMesh out;
  out.points = m.points;
  std::unordered_map<uint64_t, uint32_t> mid;
  auto midpoint = [&](uint32_t a, uint32_t b) {
    const uint64_t key = (uint64_t(std::min(a, b)) << 32) | std::max(a, b);
    auto it = mid.find(key);
    if (it != mid.end()) return it->second;
    const uint32_t idx = uint32_t(out.points.size() / 3);
    for (int k = 0; k < 3; ++k) out.points.push_back(0.5 * (m.points[3 * size_t(a) + k] + m.points[3 * size_t(b) + k]));
    mid.emplace(key, idx);
    return idx;
  };
  for (size_t t = 0; t < m.triangleCount(); ++t) {
    const uint32_t a = m.triangles[3 * t], b = m.triangles[3 * t + 1], c = m.triangles[3 * t + 2];
    const uint32_t ab = midpoint(a, b), bc = midpoint(b, c), ca = midpoint(c, a);
    for (uint32_t v : {a, ab, ca, ab, b, bc, ca, bc, c, ab, bc, ca}) out.triangles.push_back(v);
  }
  return out;
}

} // namespace hdt
