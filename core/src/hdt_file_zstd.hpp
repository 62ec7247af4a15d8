// zstd for the .hdt sections: one frame (encoding 1: leaf data of version 2,
// compact label voxels) and the leaf data's blocks (encoding 2, zstd_blocks.hpp).
// Every check of a stored frame reads only its headers, so that it runs before
// the decoded size is allocated (docs/hdt-format.md: nothing allocated on
// trust). Private to hdt_core; empty without zstd.
#pragma once

#if defined(HDT_HAVE_ZSTD)
#include "hdt/volume.hpp"
#include "hdt_leaf_encoder.hpp"
#include "zstd_blocks.hpp"

#include <cstdint>
#include <memory>
#include <string>
#include <vector>

namespace hdt::hdt_file_detail {

// One zstd frame stating its content size.
struct Compressed {
  std::unique_ptr<uint8_t[]> data;
  size_t size = 0;
};
using ByteVector = std::vector<uint8_t, DefaultInitAllocator<uint8_t>>;
// The little-endian bytes of the words as one frame; large inputs with zstd's workers.
Compressed compressWords(const LeafWordVector& words, int level);
Compressed compressWords(const ByteVector& bytes, int level);

// `srcSize` bytes are exactly one zstd frame stating `dstSize` bytes;
// `what` names the section in the messages.
void checkLeafFrame(const uint8_t* src, size_t srcSize, size_t dstSize, const std::string& what = "leaf data");
// Decodes exactly `dstSize` bytes from a frame checkLeafFrame accepted.
void decompressLeaves(const uint8_t* src, size_t srcSize, uint8_t* dst, size_t dstSize,
                      const std::string& what = "leaf data");

// The leaf words as zstd blocks; `counts` (when not null, little-endian
// hosts) receives their leaf counts, taken block by block.
zstd_blocks::Encoded compressLeafBlocks(const LeafWordVector& words, int level, LeafCounts* counts = nullptr);
// Encoding 2: the table and every frame header, checked before the decoded
// size is allocated; then the blocks decoded into `dst`.
zstd_blocks::Layout checkLeafBlocks(const uint8_t* stored, size_t storedBytes, uint64_t rawBytes);
void decompressLeafBlocks(const uint8_t* stored, const zstd_blocks::Layout& layout, uint8_t* dst, size_t rawBytes);

} // namespace hdt::hdt_file_detail
#endif
