// The .hdt format's CRC-32 and section names (hdt_file_format.hpp).
#include "hdt_file_format.hpp"

#include <tbb/parallel_for.h>
#include <zlib.h>

namespace hdt::hdt_file_detail {

const char* sectionName(Section s) {
  switch (s) {
  case Section::Grid: return "grid";
  case Section::Statistics: return "statistics";
  case Section::LevelTable: return "level table";
  case Section::Elements: return "elements";
  case Section::LeafData: return "leaf data";
  case Section::End: return "end";
  case Section::LabelElements: return "label elements";
  case Section::LabelVoxels: return "label voxels";
  case Section::LabelNames: return "label names";
  case Section::CompactLabelVoxels: return "compact label voxels";
  case Section::ArrayDirectory: return "array directory";
  case Section::ArrayValues: return "array values";
  }
  return "?";
}

// zlib's crc32() takes a 32-bit length: feed it at most 1 GiB at a time.
uint32_t crc32Update(uint32_t crc, const void* data, size_t size) {
  const Bytef* p = static_cast<const Bytef*>(data);
  uLong c = crc;
  while (size > 0) {
    const uInt n = static_cast<uInt>(std::min<size_t>(size, size_t(1) << 30));
    c = crc32(c, p, n);
    p += n;
    size -= n;
  }
  return static_cast<uint32_t>(c);
}

// CRC-32 of a whole buffer. Large buffers are split into pieces checksummed
// in parallel and joined with crc32_combine: one core does only ~2-3 GB/s.
uint32_t crc32Of(const void* data, size_t size) {
  constexpr size_t kPiece = size_t(4) << 20;
  if (size <= 2 * kPiece) return crc32Update(0, data, size);
  const uint8_t* p = static_cast<const uint8_t*>(data);
  const size_t pieces = (size + kPiece - 1) / kPiece;
  std::vector<uint32_t> crcs(pieces);
  tbb::parallel_for(size_t(0), pieces, [&](size_t i) {
    crcs[i] = crc32Update(0, p + i * kPiece, std::min(kPiece, size - i * kPiece));
  });
  uLong crc = crcs[0];
  for (size_t i = 1; i < pieces; ++i)
    crc = crc32_combine(crc, crcs[i], z_off_t(std::min(kPiece, size - i * kPiece)));
  return static_cast<uint32_t>(crc);
}

// Optional sections' CRC covers the first 24 bytes of their header too (id,
// encoding, lengths), so that no flipped bit of a section a reader may skip
// goes unnoticed; this is the CRC of those 24 bytes, to continue over the payload.
uint32_t optionalSectionCrcSeed(uint32_t id, uint32_t encoding, uint64_t stored, uint64_t raw) {
  ByteWriter w;
  w.u32(id);
  w.u32(encoding);
  w.u64(stored);
  w.u64(raw);
  return crc32Update(0, w.bytes().data(), w.bytes().size());
}

// An optional section's CRC: its header's first 24 bytes, then the payload
// (whose own CRC-32 is payloadCrc).
uint32_t optionalSectionCrc(Section id, Encoding encoding, uint64_t stored, uint64_t raw, uint32_t payloadCrc) {
  const uint32_t seed = optionalSectionCrcSeed(uint32_t(id), uint32_t(encoding), stored, raw);
  return static_cast<uint32_t>(crc32_combine(seed, payloadCrc, z_off_t(stored)));
}

} // namespace hdt::hdt_file_detail
