// A volume encoded for the .hdt writer (hdt_file_write.cpp): every section
// header known before the first byte goes out. Private to hdt_core.
#pragma once

#include "hdt/hdt_file.hpp"
#include "hdt/volume.hpp"
#include "hdt_file_format.hpp"
#include "hdt_file_zstd.hpp"
#include "hdt_leaf_encoder.hpp"

#include <cstdint>
#include <vector>

namespace hdt::hdt_file_detail {

// A volume ready to be written: small sections encoded, bulk sections
// checksummed (and the leaf data compressed), so every header is known before
// the first byte goes out and the output needs no seeking.
struct EncodedVolume {
  std::vector<uint8_t> grid, stats, levels;
  uint32_t elementsCrc = 0;
  Encoding leafEncoding = Encoding::Raw;
  uint64_t leafRawBytes = 0;
#if defined(HDT_HAVE_ZSTD)
  Compressed compressed;         // Encoding::Zstd
  zstd_blocks::Encoded blocks;   // Encoding::ZstdBlocks
#endif
  uint32_t leafCrc = 0;

  // Part labels (optional sections 16-18), when the volume has them.
  bool labelled = false;
  uint32_t labelElementsCrc = 0;
  Encoding labelVoxelEncoding = Encoding::Raw;
  std::vector<uint8_t, DefaultInitAllocator<uint8_t>> labelVoxelBytes; // section 21 decoded (freed once compressed)
  uint64_t labelVoxelRawBytes = 0;
#if defined(HDT_HAVE_ZSTD)
  Compressed labelVoxelsCompressed;
#endif
  uint32_t labelVoxelsCrc = 0;
  std::vector<uint8_t> labelNames; // empty: no names section

  // Transferred arrays (optional sections 19-20), when the volume has them.
  std::vector<uint8_t> arrayDirectory; // empty: no array sections
  uint64_t arrayValueBytes = 0;
  uint32_t arrayValuesCrc = 0;

  uint64_t leafStoredBytes() const {
#if defined(HDT_HAVE_ZSTD)
    if (leafEncoding == Encoding::Zstd) return compressed.size;
    if (leafEncoding == Encoding::ZstdBlocks) return blocks.storedBytes();
#endif
    return leafRawBytes;
  }
  uint64_t labelVoxelStoredBytes() const {
#if defined(HDT_HAVE_ZSTD)
    if (labelVoxelEncoding == Encoding::Zstd) return labelVoxelsCompressed.size;
#endif
    return labelVoxelRawBytes;
  }
};

// The whole volume. `leafCounts`: where the leaves go as zstd blocks on a
// little-endian host (leafCountsFromBlocks), it receives their counts, taken
// as the blocks were compressed.
EncodedVolume encode(const Volume& v, const HdtWriteOptions& options, HdtLeafEncoder* streamed, LeafCounts* leafCounts);
// Whether encode counts the leaf words as it compresses them.
bool leafCountsFromBlocks(const Volume& v, const HdtWriteOptions& options);

// Parts of encode, for the writer that streams the leaf data (its leaf
// section is written as the blocks are compressed).
void encodeSmallSections(const Volume& v, EncodedVolume& e);
void encodeLabels(const Volume& v, const HdtWriteOptions& options, EncodedVolume& e);
void encodeArrays(const Volume& v, EncodedVolume& e);

// The size of the file emitted from `e`.
uint64_t encodedSize(const EncodedVolume& e, const Volume& v);

} // namespace hdt::hdt_file_detail
