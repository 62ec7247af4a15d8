// hdt::HdtLeafEncoder: the leaf data's zstd blocks compressed as the copy back
// brings their bytes. Each arrived() hands the blocks completed since the last
// one to a oneTBB task, which compresses them in parallel beside the copy. The
// tasks run in an arena of their own at low priority: the copy is the critical
// path, and a thread waiting for the copy's own tasks must not pick up a
// compression task (it would finish the copy only after that block).
#include "hdt_leaf_encoder.hpp"

#include <tbb/task_arena.h>
#include <tbb/task_group.h>

#include <cstring>
#include <optional>

namespace hdt {

constexpr bool kLittleEndianHost = __BYTE_ORDER__ == __ORDER_LITTLE_ENDIAN__;

// Where the compiler can pick the processor's bit count at load time (one
// copy of the function with POPCNT, one without, chosen by the loader), the
// leaf scan uses it: baseline x86-64 has none, and the portable bit count
// (popcount32) made this scan cost as much CPU as the leaves' compression.
#if defined(__x86_64__) && defined(__linux__) && defined(__has_attribute)
#if __has_attribute(target_clones)
#define HDT_POPCNT_CLONES __attribute__((target_clones("popcnt", "default")))
#endif
#endif
#ifndef HDT_POPCNT_CLONES
#define HDT_POPCNT_CLONES
#endif

// The voxel counts of `n` leaf words, two words a step; words with a field in
// the invalid state 3 are only flagged (the writer finds the first).
HDT_POPCNT_CLONES LeafCounts countLeafWords(const uint32_t* words, size_t n) {
  constexpr uint64_t inside = uint64_t(kInsidePlaneBits) << 32 | kInsidePlaneBits;
  uint64_t surfaceCount = 0, insideCount = 0, invalid = 0;
  size_t i = 0;
  for (; i + 2 <= n; i += 2) {
    uint64_t x;
    std::memcpy(&x, words + i, sizeof x); // words i and i + 1; the planes' bits keep their meaning
    insideCount += uint64_t(__builtin_popcountll(x & inside));
    surfaceCount += uint64_t(__builtin_popcountll(x & (inside << 1)));
    invalid |= x & (x >> 1) & inside;
  }
  for (; i < n; ++i) {
    insideCount += planeCount(words[i], kInsidePlane);
    surfaceCount += planeCount(words[i], kSurfacePlane);
    invalid |= invalidFields(words[i]);
  }
  return LeafCounts{surfaceCount, insideCount, invalid != 0 ? 1u : 0u};
}

struct HdtLeafEncoder::State {
  HdtWriteOptions options;
  bool used = false;
#if defined(HDT_HAVE_ZSTD)
  const uint32_t* words = nullptr;
  size_t count = 0;       // words of the volume being fed
  size_t arrivedWords = 0; // words [0, arrivedWords) final
  uint64_t handedOut = 0; // blocks [0, handedOut) given to a task
  std::optional<BlockLeafCounts> counts; // declared before the compressor, which holds its visitor
  std::optional<zstd_blocks::BlockCompressor> compressor;
  tbb::task_arena arena{tbb::task_arena::automatic, 1, tbb::task_arena::priority::low};
  tbb::task_group tasks;

  void wait() {
    arena.execute([this] { tasks.wait(); });
  }
#else
  void wait() {}
#endif
};

HdtLeafEncoder::State& leafEncoderState(HdtLeafEncoder& e) { return *e.state_; }

HdtLeafEncoder::HdtLeafEncoder(const HdtWriteOptions& options) : state_(new State) { state_->options = options; }

HdtLeafEncoder::~HdtLeafEncoder() {
  try {
    state_->wait();
  } catch (...) {
    // nobody takes these blocks any more
  }
}

void HdtLeafEncoder::waitForBlocks() { state_->wait(); }

void HdtLeafEncoder::abandon() {
  State& s = *state_;
  try {
    s.wait();
  } catch (...) {
    // the build's own error is the one to report
  }
#if defined(HDT_HAVE_ZSTD)
  s.compressor.reset();
  s.words = nullptr;
  s.count = s.arrivedWords = 0;
  s.handedOut = 0;
#endif
}

bool HdtLeafEncoder::usedByWriter() const { return state_->used; }

void HdtLeafEncoder::begin(const uint32_t* words, size_t count) {
  State& s = *state_;
  s.wait(); // a previous build's blocks
  s.used = false;
#if defined(HDT_HAVE_ZSTD)
  s.compressor.reset();
  s.words = words;
  s.count = count;
  s.arrivedWords = 0;
  s.handedOut = 0;
  // Only what the writer would write as blocks, from the words' own bytes.
  if (kLittleEndianHost && s.options.compressLeaves && s.options.leafBlocks && count > 0) {
    const size_t bytes = count * sizeof(uint32_t);
    s.counts.emplace((uint64_t(bytes) + (size_t(1) << zstd_blocks::kWriterBlockLog) - 1) >> zstd_blocks::kWriterBlockLog);
    s.compressor.emplace(bytes, s.options.zstdLevel, zstd_blocks::kWriterBlockLog, s.counts->visitor());
  }
#else
  (void)words;
  (void)count;
#endif
}

void HdtLeafEncoder::arrived(size_t count) {
#if defined(HDT_HAVE_ZSTD)
  State& s = *state_;
  if (!s.compressor || count > s.count || count < s.arrivedWords) return;
  s.arrivedWords = count;
  const uint64_t complete = count == s.count ? s.compressor->blocks()
                                             : (uint64_t(count) * sizeof(uint32_t)) >> zstd_blocks::kWriterBlockLog;
  if (complete <= s.handedOut) return;
  const uint64_t first = s.handedOut;
  s.handedOut = complete;
  const uint8_t* data = reinterpret_cast<const uint8_t*>(s.words);
  zstd_blocks::BlockCompressor* c = &*s.compressor;
  s.arena.execute([&s, c, data, first, complete] {
    s.tasks.run([c, data, first, complete] { c->compressBlocks(data, first, complete); });
  });
#else
  (void)count;
#endif
}

#if defined(HDT_HAVE_ZSTD)
namespace {
bool covers(const HdtLeafEncoder::State& s, const LeafWordVector& words, const HdtWriteOptions& options) {
  return s.compressor && s.words == words.data() && s.count == words.size() && s.arrivedWords == s.count &&
         s.handedOut == s.compressor->blocks() && options.compressLeaves && options.leafBlocks &&
         options.zstdLevel == s.options.zstdLevel;
}
} // namespace

zstd_blocks::BlockCompressor* streamingLeafBlocks(HdtLeafEncoder& encoder, const LeafWordVector& words,
                                                  const HdtWriteOptions& options) {
  HdtLeafEncoder::State& s = leafEncoderState(encoder);
  return covers(s, words, options) ? &*s.compressor : nullptr;
}

std::unique_ptr<zstd_blocks::Encoded> takeStreamedLeafBlocks(HdtLeafEncoder& encoder, const LeafWordVector& words,
                                                             const HdtWriteOptions& options, LeafCounts* counts) {
  HdtLeafEncoder::State& s = leafEncoderState(encoder);
  s.wait();
  if (!covers(s, words, options)) return nullptr;
  auto e = std::make_unique<zstd_blocks::Encoded>(s.compressor->finish());
  if (counts) *counts = s.counts->total();
  s.compressor.reset();
  s.used = true;
  return e;
}
#endif

} // namespace hdt
