// The .hdt file format (spec: docs/hdt-format.md): writer and validating reader.
#pragma once

#include "hdt/volume.hpp"

#include <cstdint>
#include <string>
#include <vector>

namespace hdt {

class AtomicFile;

struct HdtWriteOptions {
  bool compressLeaves = true; // zstd, when the build has it
  int zstdLevel = 3;
  // Compressed leaves as independent zstd blocks, compressed (and read) in
  // parallel: format version 3. false: one zstd frame, format version 2, for
  // readers that predate version 3. Either way the bytes do not depend on the
  // thread count. (Raw leaves are written as version 2.)
  bool leafBlocks = true;
};

// Serialises to bytes / a file.
std::vector<uint8_t> serializeHdt(const Volume& volume, const HdtWriteOptions& options = {});
// writeHdt replaces `path` only once the whole file is written and synced
// (hdt/atomic_file.hpp): a failure leaves the old file, never a partial one.
// Refused volumes: Error(InvalidArgument); I/O failures: Error(OutputFailed).
void writeHdt(const Volume& volume, const std::string& path, const HdtWriteOptions& options = {});
// Writes into `out` without committing it, for callers that commit several
// outputs together (the CLI's -o and --dense).
void writeHdt(const Volume& volume, AtomicFile& out, const HdtWriteOptions& options = {});

// Parses and validates everything (magic, version, sizes, checksums, tree
// consistency). Never trusts a header field before checking it. Throws
// Error(BadInput) with a message naming the file and the problem.
Volume deserializeHdt(const uint8_t* data, size_t size, const std::string& name = "<memory>");
Volume readHdt(const std::string& path);

} // namespace hdt
