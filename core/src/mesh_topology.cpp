#include "hdt/mesh_topology.hpp"

#include "scratch.hpp"

#include <tbb/blocked_range.h>
#include <tbb/parallel_for.h>
#include <tbb/parallel_reduce.h>
#include <tbb/task_arena.h>

#include <algorithm>
#include <atomic>
#include <utility>
#include <vector>

namespace hdt {

namespace {

// Values of items [0, n) grouped by bucket in one pass over the items: emit(i,
// put) calls put(bucket, value) for each value of item i. Each block of items
// (itemBlocks: the caller's `before` work on it first) is counted and then
// written at once, while its items are still in cache, into its own part of
// `values`, bucket by bucket. Bucket b is block 0's values of b, then block
// 1's, ... (forEachPart, gather): in item order whatever the thread count.
template <class Value, class Count> struct Buckets {
  size_t buckets = 0, blocks = 0, capacity = 0; // capacity: a block's part of values
  Scratch<Value> values;
  // Block k, bucket b: values[k capacity + first[k row + b], ... + first[k row + b + 1]).
  Scratch<Count> first;
  size_t row() const { return buckets + 16; } // padded: a power-of-two stride would share cache sets
  // f(first, last) for each block's values of bucket b, in block order.
  template <class F> void forEachPart(size_t b, F f) const {
    for (size_t k = 0; k < blocks; ++k) {
      const Count* at = first.data() + k * row();
      const Value* part = values.data() + k * capacity;
      f(part + at[b], part + at[b + 1]);
    }
  }
  void gather(size_t b, std::vector<Value>& out) const {
    out.clear();
    forEachPart(b, [&out](const Value* f, const Value* l) { out.insert(out.end(), f, l); });
  }
};

// Buckets: at most 2^16 (a staged value's bucket is 16 bits).
template <class Value, class Count, class Emit>
Buckets<Value, Count> scatterCounted(size_t n, size_t valuesPerItem, size_t buckets, Emit emit, const BlockWork& before) {
  Buckets<Value, Count> out;
  out.buckets = buckets;
  const ItemBlocks blocks = itemBlocks(n);
  const size_t block = blocks.size;
  out.blocks = blocks.count;
  out.capacity = block * valuesPerItem;
  out.values = Scratch<Value>(out.blocks * out.capacity);
  out.first = Scratch<Count>(out.blocks * out.row());
  // Each thread stages its block's values (and their buckets) in emit order in
  // its own slot, reused block after block while it stays in cache, so that
  // emit runs once an item.
  const size_t slots = size_t(std::max(1, tbb::this_task_arena::max_concurrency()));
  Scratch<Value> staged(slots * out.capacity);
  Scratch<uint16_t> stagedBucket(slots * out.capacity);
  tbb::parallel_for(size_t(0), out.blocks, [&](size_t k) {
    Count* first = out.first.data() + k * out.row();
    std::fill(first, first + buckets + 1, Count(0));
    const size_t begin = k * block, end = std::min(n, begin + block);
    if (before) before(k, begin, end);
    const size_t slot = std::min(slots - 1, size_t(std::max(0, tbb::this_task_arena::current_thread_index())));
    Value* value = staged.data() + slot * out.capacity;
    uint16_t* bucketOf = stagedBucket.data() + slot * out.capacity;
    size_t m = 0;
    auto stage = [&](size_t b, const Value& v) {
      ++first[b + 1];
      value[m] = v;
      bucketOf[m++] = uint16_t(b);
    };
    for (size_t i = begin; i < end; ++i) emit(i, stage);
    for (size_t b = 0; b < buckets; ++b) first[b + 1] += first[b];
    std::vector<Count> next(first, first + buckets); // this block's next slot in each bucket
    Value* part = out.values.data() + k * out.capacity;
    for (size_t j = 0; j < m; ++j) part[next[bucketOf[j]]++] = value[j];
  });
  return out;
}

// At most valuesPerItem values an item; then(buckets) with the scattered values.
template <class Value, class Emit, class Then>
auto scatter(size_t n, size_t valuesPerItem, size_t buckets, Emit emit, const BlockWork& before, Then then) {
  if (itemBlocks(n).size * valuesPerItem <= UINT32_MAX)
    return then(scatterCounted<Value, uint32_t>(n, valuesPerItem, buckets, emit, before));
  return then(scatterCounted<Value, size_t>(n, valuesPerItem, buckets, emit, before));
}

int bitWidth(uint64_t x) { return x ? 64 - __builtin_clzll(x) : 0; }

// ---- point numbers ----------------------------------------------------------------------

struct Point {
  int32_t x, y, z;
  uint32_t index;
};

uint64_t hashOf(int32_t x, int32_t y, int32_t z) {
  uint64_t h = uint64_t(uint32_t(x)) * 0x9E3779B97F4A7C15ull ^ uint64_t(uint32_t(y)) * 0xC2B2AE3D27D4EB4Full ^
               uint64_t(uint32_t(z)) * 0x165667B19E3779F9ull;
  h ^= h >> 31;
  h *= 0xD6E8FEB86659FD93ull;
  return h ^ (h >> 32);
}

size_t numberTableSize(size_t points) {
  size_t size = 16;
  while (size < 2 * points) size *= 2;
  return size;
}

// One bucket's points, read where the scatter put them (its blocks' parts, in
// index order): the first of equal ones numbers them all. The open-addressing
// table holds positions + 1 in the scattered values (0 is free), so the
// bucket is not copied first; a probe reads a value of this bucket (in
// cache). Position: uint32_t, or uint64_t where the values are more.
template <class Position, class Scattered>
void numberBucket(const Scattered& b, size_t bucket, NumberedPoint* out, Position* table) {
  size_t n = 0;
  b.forEachPart(bucket, [&n](const Point* f, const Point* l) { n += size_t(l - f); });
  const size_t mask = numberTableSize(n) - 1;
  std::fill(table, table + mask + 1, Position(0));
  const Point* values = b.values.data();
  b.forEachPart(bucket, [&](const Point* f, const Point* l) {
    for (; f != l; ++f) {
      const Point& p = *f;
      size_t slot = hashOf(p.x, p.y, p.z) & mask;
      uint32_t number = p.index;
      for (; table[slot] != 0; slot = (slot + 1) & mask) {
        const Point& q = values[table[slot] - 1];
        if (q.x == p.x && q.y == p.y && q.z == p.z) {
          number = q.index;
          break;
        }
      }
      if (number == p.index) table[slot] = Position(f - values + 1);
      out[p.index].number = number;
    }
  });
}

// Each bucket numbered with one table a thread (warm pages, reused bucket
// after bucket), of the largest bucket's size.
template <class Position, class Scattered> void numberBuckets(const Scattered& b, NumberedPoint* out) {
  size_t largest = 0;
  for (size_t k = 0; k < b.buckets; ++k) {
    size_t n = 0;
    b.forEachPart(k, [&n](const Point* f, const Point* l) { n += size_t(l - f); });
    largest = std::max(largest, n);
  }
  const size_t slots = size_t(std::max(1, tbb::this_task_arena::max_concurrency()));
  const size_t tableSize = numberTableSize(largest);
  Scratch<Position> tables(slots * tableSize);
  tbb::parallel_for(tbb::blocked_range<size_t>(0, b.buckets), [&](const tbb::blocked_range<size_t>& r) {
    const size_t slot = std::min(slots - 1, size_t(std::max(0, tbb::this_task_arena::current_thread_index())));
    for (size_t k = r.begin(); k != r.end(); ++k) numberBucket(b, k, out, tables.data() + slot * tableSize);
  });
}

// ---- edges and corners ------------------------------------------------------------------
//
// A triangle with point numbers a < b < c gives two entries, each filed under
// its smallest point: the corner entry (a | b, c), which stands for edges
// (a, b) and (a, c), and the edge entry (b | c, none). An entry is one integer
//   (p mod 2^shift) << 2 idBits | q << idBits | r,  none = 2^idBits - 1,
// 64 bits where they fit (up to 2^25 points), else 128. A point's entries
// give the other ends of its edges to higher points (each must come an even
// number of times), and two triangles with the same corners give equal
// corner entries.

struct Tally {
  size_t duplicates = 0;
  Tally operator+(const Tally& o) const { return {duplicates + o.duplicates}; }
};

template <class Entry> struct EntryCode {
  int idBits, shift;
  Entry none; // also the mask of q and r
  Entry of(uint32_t p, uint32_t q, Entry r) const {
    return (Entry(p & ((uint32_t(1) << shift) - 1)) << (2 * idBits)) | (Entry(q) << idBits) | r;
  }
  size_t localPoint(Entry e) const { return size_t(e >> (2 * idBits)); }
  uint32_t q(Entry e) const { return uint32_t((e >> idBits) & none); }
  Entry r(Entry e) const { return e & none; }
};

// Values that equal an earlier one in [first, last): a run of m equal values
// gives m - 1. Pairwise for the few values of a point, else sorted.
template <class T> size_t repeats(T* first, T* last) {
  size_t n = size_t(last - first), count = 0;
  if (n <= 16) {
    for (size_t i = 1; i < n; ++i) {
      bool seen = false;
      for (size_t j = 0; j < i; ++j) seen |= first[j] == first[i];
      count += seen;
    }
    return count;
  }
  std::sort(first, last);
  for (size_t i = 1; i < n; ++i) count += first[i] == first[i - 1];
  return count;
}

// Whether some value comes an odd number of times in [first, last).
bool someOddCount(uint32_t* first, uint32_t* last) {
  const size_t n = size_t(last - first);
  if (n <= 16) {
    unsigned odd = 0;
    for (size_t i = 0; i < n; ++i) {
      unsigned c = 0;
      for (size_t j = 0; j < n; ++j) c += first[j] == first[i];
      odd |= c;
    }
    return odd & 1;
  }
  std::sort(first, last);
  for (size_t i = 0; i < n;) {
    size_t j = i + 1;
    while (j < n && first[j] == first[i]) ++j;
    if ((j - i) & 1) return true;
    i = j;
  }
  return false;
}

// A hash of an entry, for a table of mask + 1 slots.
template <class Entry> size_t slotOf(Entry e, size_t mask) {
  uint64_t x = uint64_t(e);
  if constexpr (sizeof(Entry) > 8) x ^= uint64_t(e >> 64) * 0xC2B2AE3D27D4EB4Full;
  x *= 0x9E3779B97F4A7C15ull;
  return size_t(x ^ (x >> 32)) & mask;
}

// One bucket. While the mesh may be closed: ordered by point (a counting sort
// over the bucket's 2^shift points, or a plain sort where it has fewer entries
// than points), then each point's entries on their own: repeated corner
// entries, and the other ends of its edges, each of which must come an even
// number of times. Once one has not, the mesh is open (open set): the buckets
// tallied after that only count their repeated corner entries, in any order,
// in a hash table (in cache, no sort).
template <class Entry> struct BucketTally {
  const EntryCode<Entry>& code;
  std::atomic<bool>& open;
  std::vector<Entry> sorted, corners, cornerTable;
  std::vector<uint32_t> count, ends;
  bool parity = true; // this point's edges are checked

  void point(const Entry* first, const Entry* last, Tally& t) {
    const size_t n = size_t(last - first);
    if (ends.size() < 2 * n) ends.resize(2 * n), corners.resize(n);
    size_t e = 0, c = 0;
    if (parity) {
      for (const Entry* i = first; i != last; ++i) {
        ends[e++] = code.q(*i);
        if (code.r(*i) != code.none) ends[e++] = uint32_t(code.r(*i)), corners[c++] = *i;
      }
      if (someOddCount(ends.data(), ends.data() + e)) open.store(true, std::memory_order_relaxed), parity = false;
    } else {
      for (const Entry* i = first; i != last; ++i)
        if (code.r(*i) != code.none) corners[c++] = *i;
    }
    t.duplicates += repeats(corners.data(), corners.data() + c);
  }

  // Repeated corner entries of bucket `bucket`: a table of them (0 is free:
  // no corner entry is 0, its r is above its q).
  template <class Scattered> void duplicatesOnly(const Scattered& b, size_t bucket, Tally& t) {
    const Entry none = code.none;
    size_t c = 0;
    b.forEachPart(bucket, [&](const Entry* f, const Entry* l) {
      for (; f != l; ++f) c += (*f & none) != none;
    });
    const size_t mask = numberTableSize(c) - 1; // the same load as the numbering's tables
    cornerTable.assign(mask + 1, Entry(0));
    b.forEachPart(bucket, [&](const Entry* f, const Entry* l) {
      for (; f != l; ++f) {
        const Entry e = *f;
        if ((e & none) == none) continue;
        size_t slot = slotOf(e, mask);
        while (cornerTable[slot] != 0 && cornerTable[slot] != e) slot = (slot + 1) & mask;
        if (cornerTable[slot] == e) ++t.duplicates;
        else cornerTable[slot] = e;
      }
    });
  }

  // Bucket `bucket` of the scattered entries b, read from its blocks' parts.
  template <class Scattered> void operator()(const Scattered& b, size_t bucket, Tally& t) {
    if (open.load(std::memory_order_relaxed)) return duplicatesOnly(b, bucket, t);
    parity = true;
    const size_t points = size_t(1) << code.shift;
    size_t n = 0;
    b.forEachPart(bucket, [&n](const Entry* f, const Entry* l) { n += size_t(l - f); });
    if (n < points) {
      b.gather(bucket, sorted);
      std::sort(sorted.begin(), sorted.end());
      for (size_t i = 0; i < n;) {
        size_t j = i + 1;
        while (j < n && code.localPoint(sorted[j]) == code.localPoint(sorted[i])) ++j;
        point(sorted.data() + i, sorted.data() + j, t);
        i = j;
      }
      return;
    }
    count.assign(points + 1, 0);
    b.forEachPart(bucket, [this](const Entry* f, const Entry* l) {
      for (; f != l; ++f) ++count[code.localPoint(*f) + 1];
    });
    for (size_t p = 0; p < points; ++p) count[p + 1] += count[p];
    sorted.resize(n);
    b.forEachPart(bucket, [this](const Entry* f, const Entry* l) {
      for (; f != l; ++f) sorted[count[code.localPoint(*f)]++] = *f;
    });
    // count[p] is now where point p + 1 starts
    for (size_t p = 0, begin = 0; p < points; begin = count[p++]) point(sorted.data() + begin, sorted.data() + count[p], t);
  }
};

template <class Entry>
SurfaceTopology tally(const uint32_t* indices, const uint8_t* keep, size_t triangles, const NumberedPoint* numbers,
                      uint64_t pointRange, int shift, const BlockWork& before) {
  EntryCode<Entry> code;
  code.idBits = bitWidth(pointRange);
  code.none = (Entry(1) << code.idBits) - 1;
  code.shift = shift;
  const size_t buckets = size_t(((pointRange - 1) >> shift) + 1);
  const auto file = [&](size_t t, auto&& put) {
    if (keep && !keep[t]) return;
    uint32_t v[3];
    for (int j = 0; j < 3; ++j) v[j] = numbers ? numbers[indices[3 * t + j]].number : indices[3 * t + j];
    if (v[1] < v[0]) std::swap(v[0], v[1]);
    if (v[2] < v[1]) std::swap(v[1], v[2]);
    if (v[1] < v[0]) std::swap(v[0], v[1]);
    put(v[0] >> shift, code.of(v[0], v[1], v[2]));
    put(v[1] >> shift, code.of(v[1], v[2], code.none));
  };
  std::atomic<bool> open{false};
  const Tally t = scatter<Entry>(triangles, 2, buckets, file, before, [&](const auto& b) {
    return tbb::parallel_reduce(
        tbb::blocked_range<size_t>(0, buckets), Tally{},
        [&](const tbb::blocked_range<size_t>& r, Tally sum) {
          BucketTally<Entry> bucket{code, open, {}, {}, {}, {}, {}};
          for (size_t k = r.begin(); k != r.end(); ++k) bucket(b, k, sum);
          return sum;
        },
        [](const Tally& x, const Tally& y) { return x + y; });
  });
  return SurfaceTopology{!open.load(), t.duplicates};
}

} // namespace

ItemBlocks itemBlocks(size_t n) {
  ItemBlocks b;
  b.count = std::clamp<size_t>(n >> 12, 1, 64);
  b.size = (n + b.count - 1) / b.count;
  return b;
}

void numberLatticePoints(NumberedPoint* points, size_t count, const BlockWork& before) {
  if (count == 0) return;
  // At least 64 points a bucket, at most 256 buckets: each block's points go
  // to few buckets (a few cache lines written at a time), and a bucket's
  // parts in the blocks are not too small to read.
  int bits = 0;
  while (bits < 8 && (count >> (bits + 6)) > 0) ++bits;
  const auto file = [&](size_t i, auto&& put) {
    const NumberedPoint& p = points[i];
    const uint64_t h = hashOf(p.x, p.y, p.z);
    put(bits ? size_t(h >> (64 - bits)) : 0, Point{p.x, p.y, p.z, uint32_t(i)});
  };
  scatter<Point>(count, 1, size_t(1) << bits, file, before, [&](const auto& b) {
    if (b.values.size() < UINT32_MAX) numberBuckets<uint32_t>(b, points);
    else numberBuckets<uint64_t>(b, points);
    return 0;
  });
}

SurfaceTopology surfaceTopology(const uint32_t* indices, const uint8_t* keep, size_t triangles,
                                const NumberedPoint* numbers, uint64_t pointRange, const BlockWork& before) {
  if (triangles == 0 || pointRange == 0) return SurfaceTopology{};
  int shift = 0; // at most about 1024 buckets of 2^shift points (as few for the same reasons as the numbers')
  while ((pointRange >> shift) > 1024) ++shift;
  if (shift + 2 * bitWidth(pointRange) <= 64) return tally<uint64_t>(indices, keep, triangles, numbers, pointRange, shift, before);
  return tally<unsigned __int128>(indices, keep, triangles, numbers, pointRange, shift, before);
}

} // namespace hdt
