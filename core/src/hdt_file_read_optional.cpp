// The .hdt reader's optional sections (hdt_file_read.hpp): part labels (16,
// 17, 18, 21), transferred arrays (19, 20), and the unknown ones, skipped or
// refused by the unknown-section rule.
#include "hdt_file_read.hpp"

#include "hdt_file_checks.hpp"
#include "hdt_file_zstd.hpp"

#include "hdt/labels.hpp"
#include "hdt/lattice.hpp"
#include "hdt/transfer.hpp"

#include <algorithm>
#include <cstring>

namespace hdt::hdt_file_detail {
namespace {

// An optional section this reader does not know and may skip: its payload is
// checksummed in bounded chunks and dropped.
void skipSection(Source& in, const RawSectionHeader& raw) {
  const std::string name = "optional section " + str(raw.id);
  if (raw.encoding != uint32_t(Encoding::Raw) && raw.encoding != uint32_t(Encoding::Zstd)) {
    invalid(name + ": invalid encoding " + str(raw.encoding));
  }
  if (raw.stored > in.remaining()) {
    invalid(name + ": " + str(raw.stored) + " bytes stored but only " + str(in.remaining()) +
            " remain in the file (truncated?)");
  }
  if (raw.encoding == uint32_t(Encoding::Raw) && raw.raw != raw.stored) {
    invalid(name + ": raw section with " + str(raw.stored) + " bytes stored but " + str(raw.raw) + " decoded");
  }
  std::vector<uint8_t> scratch;
  uint32_t crc = optionalSectionCrcSeed(raw.id, raw.encoding, raw.stored, raw.raw);
  for (uint64_t left = raw.stored; left > 0;) {
    const size_t n = size_t(std::min<uint64_t>(left, kSkipChunkBytes));
    crc = crc32Update(crc, in.view(n, scratch), n);
    left -= n;
  }
  if (crc != raw.crc) invalid(name + ": CRC-32 mismatch");
}

// Rule 6 for an optional section: the CRC covers the header's first 24 bytes.
void checkOptionalCrc(const SectionHeader& h, const uint8_t* stored) {
  checkCrc(h, optionalSectionCrc(h.id, h.encoding, h.stored, h.raw, crc32Of(stored, size_t(h.stored))));
}

// An optional section holding an array of T (raw, or zstd when allowed), its
// raw length already checked; decoded into `out`.
template <class T, class A> void readOptionalArray(Source& in, const SectionHeader& h, std::vector<T, A>& out) {
  const std::string what = sectionName(h.id);
  if (h.encoding == Encoding::Raw) {
    out.resize(size_t(h.raw) / sizeof(T)); // the section is in the file: bounded by its size
    in.read(out.data(), size_t(h.stored));
    checkOptionalCrc(h, reinterpret_cast<const uint8_t*>(out.data()));
  } else {
    std::vector<uint8_t> scratch;
    const uint8_t* stored = in.view(size_t(h.stored), scratch); // in the file: bounded by its size
    checkOptionalCrc(h, stored);
#if defined(HDT_HAVE_ZSTD)
    checkLeafFrame(stored, size_t(h.stored), size_t(h.raw), what);
    out.resize(size_t(h.raw) / sizeof(T));
    decompressLeaves(stored, size_t(h.stored), reinterpret_cast<uint8_t*>(out.data()), size_t(h.raw), what);
#else
    invalid(what + " section: zstd-compressed but this build of HDT has no zstd support");
#endif
  }
  littleEndianToHost(out.data(), out.size());
}

std::map<Label, std::string> decodeLabelNames(const uint8_t* bytes, size_t size) {
  ByteReader r(bytes, size);
  if (size < 4) invalid("label names section: shorter than its count");
  const uint32_t count = r.u32();
  std::map<Label, std::string> names;
  size_t at = 4;
  uint32_t previous = 0;
  for (uint32_t i = 0; i < count; ++i) {
    if (size - at < 4) invalid("label names section: ends inside entry " + str(i));
    const uint32_t packed = r.u32();
    const uint32_t label = packed & 0xFFFFu, length = packed >> 16;
    at += 4;
    if (label <= previous) invalid("label names section: labels are not increasing from 1 (label " + str(label) + ")");
    if (length > kMaxLabelNameLength) invalid("label names section: a name longer than 255 bytes");
    if (size - at < length) invalid("label names section: ends inside the name of label " + str(label));
    names[Label(label)].assign(reinterpret_cast<const char*>(r.bytes(length)), length);
    at += length;
    previous = label;
  }
  if (at != size) invalid("label names section: " + str(size - at) + " bytes after the last name");
  checkLabelNames(names);
  return names;
}

// memcpy for arrays that may be empty (an empty vector's data() may be null).
void copyBytes(void* to, const void* from, size_t n) {
  if (n) std::memcpy(to, from, n);
}

// Section 21's payload (compactLabelVoxelBytes), decoded: the palettes
// first, which say how many index words and wide labels must follow.
void decodeCompactLabelVoxels(const uint8_t* bytes, size_t size, Volume& v, size_t mixed) {
  LabelField& f = v.labels;
  ByteReader r(bytes, size);
  const uint32_t layout = r.u32();
  if (layout != kCompactLabelLayout)
    invalid("compact label voxels section: layout " + str(layout) + ", this reader knows layout 2");
  if ((size - 4) / sizeof(LeafPalette) < mixed)
    invalid("compact label voxels section: " + str(size) + " bytes cannot hold " + str(mixed) + " palettes");
  f.palettes.resize(mixed);
  copyBytes(f.palettes.data(), bytes + 4, mixed * sizeof(LeafPalette));
  littleEndianToHost(reinterpret_cast<Label*>(f.palettes.data()), mixed * kPaletteSize);
  size_t wide = 0;
  for (const LeafPalette& p : f.palettes) wide += p.isWide();
  const size_t words = (mixed - wide) * leafWordCount(v.grid.leafSize), wideLabels = wide * v.grid.leafVoxels();
  const size_t head = 4 + mixed * sizeof(LeafPalette);
  if (size != head + words * 4 + wideLabels * 2)
    invalid("compact label voxels section: " + str(size) + " bytes, but its palettes call for " +
            str(head + words * 4 + wideLabels * 2));
  f.paletteIndices.resize(words);
  copyBytes(f.paletteIndices.data(), bytes + head, words * 4);
  littleEndianToHost(f.paletteIndices.data(), words);
  f.wideLabels.resize(wideLabels);
  copyBytes(f.wideLabels.data(), bytes + head + words * 4, wideLabels * 2);
  littleEndianToHost(f.wideLabels.data(), wideLabels);
}

// Section 16; `mixed` receives the mixed leaves.
void readLabelElements(Source& in, const SectionHeader& h, Volume& v, std::vector<uint64_t>& mixed) {
  LabelField& f = v.labels;
  expectRawBytes(h, uint64_t(v.elements.size()) * sizeof(Label));
  readOptionalArray(in, h, f.elementLabels);
  mixed = checkLabelElements(f.elementLabels, v.elements);
}

// Section 17, the 16-bit layout of older files: checked, then converted.
void readSixteenBitLabelVoxels(Source& in, const SectionHeader& h, Volume& v, const std::vector<uint64_t>& mixed) {
  const uint64_t V = v.grid.leafVoxels();
  expectRawBytes(h, mixed.size() * V * sizeof(Label)); // at most 8x the leaf data
  std::vector<Label> labels;
  readOptionalArray(in, h, labels);
  checkSixteenBitVoxelLabels(v, mixed, labels);
  packVoxelLabels(v, labels.data());
}

// Section 21.
void readCompactLabelVoxels(Source& in, const SectionHeader& h, Volume& v, const std::vector<uint64_t>& mixed) {
  const uint64_t V = v.grid.leafVoxels();
  // Bounded before decoding: the palettes, and at most 16 bits a voxel.
  const uint64_t least = 4 + mixed.size() * sizeof(LeafPalette), most = least + mixed.size() * V * sizeof(Label);
  if (h.raw < least || h.raw > most)
    invalid("compact label voxels section: " + str(h.raw) + " bytes, expected " + str(least) + " to " + str(most));
  std::vector<uint8_t> bytes;
  readOptionalArray(in, h, bytes);
  decodeCompactLabelVoxels(bytes.data(), bytes.size(), v, mixed.size());
  bytes = {};
  indexMixedLeaves(v);
  checkLabelVoxels(v, mixed);
}

// Section 18.
void readLabelNames(Source& in, const SectionHeader& h, Volume& v) {
  // 65535 names of 255 bytes at most, each with a 4-byte head.
  if (h.raw > 4 + 65535 * (4 + kMaxLabelNameLength)) invalid("label names section: too long");
  std::vector<uint8_t> scratch;
  const uint8_t* bytes = in.view(size_t(h.stored), scratch);
  checkOptionalCrc(h, bytes);
  v.labels.names = decodeLabelNames(bytes, size_t(h.stored));
}

// The part-label sections (16, 17, 18, 21); `mixed` receives the mixed leaves.
void readLabelSection(Source& in, const RawSectionHeader& raw, Volume& v, std::vector<uint64_t>& mixed) {
  const Section id = Section(raw.id);
  const bool voxels = id == Section::LabelVoxels || id == Section::CompactLabelVoxels;
  const SectionHeader h = checkSectionHeader(raw, id, sectionName(id), voxels ? Encoding::Zstd : Encoding::Raw, in);
  if (id != Section::LabelElements && v.labels.empty())
    invalid(std::string(sectionName(id)) + " section without the label elements section");
  switch (id) {
  case Section::LabelElements: readLabelElements(in, h, v, mixed); break;
  case Section::LabelVoxels: readSixteenBitLabelVoxels(in, h, v, mixed); break;
  case Section::CompactLabelVoxels: readCompactLabelVoxels(in, h, v, mixed); break;
  default: readLabelNames(in, h, v); break;
  }
}

// Section 19's contents (encodeArrayDirectory): arrays with names, sources
// and components, values still empty.
std::vector<VoxelArray> decodeArrayDirectory(const uint8_t* bytes, size_t size) {
  const std::string what = "array directory section: ";
  if (size < 4) invalid(what + "shorter than its count");
  ByteReader r(bytes, size);
  const uint32_t count = r.u32();
  if (count == 0 || count > kMaxVoxelArrays) invalid(what + str(count) + " arrays (1 to 256)");
  std::vector<VoxelArray> arrays(count);
  size_t at = 4;
  for (VoxelArray& a : arrays) {
    if (size - at < 4) invalid(what + "ends inside an entry");
    const uint32_t length = r.u32();
    at += 4;
    if (length == 0 || length > kMaxArrayNameLength) invalid(what + "a name of " + str(length) + " bytes (1 to 255)");
    if (size - at < size_t(length) + 8) invalid(what + "ends inside an entry");
    a.name.assign(reinterpret_cast<const char*>(r.bytes(length)), length);
    const uint32_t source = r.u32(), components = r.u32();
    at += size_t(length) + 8;
    if (source > uint32_t(ArraySource::Cell)) invalid(what + "array '" + a.name + "': unknown source " + str(source));
    if (components < 1 || components > kMaxArrayComponents)
      invalid(what + "array '" + a.name + "': " + str(components) + " components (1 to 64)");
    a.source = ArraySource(source);
    a.components = components;
    for (const VoxelArray& b : arrays) {
      if (&b == &a) break;
      if (b.name == a.name) invalid(what + "array '" + a.name + "' appears twice");
    }
  }
  if (at != size) invalid(what + str(size - at) + " bytes after the last entry");
  return arrays;
}

// The transferred-array sections (19, 20). The values' size follows from
// the directory and the surface voxels of the leaf data already read (at most
// 64 * 256 floats per surface voxel), and raw encoding keeps it within the file.
void readArraySection(Source& in, const RawSectionHeader& raw, Volume& v) {
  const Section id = Section(raw.id);
  const SectionHeader h = checkSectionHeader(raw, id, sectionName(id), Encoding::Raw, in);
  if (id == Section::ArrayDirectory) {
    if (h.raw > 4 + kMaxVoxelArrays * (12 + kMaxArrayNameLength)) invalid("array directory section: too long");
    std::vector<uint8_t> scratch;
    const uint8_t* bytes = in.view(size_t(h.stored), scratch);
    checkOptionalCrc(h, bytes);
    v.arrays = decodeArrayDirectory(bytes, size_t(h.stored));
    return;
  }
  if (v.arrays.empty()) invalid("array values section without the array directory section");
  uint64_t surface = 0;
  for (uint32_t w : v.leafWords) surface += planeCount(w, kSurfacePlane);
  uint64_t expected = 0;
  for (const VoxelArray& a : v.arrays) expected += surface * a.components * sizeof(float);
  expectRawBytes(h, expected);
  uint32_t crc = optionalSectionCrcSeed(raw.id, raw.encoding, raw.stored, raw.raw);
  for (VoxelArray& a : v.arrays) {
    a.values.resize(size_t(surface * a.components));
    in.read(a.values.data(), a.values.size() * sizeof(float));
    crc = crc32Update(crc, a.values.data(), a.values.size() * sizeof(float));
    littleEndianToHost(a.values.data(), a.values.size());
  }
  checkCrc(h, crc);
}

} // namespace

void readOptionalSections(Source& in, Volume& v) {
  uint32_t previous = 0;
  std::vector<uint64_t> mixed;
  bool labelVoxels = false, arrayValues = false;
  for (;;) {
    const RawSectionHeader raw = readRawSectionHeader(in, "next optional or the end");
    if (raw.id == uint32_t(Section::End)) {
      if (raw.encoding != 0 || raw.stored != 0 || raw.raw != 0 || raw.crc != 0) {
        invalid("end section at byte " + str(raw.at) + ": encoding, lengths and CRC must be 0");
      }
      break;
    }
    if (raw.id < kFirstOptionalSection) {
      invalid("section id " + str(raw.id) + " at byte " + str(raw.at) +
              ": expected an optional section (id 16 or more) or the end section (id 6)");
    }
    if (raw.id <= previous) {
      invalid("optional section " + str(raw.id) + " at byte " + str(raw.at) + " follows section " +
              str(previous) + ": optional sections appear once each, in increasing id order");
    }
    previous = raw.id;
    const bool voxelSection = raw.id == uint32_t(Section::LabelVoxels) || raw.id == uint32_t(Section::CompactLabelVoxels);
    if ((raw.id >= uint32_t(Section::LabelElements) && raw.id <= uint32_t(Section::LabelNames)) || voxelSection) {
      if (voxelSection && labelVoxels) invalid("both label voxels sections (17 and 21)");
      readLabelSection(in, raw, v, mixed);
      labelVoxels = labelVoxels || voxelSection;
      continue;
    }
    if (raw.id == uint32_t(Section::ArrayDirectory) || raw.id == uint32_t(Section::ArrayValues)) {
      readArraySection(in, raw, v);
      arrayValues = arrayValues || raw.id == uint32_t(Section::ArrayValues);
      continue;
    }
    if (raw.id & kCriticalSectionBit) {
      invalid("optional section " + str(raw.id) + " at byte " + str(raw.at) +
              " is marked critical and this reader does not know it");
    }
    skipSection(in, raw);
  }
  if (in.remaining() != 0) invalid(str(in.remaining()) + " bytes after the end section");
  if (!v.labels.empty() && !labelVoxels)
    invalid("label elements section without the label voxels section (17 or 21)");
  if (!v.arrays.empty() && !arrayValues) invalid("array directory section without the array values section");
  indexMixedLeaves(v);
}

} // namespace hdt::hdt_file_detail
