// The .hdt format's constants, section ids and byte-level encoding
// (docs/hdt-format.md), shared by the reader and the writer of hdt_file*.cpp.
// Private to hdt_core: nothing here is part of the public API.
// (hdt_file.cpp lists the files of the format and what each does.)
#pragma once

#include <algorithm>
#include <cstdint>
#include <cstring>
#include <new>
#include <stdexcept>
#include <string>
#include <vector>

namespace hdt::hdt_file_detail {

// ---- the format's constants (docs/hdt-format.md) ----------------------------------

constexpr uint8_t kMagic[4] = {'H', 'D', 'T', 0};
// Version 3 is version 2 with the leaf data as zstd blocks (encoding 2), and
// only that: the writer writes 3 exactly when it writes blocks, 2 otherwise
// (readers of version 2 read every file that needs nothing newer), and a
// version-3 file with other leaf data is refused, so that no flip of the
// version field between 2 and 3 goes unnoticed. The reader reads 1 to 3.
constexpr uint32_t kVersion = 3;       // the newest
constexpr uint32_t kOldestVersion = 1; // the oldest the reader still reads
constexpr uint32_t kFirstBlocksVersion = 3; // leaf data encoding 2
constexpr uint32_t kFlagLeafZstd = 1u; // flags bit 0
constexpr size_t kFileHeaderBytes = 12;
constexpr size_t kSectionHeaderBytes = 28;
constexpr size_t kGridBytesV1 = 56;
constexpr size_t kGridBytes = 60; // version 2: + the inside test
// Version 2: ids of optional sections start here; an unknown one with the
// critical bit set must be refused, one without it may be skipped.
constexpr uint32_t kFirstOptionalSection = 16;
constexpr uint32_t kCriticalSectionBit = 0x80000000u;
// Bytes of a skipped section checksummed at a time: the skip allocates no more.
constexpr size_t kSkipChunkBytes = size_t(1) << 20;
constexpr size_t kStatsFixedBytes = 144;
constexpr size_t kMaxBackendLength = 64;
constexpr int64_t kMaxHeight = 16; // keeps R * 2^h * L far from overflow

enum class Section : uint32_t {
  Grid = 1, Statistics = 2, LevelTable = 3, Elements = 4, LeafData = 5, End = 6,
  // Optional (version 2)
  LabelElements = 16, LabelVoxels = 17, LabelNames = 18,
  ArrayDirectory = 19, ArrayValues = 20, // transferred mesh data (hdt/transfer.hpp)
  CompactLabelVoxels = 21, // replaces 17 (read only, converted): palettes of mixed leaves
};
constexpr size_t kMaxLabelNameLength = 255;
// Section 21's first field: the layout of mixed leaves' labels (1 was
// section 17's: 16 bits a voxel; 2: label_field.hpp's palettes).
constexpr uint32_t kCompactLabelLayout = 2;
// ZstdBlocks (version 3, leaf data only): a table of frame lengths, then one
// zstd frame per block of 2^b raw bytes (zstd_blocks.hpp).
enum class Encoding : uint32_t { Raw = 0, Zstd = 1, ZstdBlocks = 2 };
inline bool isCompressed(Encoding e) { return e != Encoding::Raw; }

// For messages: "grid", "leaf data", ...
const char* sectionName(Section s);

// A broken rule of the format; the entry points add the name and the ErrorKind.
struct Invalid : std::runtime_error {
  using std::runtime_error::runtime_error;
};
[[noreturn]] inline void invalid(const std::string& what) { throw Invalid(what); }

inline std::string str(uint64_t v) { return std::to_string(v); }

// A length read from the file or computed from it, as a size_t: where it does
// not fit, the allocation it is for could not succeed either.
inline size_t toSize(uint64_t bytes) {
  if (bytes > uint64_t(SIZE_MAX)) throw std::bad_alloc();
  return size_t(bytes);
}

// ---- bytes ------------------------------------------------------------------------

constexpr bool kLittleEndianHost = __BYTE_ORDER__ == __ORDER_LITTLE_ENDIAN__;

// zlib's CRC-32 (the format's checksum) continued over `size` more bytes.
uint32_t crc32Update(uint32_t crc, const void* data, size_t size);
// CRC-32 of a whole buffer; large ones in parallel pieces.
uint32_t crc32Of(const void* data, size_t size);

inline uint32_t byteSwap(uint32_t v) { return __builtin_bswap32(v); }
inline uint16_t byteSwap(uint16_t v) { return __builtin_bswap16(v); }
inline uint8_t byteSwap(uint8_t v) { return v; }
inline float byteSwap(float v) {
  uint32_t b;
  std::memcpy(&b, &v, 4);
  b = __builtin_bswap32(b);
  std::memcpy(&v, &b, 4);
  return v;
}

// Calls fn(bytes, size) over the little-endian encoding of `words`, in order.
// On little-endian hosts that is the array itself, in one call and no copy.
template <class T, class Fn> void forEachLittleEndianChunk(const T* words, size_t count, Fn&& fn) {
  if (count == 0) return;
  if (kLittleEndianHost) {
    fn(reinterpret_cast<const uint8_t*>(words), count * sizeof(T));
    return;
  }
  std::vector<T> chunk(std::min<size_t>(count, 1 << 16));
  for (size_t i = 0; i < count; i += chunk.size()) {
    const size_t n = std::min(chunk.size(), count - i);
    for (size_t j = 0; j < n; ++j) chunk[j] = byteSwap(words[i + j]);
    fn(reinterpret_cast<const uint8_t*>(chunk.data()), n * sizeof(T));
  }
}

// CRC-32 of the little-endian encoding of `words`.
template <class Words> uint32_t crcOfWords(const Words& words) {
  if (kLittleEndianHost) return crc32Of(words.data(), words.size() * sizeof(words[0]));
  uint32_t crc = 0;
  forEachLittleEndianChunk(words.data(), words.size(),
                           [&](const uint8_t* p, size_t n) { crc = crc32Update(crc, p, n); });
  return crc;
}

// Words just read in little-endian order -> host order, in place.
template <class T> void littleEndianToHost(T* words, size_t count) {
  if (!kLittleEndianHost)
    for (size_t i = 0; i < count; ++i) words[i] = byteSwap(words[i]);
}

// Little-endian encoding of the small sections' fields.
class ByteWriter {
public:
  void u32(uint32_t v) {
    for (int i = 0; i < 4; ++i) bytes_.push_back(uint8_t(v >> (8 * i)));
  }
  void u64(uint64_t v) {
    for (int i = 0; i < 8; ++i) bytes_.push_back(uint8_t(v >> (8 * i)));
  }
  void i32(int32_t v) { u32(static_cast<uint32_t>(v)); }
  void f64(double v) {
    uint64_t b;
    std::memcpy(&b, &v, 8);
    u64(b);
  }
  void raw(const void* data, size_t size) {
    const uint8_t* p = static_cast<const uint8_t*>(data);
    bytes_.insert(bytes_.end(), p, p + size);
  }
  const std::vector<uint8_t>& bytes() const { return bytes_; }

private:
  std::vector<uint8_t> bytes_;
};

// The CRC-32 of an optional section's first 24 header bytes (id, encoding,
// lengths), which its CRC covers before the payload.
uint32_t optionalSectionCrcSeed(uint32_t id, uint32_t encoding, uint64_t stored, uint64_t raw);
// An optional section's CRC: its header's first 24 bytes, then the payload
// (whose own CRC-32 is payloadCrc).
uint32_t optionalSectionCrc(Section id, Encoding encoding, uint64_t stored, uint64_t raw, uint32_t payloadCrc);

// The matching decoder. Callers check section lengths before decoding, so
// running past the end is a bug here, but still an error rather than a crash.
class ByteReader {
public:
  ByteReader(const uint8_t* data, size_t size) : p_(data), size_(size) {}
  uint32_t u32() { return uint32_t(take(4)); }
  uint64_t u64() { return take(8); }
  int32_t i32() { return static_cast<int32_t>(u32()); }
  double f64() {
    const uint64_t b = take(8);
    double v;
    std::memcpy(&v, &b, 8);
    return v;
  }
  const uint8_t* bytes(size_t n) {
    need(n);
    const uint8_t* p = p_ + pos_;
    pos_ += n;
    return p;
  }

private:
  void need(size_t n) const {
    if (n > size_ - pos_) invalid("internal: field beyond its section");
  }
  uint64_t take(int n) {
    need(size_t(n));
    uint64_t v = 0;
    for (int i = 0; i < n; ++i) v |= uint64_t(p_[pos_ + i]) << (8 * i);
    pos_ += size_t(n);
    return v;
  }
  const uint8_t* p_;
  size_t size_;
  size_t pos_ = 0;
};

} // namespace hdt::hdt_file_detail
