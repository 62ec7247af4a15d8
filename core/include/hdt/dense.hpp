// Dense export of a volume: one byte a voxel (0 outside, 1 inside, 2 surface).
#pragma once

#include "hdt/volume.hpp"

#include <cstdint>
#include <string>
#include <vector>

namespace hdt {

class AtomicFile;

constexpr int kMaxDenseResolution = 1024;

// N^3 bytes, x fastest. Throws Error(InvalidArgument) above kMaxDenseResolution.
std::vector<uint8_t> denseStates(const Volume& volume);

// NRRD (encoding raw, type uint8, sizes N N N, space origin and directions).
// Replaces `path` only once the whole file is written (hdt/atomic_file.hpp).
void writeNrrd(const Volume& volume, const std::string& path);
// Writes into `out` without committing it.
void writeNrrd(const Volume& volume, AtomicFile& out);

// The part labels of a labelled volume (hdt/labels.hpp), N^3 uint16, x
// fastest, 0 outside. Throws Error(InvalidArgument) for an unlabelled volume
// or above kMaxDenseResolution.
std::vector<uint16_t> denseLabels(const Volume& volume);
// NRRD of denseLabels (type uint16, little endian), otherwise like writeNrrd.
void writeLabelNrrd(const Volume& volume, const std::string& path);
void writeLabelNrrd(const Volume& volume, AtomicFile& out);

// The NRRD header both writers use (type "uint8" / "uint16", a comment line).
std::string nrrdHeader(const Volume& volume, const char* type, const char* comment);

} // namespace hdt
