#include "zstd_blocks.hpp"

#if defined(HDT_HAVE_ZSTD)

#include "hdt/error.hpp"

#include <tbb/enumerable_thread_specific.h>
#include <tbb/parallel_for.h>
#include <zlib.h>
#include <zstd.h>

#include <algorithm>
#include <atomic>
#include <condition_variable>
#include <mutex>
#include <memory>
#include <new>
#include <utility>

namespace hdt {
namespace zstd_blocks {
namespace {

struct CCtxFree {
  void operator()(ZSTD_CCtx* c) const { ZSTD_freeCCtx(c); }
};
struct DCtxFree {
  void operator()(ZSTD_DCtx* d) const { ZSTD_freeDCtx(d); }
};

std::string str(uint64_t v) { return std::to_string(v); }

void putLe(std::vector<uint8_t>& out, uint64_t v, int bytes) {
  for (int i = 0; i < bytes; ++i) out.push_back(uint8_t(v >> (8 * i)));
}
uint64_t getLe(const uint8_t* p, int bytes) {
  uint64_t v = 0;
  for (int i = 0; i < bytes; ++i) v |= uint64_t(p[i]) << (8 * i);
  return v;
}

uint32_t crcOf(const uint8_t* p, size_t n) { // n < 4 GiB: blocks and tables
  return static_cast<uint32_t>(crc32(0, p, static_cast<uInt>(n)));
}

uint64_t blockCount(uint64_t rawBytes, uint32_t blockLog) {
  return (rawBytes + (uint64_t(1) << blockLog) - 1) >> blockLog;
}
size_t blockBytes(uint64_t rawBytes, uint32_t blockLog, uint64_t i) {
  return size_t(std::min<uint64_t>(uint64_t(1) << blockLog, rawBytes - (i << blockLog)));
}

} // namespace

uint64_t Encoded::storedBytes() const {
  uint64_t n = table.size();
  for (const auto& f : frames) n += f.size();
  return n;
}

struct BlockCompressor::State {
  size_t size;
  int level;
  uint32_t blockLog;
  BlockVisitor visit;
  Encoded e;
  std::vector<uint32_t> crcs;
  // Which blocks are compressed, for waitForBlock.
  std::unique_ptr<std::atomic<bool>[]> done;
  bool failed = false; // under `m`
  std::mutex m;
  std::condition_variable blockDone;
  void announce(uint64_t i, bool ok) {
    {
      std::lock_guard<std::mutex> lock(m); // a waiter sees the flag or gets the notification
      if (ok) done[size_t(i)].store(true, std::memory_order_release);
      else failed = true;
    }
    blockDone.notify_all();
  }
  // Each thread compresses into its own worst-case buffer, then keeps an
  // exact-size copy: the working set is one bound a thread, not a block.
  struct Worker {
    std::unique_ptr<ZSTD_CCtx, CCtxFree> cctx{ZSTD_createCCtx()};
    std::vector<uint8_t> scratch;
  };
  tbb::enumerable_thread_specific<Worker> workers;
};

BlockCompressor::BlockCompressor(size_t size, int level, uint32_t blockLog, BlockVisitor visit) : state_(new State) {
  state_->size = size;
  state_->visit = std::move(visit);
  state_->level = level;
  state_->blockLog = blockLog;
  const uint64_t n = blockCount(size, blockLog);
  state_->e.frames.resize(static_cast<size_t>(n));
  state_->crcs.resize(static_cast<size_t>(n));
  state_->done.reset(new std::atomic<bool>[size_t(n)]);
  for (uint64_t i = 0; i < n; ++i) state_->done[size_t(i)].store(false, std::memory_order_relaxed);
}

const std::vector<uint8_t>* BlockCompressor::waitForBlock(uint64_t i) {
  State& st = *state_;
  if (!st.done[size_t(i)].load(std::memory_order_acquire)) {
    std::unique_lock<std::mutex> lock(st.m);
    st.blockDone.wait(lock, [&] { return st.failed || st.done[size_t(i)].load(std::memory_order_acquire); });
    if (!st.done[size_t(i)].load(std::memory_order_acquire)) return nullptr;
  }
  return &st.e.frames[size_t(i)];
}

BlockCompressor::~BlockCompressor() { delete state_; }

uint64_t BlockCompressor::blocks() const { return state_->e.frames.size(); }

void BlockCompressor::compressBlocks(const uint8_t* data, uint64_t first, uint64_t end) {
  State& st = *state_;
  const size_t bound = ZSTD_compressBound(size_t(1) << st.blockLog);
  tbb::parallel_for(first, end, [&](uint64_t i) {
    try {
      compressBlock(i, data, bound);
    } catch (...) {
      st.announce(i, false);
      throw;
    }
    st.announce(i, true);
  });
}

void BlockCompressor::compressBlock(uint64_t i, const uint8_t* data, size_t bound) {
  State& st = *state_;
  State::Worker& w = st.workers.local();
  if (!w.cctx) throw std::bad_alloc();
  if (w.scratch.size() < bound) w.scratch.resize(bound);
  const size_t bytes = blockBytes(st.size, st.blockLog, i);
  if (st.visit) st.visit(i, data + (i << st.blockLog), bytes);
  // One-shot: the frame states its content size, and the output depends
  // only on the block and the level (no workers, no shared state).
  const size_t c =
      ZSTD_compressCCtx(w.cctx.get(), w.scratch.data(), bound, data + (i << st.blockLog), bytes, st.level);
  if (ZSTD_isError(c)) throw Error(ErrorKind::OutOfResources, std::string("zstd compress: ") + ZSTD_getErrorName(c));
  st.e.frames[size_t(i)].assign(w.scratch.data(), w.scratch.data() + c);
  st.crcs[size_t(i)] = crcOf(st.e.frames[size_t(i)].data(), c);
}

Encoded BlockCompressor::finish() {
  State& st = *state_;
  Encoded e = std::move(st.e);
  putLe(e.table, st.blockLog, 4);
  putLe(e.table, e.frames.size(), 4);
  for (const auto& f : e.frames) putLe(e.table, f.size(), 8);
  uLong crc = crcOf(e.table.data(), e.table.size());
  for (size_t i = 0; i < e.frames.size(); ++i) crc = crc32_combine(crc, st.crcs[i], z_off_t(e.frames[i].size()));
  e.crc = static_cast<uint32_t>(crc);
  st.e = Encoded();
  st.crcs.clear();
  st.done.reset();
  st.workers.clear();
  return e;
}

Encoded compress(const uint8_t* data, size_t size, int level, uint32_t blockLog, const BlockVisitor& visit) {
  BlockCompressor c(size, level, blockLog, visit);
  c.compressBlocks(data, 0, c.blocks());
  return c.finish();
}

Layout check(const uint8_t* stored, size_t storedBytes, uint64_t rawBytes) {
  if (storedBytes < kTableHeaderBytes)
    throw Invalid("the zstd block table is cut short (" + str(storedBytes) + " bytes stored)");
  Layout l;
  l.blockLog = uint32_t(getLe(stored, 4));
  if (l.blockLog < kMinBlockLog || l.blockLog > kMaxBlockLog) {
    throw Invalid("zstd block size 2^" + str(l.blockLog) + " is outside 2^" + str(kMinBlockLog) + " to 2^" +
                  str(kMaxBlockLog));
  }
  const uint64_t n = getLe(stored + 4, 4), expected = blockCount(rawBytes, l.blockLog);
  if (n != expected) throw Invalid(str(n) + " zstd blocks, expected " + str(expected));
  // n <= raw / 64 KiB + 1, and the raw size is bounded by the file already;
  // the table must still fit in the section before it is read.
  if (n > (storedBytes - kTableHeaderBytes) / 8) {
    throw Invalid("the zstd block table of " + str(n) + " blocks does not fit in " + str(storedBytes) + " bytes");
  }
  size_t at = kTableHeaderBytes + size_t(n) * 8;
  l.frameStart.resize(size_t(n));
  l.frameBytes.resize(size_t(n));
  for (uint64_t i = 0; i < n; ++i) {
    const uint64_t length = getLe(stored + kTableHeaderBytes + 8 * i, 8);
    if (length > storedBytes - at) {
      throw Invalid("zstd block " + str(i) + " of " + str(length) + " bytes runs past the section");
    }
    const uint8_t* frame = stored + at;
    const size_t bytes = blockBytes(rawBytes, l.blockLog, i);
    const unsigned long long content = ZSTD_getFrameContentSize(frame, size_t(length));
    if (content == ZSTD_CONTENTSIZE_ERROR) throw Invalid("zstd block " + str(i) + " is not a zstd frame");
    if (content == ZSTD_CONTENTSIZE_UNKNOWN)
      throw Invalid("zstd block " + str(i) + ": the frame does not state its size");
    if (content != bytes) {
      throw Invalid("zstd block " + str(i) + " holds " + str(content) + " bytes, expected " + str(bytes));
    }
    const size_t frameBytes = ZSTD_findFrameCompressedSize(frame, size_t(length));
    if (ZSTD_isError(frameBytes) || frameBytes != length)
      throw Invalid("zstd block " + str(i) + " is not exactly one zstd frame");
    l.frameStart[size_t(i)] = at;
    l.frameBytes[size_t(i)] = size_t(length);
    at += size_t(length);
  }
  if (at != storedBytes) throw Invalid(str(storedBytes - at) + " bytes after the last zstd block");
  return l;
}

void decompress(const uint8_t* stored, const Layout& layout, uint8_t* dst, size_t rawBytes) {
  const size_t n = layout.frameStart.size();
  std::atomic<size_t> firstBad{n};
  tbb::enumerable_thread_specific<std::unique_ptr<ZSTD_DCtx, DCtxFree>> contexts;
  tbb::parallel_for(size_t(0), n, [&](size_t i) {
    auto& d = contexts.local();
    if (!d) d.reset(ZSTD_createDCtx());
    if (!d) throw std::bad_alloc();
    const size_t bytes = blockBytes(rawBytes, layout.blockLog, i);
    // One-shot into the volume: zstd never writes beyond `bytes`.
    const size_t got = ZSTD_decompressDCtx(d.get(), dst + (i << layout.blockLog), bytes,
                                           stored + layout.frameStart[i], layout.frameBytes[i]);
    if (ZSTD_isError(got) || got != bytes) {
      size_t seen = firstBad.load();
      while (i < seen && !firstBad.compare_exchange_weak(seen, i)) {
      }
    }
  });
  const size_t bad = firstBad.load();
  if (bad != n) throw Invalid("zstd block " + str(bad) + " does not decode to its " +
                              str(blockBytes(rawBytes, layout.blockLog, bad)) + " bytes");
}

} // namespace zstd_blocks
} // namespace hdt

#endif
