// The .hdt writer: an encoded volume (hdt_file_encode.hpp) emitted to a sink,
// after the format's checks (hdt_file_checks.hpp), which run beside the
// encoding. Private to hdt_core; the entry points are in hdt_file.cpp.
#pragma once

#include "hdt/hdt_file.hpp"
#include "hdt/volume.hpp"
#include "hdt_file_encode.hpp"

#include <cstdint>
#include <cstdio>
#include <string>
#include <vector>

namespace hdt::hdt_file_detail {

// Where the emitted bytes go.
class Sink {
public:
  virtual ~Sink() = default;
  virtual void write(const void* data, size_t size) = 0;
};

class VectorSink final : public Sink {
public:
  explicit VectorSink(std::vector<uint8_t>& out) : out_(out) {}
  void write(const void* data, size_t size) override {
    const uint8_t* p = static_cast<const uint8_t*>(data);
    out_.insert(out_.end(), p, p + size);
  }

private:
  std::vector<uint8_t>& out_;
};

// Every few MiB it asks the kernel to start writing what it has to the disk
// (Linux: sync_file_range, a hint), so that the disk writes while the rest is
// emitted and the fsync of AtomicFile::commit() waits for the last part only.
class FileSink final : public Sink {
public:
  FileSink(std::FILE* f, const std::string& path);
  void write(const void* data, size_t size) override;
  uint64_t position() const { return written_; }
  // Rewrites `size` bytes at `at` (< position()), where zeros were reserved.
  void patch(uint64_t at, const void* data, size_t size);

private:
  static constexpr uint64_t kWriteBackStep = uint64_t(4) << 20;
  [[noreturn]] void fail() const;
  void startWriteBack();
  std::FILE* f_;
  const std::string& path_;
  uint64_t written_ = 0, started_ = 0;
};

// Checks the volume and the options, then encodes; throws hdt::Error.
EncodedVolume prepare(const Volume& v, const HdtWriteOptions& options, const std::string& name,
                      HdtLeafEncoder* streamed);
// The file: header, sections, end.
void emit(const EncodedVolume& e, const Volume& v, Sink& out);

// Writes with the leaf frames streamed to the file (emitStreaming) where the
// build's blocks cover the volume; false, having written nothing, otherwise.
bool writeStreaming(const Volume& volume, std::FILE* f, const std::string& path, const HdtWriteOptions& options,
                    HdtLeafEncoder* streamed);

} // namespace hdt::hdt_file_detail
