// Encoding a volume's sections for the .hdt writer (hdt_file_encode.hpp).
#include "hdt_file_encode.hpp"

#include "hdt/labels.hpp"
#include "hdt/transfer.hpp"

#include <zlib.h>

#include <cstring>

namespace hdt::hdt_file_detail {
namespace {

std::vector<uint8_t> encodeLabelNames(const std::map<Label, std::string>& names) {
  ByteWriter w;
  w.u32(uint32_t(names.size()));
  for (const auto& [label, name] : names) {
    w.u32(uint32_t(label) | (uint32_t(name.size()) << 16));
    w.raw(name.data(), name.size());
  }
  return w.bytes();
}

// Appends the little-endian bytes of `words` at `at`; returns the end.
template <class T> uint8_t* putLittleEndian(uint8_t* at, const T* words, size_t count) {
  forEachLittleEndianChunk(words, count, [&](const uint8_t* p, size_t n) {
    std::memcpy(at, p, n);
    at += n;
  });
  return at;
}

// Section 21 decoded: u32 layout, the palettes, the palette indices, the wide labels.
std::vector<uint8_t, DefaultInitAllocator<uint8_t>> compactLabelVoxelBytes(const LabelField& f) {
  std::vector<uint8_t, DefaultInitAllocator<uint8_t>> bytes(4 + f.palettes.size() * sizeof(LeafPalette) +
                                                            f.paletteIndices.size() * 4 + f.wideLabels.size() * 2);
  const uint32_t layout = kCompactLabelLayout;
  uint8_t* at = putLittleEndian(bytes.data(), &layout, 1);
  static_assert(sizeof(LeafPalette) == kPaletteSize * sizeof(Label), "palettes are plain label arrays");
  at = putLittleEndian(at, reinterpret_cast<const Label*>(f.palettes.data()), f.palettes.size() * kPaletteSize);
  at = putLittleEndian(at, f.paletteIndices.data(), f.paletteIndices.size());
  putLittleEndian(at, f.wideLabels.data(), f.wideLabels.size());
  return bytes;
}

// Section 19: u32 count, then per array u32 name length, the name, u32
// source (0 point, 1 cell), u32 components.
std::vector<uint8_t> encodeArrayDirectory(const std::vector<VoxelArray>& arrays) {
  ByteWriter w;
  w.u32(uint32_t(arrays.size()));
  for (const VoxelArray& a : arrays) {
    w.u32(uint32_t(a.name.size()));
    w.raw(a.name.data(), a.name.size());
    w.u32(uint32_t(a.source));
    w.u32(a.components);
  }
  return w.bytes();
}

// Where the leaves go as zstd blocks on a little-endian host (leafCountsFromBlocks),
// `leafCounts` receives their counts, taken as the blocks were compressed.
EncodedVolume encodeRequired(const Volume& v, const HdtWriteOptions& options, HdtLeafEncoder* streamed,
                             LeafCounts* leafCounts) {
  EncodedVolume e;
  encodeSmallSections(v, e);
#if defined(HDT_HAVE_ZSTD)
  if (options.compressLeaves && !v.leafWords.empty() && options.leafBlocks) {
    e.leafEncoding = Encoding::ZstdBlocks;
    std::unique_ptr<zstd_blocks::Encoded> done =
        streamed ? takeStreamedLeafBlocks(*streamed, v.leafWords, options, leafCounts) : nullptr;
    e.blocks = done ? std::move(*done) : compressLeafBlocks(v.leafWords, options.zstdLevel, leafCounts);
    e.leafCrc = e.blocks.crc;
    return e;
  }
  if (options.compressLeaves && !v.leafWords.empty()) {
    e.leafEncoding = Encoding::Zstd;
    e.compressed = compressWords(v.leafWords, options.zstdLevel);
    e.leafCrc = crc32Of(e.compressed.data.get(), e.compressed.size);
    return e;
  }
#else
  (void)options;
  (void)streamed;
#endif
  (void)leafCounts;
  e.leafCrc = crcOfWords(v.leafWords);
  return e;
}

// Section 1.
std::vector<uint8_t> encodeGrid(const Volume& v) {
  const GridSpec& g = v.grid;
  ByteWriter w;
  w.u32(uint32_t(g.resolution));
  w.u32(uint32_t(g.rootGrid));
  w.u32(uint32_t(g.leafSize));
  w.u32(uint32_t(g.height));
  for (double o : g.origin) w.f64(o);
  w.f64(g.voxelSize);
  w.u32(v.surfaceOnly ? 1 : 0);
  w.u32(v.closedMesh ? 1 : 0);
  w.u32(uint32_t(v.insideTest));
  return w.bytes();
}

// Section 2: all of Statistics, in declaration order.
std::vector<uint8_t> encodeStatistics(const Statistics& s) {
  ByteWriter w;
  for (uint64_t x : {s.triangles, s.degenerateTriangles, s.treeElements, s.leafGrids, s.leafVoxels,
                     s.activeVoxels, s.insideVoxels})
    w.u64(x);
  w.f64(s.paperBitsPerActiveVoxel);
  w.u64(s.topologyBytes);
  w.u64(s.leafBytes);
  for (double t : {s.time.mapping, s.time.branching, s.time.leaf, s.time.classify, s.time.total}) w.f64(t);
  w.u64(s.peakHostBytes);
  w.u64(s.peakDeviceBytes);
  w.i32(s.threads);
  w.u32(uint32_t(s.backend.size()));
  w.raw(s.backend.data(), s.backend.size());
  return w.bytes();
}

// Section 3.
std::vector<uint8_t> encodeLevelTable(const std::vector<uint64_t>& levelStart) {
  ByteWriter w;
  for (uint64_t x : levelStart) w.u64(x);
  return w.bytes();
}

} // namespace

void encodeLabels(const Volume& v, const HdtWriteOptions& options, EncodedVolume& e) {
  const LabelField& f = v.labels;
  if (f.empty()) return;
  e.labelled = true;
  const uint64_t elementBytes = f.elementLabels.size() * sizeof(Label);
  e.labelElementsCrc = optionalSectionCrc(Section::LabelElements, Encoding::Raw, elementBytes, elementBytes,
                                          crcOfWords(f.elementLabels));
  e.labelVoxelBytes = compactLabelVoxelBytes(f);
  e.labelVoxelRawBytes = e.labelVoxelBytes.size();
#if defined(HDT_HAVE_ZSTD)
  if (options.compressLeaves) {
    e.labelVoxelEncoding = Encoding::Zstd;
    e.labelVoxelsCompressed = compressWords(e.labelVoxelBytes, options.zstdLevel);
    e.labelVoxelBytes = {};
    const Compressed& c = e.labelVoxelsCompressed;
    e.labelVoxelsCrc = optionalSectionCrc(Section::CompactLabelVoxels, Encoding::Zstd, c.size, e.labelVoxelRawBytes,
                                          crc32Of(c.data.get(), c.size));
  }
#else
  (void)options;
#endif
  if (e.labelVoxelEncoding == Encoding::Raw) {
    e.labelVoxelsCrc = optionalSectionCrc(Section::CompactLabelVoxels, Encoding::Raw, e.labelVoxelRawBytes,
                                          e.labelVoxelRawBytes, crc32Of(e.labelVoxelBytes.data(), e.labelVoxelRawBytes));
  }
  if (!f.names.empty()) e.labelNames = encodeLabelNames(f.names);
}

// Section 20: every array's float32 values, in directory order, raw.
void encodeArrays(const Volume& v, EncodedVolume& e) {
  if (v.arrays.empty()) return;
  e.arrayDirectory = encodeArrayDirectory(v.arrays);
  uint32_t crc = 0;
  for (const VoxelArray& a : v.arrays) {
    const uint64_t n = a.values.size() * sizeof(float);
    crc = static_cast<uint32_t>(crc32_combine(crc, crcOfWords(a.values), z_off_t(n)));
    e.arrayValueBytes += n;
  }
  e.arrayValuesCrc =
      optionalSectionCrc(Section::ArrayValues, Encoding::Raw, e.arrayValueBytes, e.arrayValueBytes, crc);
}

// The required sections but the leaf data: grid, statistics, level table, the
// elements' CRC.
void encodeSmallSections(const Volume& v, EncodedVolume& e) {
  e.grid = encodeGrid(v);
  e.stats = encodeStatistics(v.stats);
  e.levels = encodeLevelTable(v.levelStart);
  e.elementsCrc = crcOfWords(v.elements);
  e.leafRawBytes = uint64_t(v.leafWords.size()) * 4;
}

EncodedVolume encode(const Volume& v, const HdtWriteOptions& options, HdtLeafEncoder* streamed, LeafCounts* leafCounts) {
  EncodedVolume e = encodeRequired(v, options, streamed, leafCounts);
  encodeLabels(v, options, e);
  encodeArrays(v, e);
  return e;
}

uint64_t encodedSize(const EncodedVolume& e, const Volume& v) {
  uint64_t size = kFileHeaderBytes + 6 * kSectionHeaderBytes + e.grid.size() + e.stats.size() + e.levels.size() +
                  uint64_t(v.elements.size()) * 4 + e.leafStoredBytes();
  if (e.labelled) {
    size += 2 * kSectionHeaderBytes + v.labels.elementLabels.size() * sizeof(Label) + e.labelVoxelStoredBytes();
    if (!e.labelNames.empty()) size += kSectionHeaderBytes + e.labelNames.size();
  }
  if (!e.arrayDirectory.empty()) size += 2 * kSectionHeaderBytes + e.arrayDirectory.size() + e.arrayValueBytes;
  return size;
}

// Whether encodeRequired counts the leaf words as it compresses them.
bool leafCountsFromBlocks(const Volume& v, const HdtWriteOptions& options) {
#if defined(HDT_HAVE_ZSTD)
  return kLittleEndianHost && options.compressLeaves && options.leafBlocks && !v.leafWords.empty();
#else
  (void)v;
  (void)options;
  return false;
#endif
}

} // namespace hdt::hdt_file_detail
