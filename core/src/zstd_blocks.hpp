// Encoding 2 of the .hdt leaf data (docs/hdt-format.md, "Zstd blocks"): the
// raw bytes cut into blocks of 2^b bytes, each compressed on its own into one
// zstd frame, behind a table of the frames' lengths. The blocks are compressed
// and decoded in parallel (oneTBB); the bytes depend only on the data, the
// block size and the level, never on the thread count. Private to hdt_core.
#pragma once

#if defined(HDT_HAVE_ZSTD)

#include <cstddef>
#include <cstdint>
#include <functional>
#include <stdexcept>
#include <string>
#include <vector>

namespace hdt {
namespace zstd_blocks {

// What the writer uses: 2 MiB blocks, zstd's own window at level 3, so
// cutting costs little ratio and a 0.4 GB volume gives 190 parallel tasks.
constexpr uint32_t kWriterBlockLog = 21;
// What a reader accepts (a table entry a 64 KiB block at least bounds the
// table by the raw size / 8 KiB).
constexpr uint32_t kMinBlockLog = 16, kMaxBlockLog = 30;
// The table's fixed part: u32 block log, u32 block count.
constexpr size_t kTableHeaderBytes = 8;

// A broken rule of the encoding; the caller names the section.
struct Invalid : std::runtime_error {
  using std::runtime_error::runtime_error;
};

// The encoded section: the table, then the frames in block order. `crc` is
// the CRC-32 of all of it as stored.
struct Encoded {
  std::vector<uint8_t> table;
  std::vector<std::vector<uint8_t>> frames;
  uint32_t crc = 0;
  uint64_t storedBytes() const;
};

// Called with each block's bytes by the task that compresses it, just before:
// a pass over the same bytes while they are in that core's cache (the
// writer's leaf checks). Blocks of one call run at once: write per block.
using BlockVisitor = std::function<void(uint64_t block, const uint8_t* bytes, size_t n)>;

// Compresses `size` bytes (already little-endian) at `level`. Throws
// hdt::Error(OutOfResources) when zstd fails.
Encoded compress(const uint8_t* data, size_t size, int level, uint32_t blockLog = kWriterBlockLog,
                 const BlockVisitor& visit = {});

// The same encoding a few blocks at a time, as their bytes become final
// (hdt::HdtLeafEncoder): compress() is this over all blocks at once, so the
// bytes are the same however the blocks are handed in.
class BlockCompressor {
public:
  BlockCompressor(size_t size, int level, uint32_t blockLog = kWriterBlockLog, BlockVisitor visit = {});
  ~BlockCompressor();
  BlockCompressor(const BlockCompressor&) = delete;
  BlockCompressor& operator=(const BlockCompressor&) = delete;
  uint64_t blocks() const;
  // Blocks [first, end) of `data` (the whole `size` bytes; only those blocks
  // are read), in parallel. Calls for disjoint ranges may run at once.
  void compressBlocks(const uint8_t* data, uint64_t first, uint64_t end);
  // Waits until block i is compressed and returns its frame, valid until
  // finish(); null once a compression has failed (the caller that runs the
  // tasks gets the error). For a writer that writes each frame as soon as it
  // is there.
  const std::vector<uint8_t>* waitForBlock(uint64_t i);
  // Once every block is compressed: the table and the CRC; the compressor is
  // then empty.
  Encoded finish();

private:
  void compressBlock(uint64_t i, const uint8_t* data, size_t bound);
  struct State;
  State* state_;
};

// Where each block's frame lies in the stored bytes, once checked.
struct Layout {
  uint32_t blockLog = 0;
  std::vector<size_t> frameStart, frameBytes;
};

// Checks the table and every frame header against `rawBytes` (exactly one
// frame a block, stating its block's size) without decoding or allocating
// more than the table: throws Invalid.
Layout check(const uint8_t* stored, size_t storedBytes, uint64_t rawBytes);

// Decodes a checked layout into `dst` (rawBytes), blocks in parallel. Throws
// Invalid naming the first block (in block order) that fails.
void decompress(const uint8_t* stored, const Layout& layout, uint8_t* dst, size_t rawBytes);

} // namespace zstd_blocks
} // namespace hdt

#endif
