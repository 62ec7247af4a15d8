// The .hdt reader: a source of bytes, the section headers, the sections read
// and checked in file order (docs/hdt-format.md, "Validation"). A broken rule
// throws Invalid; the entry points (hdt_file.cpp) name the file. Private to hdt_core.
#pragma once

#include "hdt/volume.hpp"
#include "hdt_file_format.hpp"

#include <cerrno>
#include <cstdint>
#include <cstdio>
#include <cstring>
#include <string>
#include <vector>

namespace hdt::hdt_file_detail {

// The file's bytes, read once from the front: from memory (deserializeHdt) or
// from a file (readHdt), which is never read whole into memory.
class Source {
public:
  explicit Source(uint64_t size) : size_(size) {}
  virtual ~Source() = default;
  uint64_t position() const { return pos_; }
  uint64_t remaining() const { return size_ - pos_; }
  // The next `n` bytes (n <= remaining()) into `dst`.
  void read(void* dst, size_t n) {
    doRead(dst, n);
    pos_ += n;
  }
  // The next `n` bytes (n <= remaining()), valid until the next call; they
  // may be copied into `scratch` (a file) or not (memory).
  const uint8_t* view(size_t n, std::vector<uint8_t>& scratch) {
    const uint8_t* p = doView(n, scratch);
    pos_ += n;
    return p;
  }

protected:
  virtual void doRead(void* dst, size_t n) = 0;
  virtual const uint8_t* doView(size_t n, std::vector<uint8_t>& scratch) = 0;
  uint64_t size_;
  uint64_t pos_ = 0;
};

class MemorySource final : public Source {
public:
  MemorySource(const uint8_t* data, size_t size) : Source(size), data_(data) {}

private:
  void doRead(void* dst, size_t n) override {
    if (n) std::memcpy(dst, data_ + pos_, n);
  }
  const uint8_t* doView(size_t, std::vector<uint8_t>&) override { return data_ + pos_; }
  const uint8_t* data_;
};

class FileSource final : public Source {
public:
  FileSource(std::FILE* f, uint64_t size) : Source(size), f_(f) {}

private:
  void doRead(void* dst, size_t n) override {
    if (n && std::fread(dst, 1, n, f_) != n) {
      invalid(std::string("read error at byte ") + str(pos_) +
              (std::ferror(f_) ? ": " + std::string(std::strerror(errno)) : ": the file shrank"));
    }
  }
  const uint8_t* doView(size_t n, std::vector<uint8_t>& scratch) override {
    scratch.resize(n);
    doRead(scratch.data(), n);
    return scratch.data();
  }
  std::FILE* f_;
};

// A section header checked by rule 4 (checkSectionHeader).
struct SectionHeader {
  Section id;
  Encoding encoding;
  uint64_t stored, raw;
  uint32_t crc;
};

// The 28 bytes of a section header, not yet checked.
struct RawSectionHeader {
  uint64_t at = 0; // file offset of the header
  uint32_t id = 0, encoding = 0;
  uint64_t stored = 0, raw = 0;
  uint32_t crc = 0;
};

// `before` names the section expected there, for the message when the file
// ends first.
RawSectionHeader readRawSectionHeader(Source& in, const std::string& before);
// Rule 4 for a header whose id is known: an allowed encoding, the payload in
// the file, raw == stored when raw.
// `compressed`: the highest compressed encoding the section may have (Raw:
// none; Zstd; ZstdBlocks includes Zstd).
SectionHeader checkSectionHeader(const RawSectionHeader& raw, Section id, const std::string& name,
                                 Encoding compressed, const Source& in);
// Rule 5: checked before the payload is read.
void expectRawBytes(const SectionHeader& h, uint64_t expected);
// Rule 6.
void checkCrc(const SectionHeader& h, uint32_t actual);

// The whole file.
Volume readVolume(Source& in);
// Version 2, after the leaf data: optional sections in increasing id order,
// then the end section (docs/hdt-format.md, "Optional sections").
void readOptionalSections(Source& in, Volume& v);

} // namespace hdt::hdt_file_detail
