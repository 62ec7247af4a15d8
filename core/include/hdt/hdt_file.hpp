// The .hdt file format (spec: docs/hdt-format.md): writer and validating reader.
#pragma once

#include "hdt/builder.hpp"
#include "hdt/volume.hpp"

#include <cstdint>
#include <memory>
#include <string>
#include <vector>

namespace hdt {

class AtomicFile;

struct HdtWriteOptions {
  bool compressLeaves = true; // zstd, when the build has it
  // zstd's level: 1 is as small as 3 on leaf data and faster
  // (bench/results/end-to-end.md); any level is read by every reader.
  int zstdLevel = 1;
  // Compressed leaves as independent zstd blocks, compressed (and read) in
  // parallel: format version 3. false: one zstd frame, format version 2, for
  // readers that predate version 3. Either way the bytes do not depend on the
  // thread count. (Raw leaves are written as version 2.)
  bool leafBlocks = true;
};

// The leaf data's zstd blocks compressed while a build copies the leaf grids
// back (pass it as BuildOptions::leafSink), each block as soon as its bytes
// have landed, so that build + write costs about max(copy, compression)
// instead of their sum. Then give it to the writer with the volume the build
// returned: the file is byte for byte the one written without it (a block
// depends only on its bytes and the level). Where it does not cover exactly
// that volume's leaf words with the writer's options (another volume, a build
// that did not feed it, raw or version-2 leaves, another level), the writer
// compresses as usual. One build at a time; begin() starts over. Its tasks
// read the volume's leaf words: wait for them (waitForBlocks, or the writer,
// or the destructor) before those words are freed.
class HdtLeafEncoder final : public LeafArrivalSink {
public:
  explicit HdtLeafEncoder(const HdtWriteOptions& options = {});
  ~HdtLeafEncoder() override; // waits for the blocks in flight
  HdtLeafEncoder(const HdtLeafEncoder&) = delete;
  HdtLeafEncoder& operator=(const HdtLeafEncoder&) = delete;
  void begin(const uint32_t* words, size_t count) override;
  void arrived(size_t count) override;
  void abandon() override;
  // Returns once the blocks handed out so far are compressed (the writer
  // waits by itself; for tests and timing). Rethrows a compression error.
  void waitForBlocks();
  // True once a writer has taken the blocks of the last build fed (rather
  // than compressing the leaves itself).
  bool usedByWriter() const;

  struct State; // hdt_leaf_encoder.cpp; the writer takes the blocks from it

private:
  std::unique_ptr<State> state_;
  friend State& leafEncoderState(HdtLeafEncoder&);
};

// Serialises to bytes / a file. `streamed`: the leaf blocks compressed during
// the build (HdtLeafEncoder), used when they cover `volume`; may be null.
std::vector<uint8_t> serializeHdt(const Volume& volume, const HdtWriteOptions& options = {},
                                  HdtLeafEncoder* streamed = nullptr);
// writeHdt replaces `path` only once the whole file is written and synced
// (hdt/atomic_file.hpp): a failure leaves the old file, never a partial one.
// Refused volumes: Error(InvalidArgument); I/O failures: Error(OutputFailed).
void writeHdt(const Volume& volume, const std::string& path, const HdtWriteOptions& options = {},
              HdtLeafEncoder* streamed = nullptr);
// Writes into `out` without committing it, for callers that commit several
// outputs together (the CLI's -o and --dense).
void writeHdt(const Volume& volume, AtomicFile& out, const HdtWriteOptions& options = {},
              HdtLeafEncoder* streamed = nullptr);

// Parses and validates everything (magic, version, sizes, checksums, tree
// consistency). Never trusts a header field before checking it. Throws
// Error(BadInput) with a message naming the file and the problem.
Volume deserializeHdt(const uint8_t* data, size_t size, const std::string& name = "<memory>");
Volume readHdt(const std::string& path);

} // namespace hdt
