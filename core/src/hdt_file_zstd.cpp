// zstd for the .hdt sections (hdt_file_zstd.hpp).
#include "hdt_file_zstd.hpp"

#if defined(HDT_HAVE_ZSTD)
#include "hdt_file_format.hpp"

#include "hdt/error.hpp"

#include <zstd.h>

#include <algorithm>
#include <thread>

namespace hdt::hdt_file_detail {
namespace {

struct CCtxFree {
  void operator()(ZSTD_CCtx* c) const { ZSTD_freeCCtx(c); }
};
struct DCtxFree {
  void operator()(ZSTD_DCtx* d) const { ZSTD_freeDCtx(d); }
};

void zstdCheck(size_t code, const char* what) {
  if (ZSTD_isError(code))
    throw Error(ErrorKind::OutOfResources, std::string("zstd ") + what + ": " + ZSTD_getErrorName(code));
}

// One zstd frame stating its content size. The output buffer has room for the
// worst case (ZSTD_compressBound), so the loop never waits for space; pages of
// it that are not written are never touched.
template <class Words> Compressed compressWordsOf(const Words& words, int level) {
  const size_t rawBytes = words.size() * sizeof(words[0]);
  std::unique_ptr<ZSTD_CCtx, CCtxFree> cctx(ZSTD_createCCtx());
  if (!cctx) throw std::bad_alloc();
  zstdCheck(ZSTD_CCtx_setParameter(cctx.get(), ZSTD_c_compressionLevel, level), "level");
  zstdCheck(ZSTD_CCtx_setParameter(cctx.get(), ZSTD_c_contentSizeFlag, 1), "content size flag");
  zstdCheck(ZSTD_CCtx_setPledgedSrcSize(cctx.get(), rawBytes), "pledged size");
  if (rawBytes >= (size_t(16) << 20)) {
    // Large volumes: let zstd compress in parallel. Fails harmlessly (and we
    // stay single-threaded) when the library was built without threads.
    const int workers = int(std::min(16u, std::max(1u, std::thread::hardware_concurrency())));
    ZSTD_CCtx_setParameter(cctx.get(), ZSTD_c_nbWorkers, workers);
  }
  Compressed out;
  const size_t capacity = ZSTD_compressBound(rawBytes);
  out.data.reset(new uint8_t[capacity]);
  ZSTD_outBuffer dst{out.data.get(), capacity, 0};
  forEachLittleEndianChunk(words.data(), words.size(), [&](const uint8_t* p, size_t n) {
    ZSTD_inBuffer src{p, n, 0};
    while (src.pos < src.size)
      zstdCheck(ZSTD_compressStream2(cctx.get(), &dst, &src, ZSTD_e_continue), "compress");
  });
  ZSTD_inBuffer none{nullptr, 0, 0};
  size_t left;
  do {
    left = ZSTD_compressStream2(cctx.get(), &dst, &none, ZSTD_e_end);
    zstdCheck(left, "compress");
  } while (left != 0);
  out.size = dst.pos;
  return out;
}

} // namespace

Compressed compressWords(const LeafWordVector& words, int level) { return compressWordsOf(words, level); }
Compressed compressWords(const ByteVector& bytes, int level) { return compressWordsOf(bytes, level); }

// Checks that `srcSize` bytes are exactly one zstd frame stating a content
// size of `dstSize`. Reads only the frame's headers, so it runs before the
// destination is allocated (docs/hdt-format.md: nothing allocated on trust).
void checkLeafFrame(const uint8_t* src, size_t srcSize, size_t dstSize, const std::string& what) {
  const unsigned long long content = ZSTD_getFrameContentSize(src, srcSize);
  if (content == ZSTD_CONTENTSIZE_ERROR) invalid(what + ": not a zstd frame");
  if (content == ZSTD_CONTENTSIZE_UNKNOWN) invalid(what + ": the zstd frame does not state its size");
  if (content != dstSize) {
    invalid(what + ": the zstd frame holds " + str(content) + " bytes, expected " + str(dstSize));
  }
  const size_t frame = ZSTD_findFrameCompressedSize(src, srcSize);
  if (ZSTD_isError(frame) || frame != srcSize) invalid(what + ": not exactly one zstd frame");
}

// Decodes exactly `dstSize` bytes from a frame checkLeafFrame accepted.
void decompressLeaves(const uint8_t* src, size_t srcSize, uint8_t* dst, size_t dstSize,
                      const std::string& what) {
  std::unique_ptr<ZSTD_DCtx, DCtxFree> dctx(ZSTD_createDCtx());
  if (!dctx) throw std::bad_alloc();
  uint8_t none;
  // One-shot into the caller's buffer: zstd never writes beyond dstSize and
  // needs no window buffer of its own, whatever the frame header claims.
  const size_t n = ZSTD_decompressDCtx(dctx.get(), dstSize ? dst : &none, dstSize, src, srcSize);
  if (ZSTD_isError(n)) invalid(what + ": zstd: " + ZSTD_getErrorName(n));
  if (n != dstSize) invalid(what + ": the zstd frame decoded to " + str(n) + " bytes, expected " + str(dstSize));
}

// The leaf words as zstd blocks (encoding 2), from their little-endian bytes.
// On little-endian hosts `counts` (when not null) receives the leaf counts,
// taken block by block beside the compression.
zstd_blocks::Encoded compressLeafBlocks(const LeafWordVector& words, int level, LeafCounts* counts) {
  const size_t bytes = words.size() * sizeof(words[0]);
  if (kLittleEndianHost) {
    const uint8_t* data = reinterpret_cast<const uint8_t*>(words.data());
    if (!counts) return zstd_blocks::compress(data, bytes, level);
    BlockLeafCounts blockCounts((uint64_t(bytes) + (size_t(1) << zstd_blocks::kWriterBlockLog) - 1) >>
                                zstd_blocks::kWriterBlockLog);
    zstd_blocks::Encoded e = zstd_blocks::compress(data, bytes, level, zstd_blocks::kWriterBlockLog, blockCounts.visitor());
    *counts = blockCounts.total();
    return e;
  }
  std::vector<uint32_t> le(words.size());
  for (size_t i = 0; i < words.size(); ++i) le[i] = byteSwap(words[i]);
  return zstd_blocks::compress(reinterpret_cast<const uint8_t*>(le.data()), bytes, level);
}

// Encoding 2: the table and every frame header, checked before the decoded
// size is allocated; then the blocks decoded into `dst`.
zstd_blocks::Layout checkLeafBlocks(const uint8_t* stored, size_t storedBytes, uint64_t rawBytes) {
  try {
    return zstd_blocks::check(stored, storedBytes, rawBytes);
  } catch (const zstd_blocks::Invalid& x) {
    invalid(std::string("leaf data: ") + x.what());
  }
}
void decompressLeafBlocks(const uint8_t* stored, const zstd_blocks::Layout& layout, uint8_t* dst, size_t rawBytes) {
  try {
    zstd_blocks::decompress(stored, layout, dst, rawBytes);
  } catch (const zstd_blocks::Invalid& x) {
    invalid(std::string("leaf data: ") + x.what());
  }
}

} // namespace hdt::hdt_file_detail
#endif
