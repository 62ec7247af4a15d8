// Emitting an encoded volume as an .hdt file (hdt_file_write.hpp).
#include "hdt_file_write.hpp"

#include "hdt_file_checks.hpp"
#include "hdt_file_format.hpp"

#include "hdt/error.hpp"

#if defined(HDT_HAVE_ZSTD)
#include <zstd.h>
#endif

#include <fcntl.h>
#include <unistd.h>

#include <cerrno>
#include <cstring>
#include <exception>
#include <memory>
#include <new>
#include <stdexcept>
#include <thread>

namespace hdt::hdt_file_detail {

FileSink::FileSink(std::FILE* f, const std::string& path) : f_(f), path_(path) {
  const long at = std::ftell(f);
  written_ = started_ = at > 0 ? uint64_t(at) : 0;
}

void FileSink::write(const void* data, size_t size) {
  if (size != 0 && std::fwrite(data, 1, size, f_) != size) fail();
  written_ += size;
  if (written_ - started_ >= kWriteBackStep) startWriteBack();
}

void FileSink::patch(uint64_t at, const void* data, size_t size) {
  if (std::fflush(f_) != 0) fail();
  const uint8_t* p = static_cast<const uint8_t*>(data);
  while (size > 0) {
    const ssize_t n = ::pwrite(fileno(f_), p, size, off_t(at));
    if (n < 0 && errno == EINTR) continue;
    if (n <= 0) fail();
    p += n;
    at += uint64_t(n);
    size -= size_t(n);
  }
}

void FileSink::fail() const {
  throw Error(ErrorKind::OutputFailed, path_ + ": cannot write: " + std::strerror(errno));
}

void FileSink::startWriteBack() {
#if defined(__linux__) && defined(SYNC_FILE_RANGE_WRITE)
  if (std::fflush(f_) != 0) fail();
  // Errors are not reported here: the fsync at the commit reports them.
  ::sync_file_range(fileno(f_), off_t(started_), off_t(written_ - started_), SYNC_FILE_RANGE_WRITE);
#endif
  started_ = written_;
}

namespace {

void writeSectionHeader(Sink& out, Section id, Encoding encoding, uint64_t stored, uint64_t raw,
                        uint32_t crc) {
  ByteWriter w;
  w.u32(uint32_t(id));
  w.u32(uint32_t(encoding));
  w.u64(stored);
  w.u64(raw);
  w.u32(crc);
  out.write(w.bytes().data(), w.bytes().size());
}

void writeSmallSection(Sink& out, Section id, const std::vector<uint8_t>& payload) {
  writeSectionHeader(out, id, Encoding::Raw, payload.size(), payload.size(),
                     crc32Of(payload.data(), payload.size()));
  out.write(payload.data(), payload.size());
}

void emitLabels(const EncodedVolume& e, const Volume& v, Sink& out) {
  if (!e.labelled) return;
  const LabelField& f = v.labels;
  const uint64_t elementBytes = f.elementLabels.size() * sizeof(Label);
  writeSectionHeader(out, Section::LabelElements, Encoding::Raw, elementBytes, elementBytes, e.labelElementsCrc);
  forEachLittleEndianChunk(f.elementLabels.data(), f.elementLabels.size(),
                           [&](const uint8_t* p, size_t n) { out.write(p, n); });
  if (!e.labelNames.empty()) {
    const uint64_t n = e.labelNames.size();
    writeSectionHeader(out, Section::LabelNames, Encoding::Raw, n, n,
                       optionalSectionCrc(Section::LabelNames, Encoding::Raw, n, n, crc32Of(e.labelNames.data(), n)));
    out.write(e.labelNames.data(), n);
  }
}

// After the transferred arrays (19, 20): optional sections go in id order.
void emitCompactLabelVoxels(const EncodedVolume& e, Sink& out) {
  if (!e.labelled) return;
  writeSectionHeader(out, Section::CompactLabelVoxels, e.labelVoxelEncoding, e.labelVoxelStoredBytes(),
                     e.labelVoxelRawBytes, e.labelVoxelsCrc);
#if defined(HDT_HAVE_ZSTD)
  if (e.labelVoxelEncoding == Encoding::Zstd) out.write(e.labelVoxelsCompressed.data.get(), e.labelVoxelsCompressed.size);
#endif
  if (e.labelVoxelEncoding == Encoding::Raw) out.write(e.labelVoxelBytes.data(), e.labelVoxelBytes.size());
}

void emitArrays(const EncodedVolume& e, const Volume& v, Sink& out) {
  if (e.arrayDirectory.empty()) return;
  const uint64_t n = e.arrayDirectory.size();
  writeSectionHeader(out, Section::ArrayDirectory, Encoding::Raw, n, n,
                     optionalSectionCrc(Section::ArrayDirectory, Encoding::Raw, n, n, crc32Of(e.arrayDirectory.data(), n)));
  out.write(e.arrayDirectory.data(), n);
  writeSectionHeader(out, Section::ArrayValues, Encoding::Raw, e.arrayValueBytes, e.arrayValueBytes, e.arrayValuesCrc);
  for (const VoxelArray& a : v.arrays)
    forEachLittleEndianChunk(a.values.data(), a.values.size(), [&](const uint8_t* p, size_t k) { out.write(p, k); });
}

// The file header and the required sections before the leaf data.
void emitHead(const EncodedVolume& e, const Volume& v, Sink& out) {
  ByteWriter header;
  header.raw(kMagic, 4);
  header.u32(e.leafEncoding == Encoding::ZstdBlocks ? kFirstBlocksVersion : 2u);
  header.u32(isCompressed(e.leafEncoding) ? kFlagLeafZstd : 0u);
  out.write(header.bytes().data(), header.bytes().size());

  writeSmallSection(out, Section::Grid, e.grid);
  writeSmallSection(out, Section::Statistics, e.stats);
  writeSmallSection(out, Section::LevelTable, e.levels);

  const uint64_t elementBytes = uint64_t(v.elements.size()) * 4;
  writeSectionHeader(out, Section::Elements, Encoding::Raw, elementBytes, elementBytes, e.elementsCrc);
  forEachLittleEndianChunk(v.elements.data(), v.elements.size(),
                           [&](const uint8_t* p, size_t n) { out.write(p, n); });
}

void emitLeaves(const EncodedVolume& e, const Volume& v, Sink& out) {
  writeSectionHeader(out, Section::LeafData, e.leafEncoding, e.leafStoredBytes(), e.leafRawBytes, e.leafCrc);
  bool leavesWritten = false;
#if defined(HDT_HAVE_ZSTD)
  if (e.leafEncoding == Encoding::Zstd) {
    out.write(e.compressed.data.get(), e.compressed.size);
    leavesWritten = true;
  }
  if (e.leafEncoding == Encoding::ZstdBlocks) {
    out.write(e.blocks.table.data(), e.blocks.table.size());
    for (const auto& frame : e.blocks.frames) out.write(frame.data(), frame.size());
    leavesWritten = true;
  }
#endif
  if (!leavesWritten) {
    forEachLittleEndianChunk(v.leafWords.data(), v.leafWords.size(),
                             [&](const uint8_t* p, size_t n) { out.write(p, n); });
  }
}

// The optional sections after the leaf data, then the end.
void emitTail(const EncodedVolume& e, const Volume& v, Sink& out) {
  emitLabels(e, v, out);
  emitArrays(e, v, out);
  emitCompactLabelVoxels(e, out);
  writeSectionHeader(out, Section::End, Encoding::Raw, 0, 0, 0);
}

#if defined(HDT_HAVE_ZSTD)
// The leaf frames written as the build's streamed blocks are compressed,
// during the compression rather than after it (so the emit and the disk's
// write-back overlap it); the leaf section's header and block table, which
// need every frame's size and the CRC, are written last over zeros reserved
// for them. The same bytes as encode + emit.
void emitStreaming(const Volume& v, const HdtWriteOptions& options, HdtLeafEncoder& streamed,
                   zstd_blocks::BlockCompressor& blocks, FileSink& out, LeafCounts* blockLeaves) {
  EncodedVolume e;
  encodeSmallSections(v, e);
  e.leafEncoding = Encoding::ZstdBlocks;
  encodeLabels(v, options, e);
  encodeArrays(v, e);
  emitHead(e, v, out);
  const uint64_t leafAt = out.position(), n = blocks.blocks();
  const std::vector<uint8_t> reserved(kSectionHeaderBytes + zstd_blocks::kTableHeaderBytes + 8 * size_t(n));
  out.write(reserved.data(), reserved.size());
  for (uint64_t i = 0; i < n; ++i) {
    const std::vector<uint8_t>* frame = blocks.waitForBlock(i);
    if (!frame) break; // a compression failed: taking the blocks rethrows its error
    out.write(frame->data(), frame->size());
  }
  std::unique_ptr<zstd_blocks::Encoded> done = takeStreamedLeafBlocks(streamed, v.leafWords, options, blockLeaves);
  if (!done) throw std::logic_error("the streamed leaf blocks stopped covering the volume");
  e.blocks = std::move(*done);
  e.leafCrc = e.blocks.crc;
  std::vector<uint8_t> head;
  VectorSink headSink(head);
  writeSectionHeader(headSink, Section::LeafData, e.leafEncoding, e.leafStoredBytes(), e.leafRawBytes, e.leafCrc);
  headSink.write(e.blocks.table.data(), e.blocks.table.size());
  if (head.size() != reserved.size()) throw std::logic_error("the leaf block table's size changed");
  out.patch(leafAt, head.data(), head.size());
  emitTail(e, v, out);
}
#endif

// The zstd level is one zstd has.
void checkLevel(const HdtWriteOptions& options) {
#if defined(HDT_HAVE_ZSTD)
  if (options.compressLeaves &&
      (options.zstdLevel < ZSTD_minCLevel() || options.zstdLevel > ZSTD_maxCLevel())) {
    throw Error(ErrorKind::InvalidArgument, "zstd level " + std::to_string(options.zstdLevel) +
                                                " is out of range [" + std::to_string(ZSTD_minCLevel()) +
                                                ", " + std::to_string(ZSTD_maxCLevel()) + "]");
  }
#else
  (void)options;
#endif
}

// Checks the volume beside `encodeStep(LeafCounts* blockLeaves)`, which
// encodes (and may write): the checks' verdict comes first, as if they had
// run alone, then the encoding's error. Throws hdt::Error.
template <class EncodeStep>
void checkedEncode(const Volume& v, const HdtWriteOptions& options, const std::string& name, EncodeStep&& encodeStep) {
  checkLevel(options);
  // The checks and the encoding both only read the volume: they run at the
  // same time. Leaves written as zstd blocks are counted by the tasks that
  // compress them, block by block while the block is in cache (a second pass
  // over the volume cost as much as a third of the compression); the checker
  // leaves them out. The checks' verdict comes first, as if they had run alone.
  const bool countsFromBlocks = leafCountsFromBlocks(v, options);
  std::exception_ptr checkError;
  TreeCounts tree;
  LeafCounts leaves;
  std::thread checker([&] {
    try {
      tree = checkVolumeTree(v);
      if (!countsFromBlocks) leaves = checkLeaves(v.leafWords, v.grid.leafSize, v.surfaceOnly);
    } catch (...) {
      checkError = std::current_exception();
    }
  });
  LeafCounts blockLeaves;
  std::exception_ptr encodeError;
  try {
    encodeStep(countsFromBlocks ? &blockLeaves : nullptr);
  } catch (...) {
    encodeError = std::current_exception();
  }
  checker.join();
  try {
    if (checkError) std::rethrow_exception(checkError);
    if (countsFromBlocks && !encodeError) {
      checkLeafCounts(blockLeaves, v.leafWords, v.grid.leafSize, v.surfaceOnly);
      leaves = blockLeaves;
    } else if (countsFromBlocks) {
      leaves = checkLeaves(v.leafWords, v.grid.leafSize, v.surfaceOnly); // the encoding failed before counting
    }
    checkVolumeRest(v, tree, leaves, StatisticsOf::Contents);
  } catch (const Invalid& x) {
    throw Error(ErrorKind::InvalidArgument, name + ": refusing to write an inconsistent volume: " + x.what());
  }
  try {
    if (encodeError) std::rethrow_exception(encodeError);
  } catch (const Error& x) { // zstd failures; the file's own errors name it already
    if (x.kind() == ErrorKind::OutputFailed) throw;
    throw Error(x.kind(), name + ": " + x.what());
  } catch (const std::bad_alloc&) {
    throw Error(ErrorKind::OutOfResources, name + ": out of memory while encoding the volume");
  }
}

} // namespace

void emit(const EncodedVolume& e, const Volume& v, Sink& out) {
  emitHead(e, v, out);
  emitLeaves(e, v, out);
  emitTail(e, v, out);
}

EncodedVolume prepare(const Volume& v, const HdtWriteOptions& options, const std::string& name,
                      HdtLeafEncoder* streamed) {
  EncodedVolume e;
  checkedEncode(v, options, name, [&](LeafCounts* blockLeaves) { e = encode(v, options, streamed, blockLeaves); });
  return e;
}

bool writeStreaming(const Volume& volume, std::FILE* f, const std::string& path, const HdtWriteOptions& options,
                    HdtLeafEncoder* streamed) {
#if defined(HDT_HAVE_ZSTD)
  zstd_blocks::BlockCompressor* blocks =
      streamed ? streamingLeafBlocks(*streamed, volume.leafWords, options) : nullptr;
  if (!blocks) return false;
  FileSink sink(f, path);
  checkedEncode(volume, options, path, [&](LeafCounts* blockLeaves) {
    emitStreaming(volume, options, *streamed, *blocks, sink, blockLeaves);
  });
  return true;
#else
  (void)volume;
  (void)f;
  (void)path;
  (void)options;
  (void)streamed;
  return false;
#endif
}

} // namespace hdt::hdt_file_detail
