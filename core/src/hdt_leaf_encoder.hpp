// The writer's side of hdt::HdtLeafEncoder (hdt_file.hpp). Private to hdt_core.
#pragma once

#include "hdt/hdt_file.hpp"
#include "zstd_blocks.hpp"

#include <memory>
#include <vector>

namespace hdt {

// The voxel counts of leaf words, for the writer's checks (rule 19 and the
// statistics): invalidWords is 0, or not 0 when some field is in the invalid
// state 3 (the writer then finds the first).
struct LeafCounts {
  uint64_t surface = 0, inside = 0, invalidWords = 0;
  LeafCounts& operator+=(const LeafCounts& o) {
    surface += o.surface;
    inside += o.inside;
    invalidWords += o.invalidWords;
    return *this;
  }
};
LeafCounts countLeafWords(const uint32_t* words, size_t n);

#if defined(HDT_HAVE_ZSTD)
// The leaf counts of each zstd block, taken by the tasks that compress the
// blocks (the words are then in that core's cache): the writer's leaf check
// without a second pass over the volume. Little-endian hosts (the block bytes
// are the words).
class BlockLeafCounts {
public:
  explicit BlockLeafCounts(uint64_t blocks) : perBlock_(size_t(blocks)) {}
  zstd_blocks::BlockVisitor visitor() {
    return [this](uint64_t block, const uint8_t* bytes, size_t n) {
      perBlock_[size_t(block)] = countLeafWords(reinterpret_cast<const uint32_t*>(bytes), n / sizeof(uint32_t));
    };
  }
  LeafCounts total() const {
    LeafCounts t;
    for (const LeafCounts& c : perBlock_) t += c;
    return t;
  }

private:
  std::vector<LeafCounts> perBlock_;
};

// Waits for the blocks in flight, then hands over the encoded leaf data when
// the encoder was fed exactly `words` (all of them) at the options' level;
// null otherwise (the writer then compresses). Rethrows a compression error.
// The encoder's blocks when they cover exactly `words` with the options' level
// (every word has arrived and every block is handed to a task), so that a
// writer may write each frame as soon as it is compressed (waitForBlock), then
// take the blocks; null otherwise. Does not wait.
zstd_blocks::BlockCompressor* streamingLeafBlocks(HdtLeafEncoder& encoder, const LeafWordVector& words,
                                                  const HdtWriteOptions& options);

// `counts` (when not null) receives the blocks' leaf counts.
std::unique_ptr<zstd_blocks::Encoded> takeStreamedLeafBlocks(HdtLeafEncoder& encoder, const LeafWordVector& words,
                                                             const HdtWriteOptions& options, LeafCounts* counts = nullptr);
#endif

} // namespace hdt
