// Dense export of part labels: the tree walked once (volume_walk.hpp), each
// element writing its own block of the N^3 label array, in parallel.
#include "hdt/atomic_file.hpp"
#include "hdt/dense.hpp"
#include "hdt/error.hpp"
#include "hdt/labels.hpp"
#include "hdt/volume_walk.hpp"

#include <algorithm>

namespace hdt {

std::vector<uint16_t> denseLabels(const Volume& v) {
  const GridSpec& g = v.grid;
  if (v.labels.empty()) throw Error(ErrorKind::InvalidArgument, "label export: the volume has no labels");
  if (g.resolution > kMaxDenseResolution) {
    throw Error(ErrorKind::InvalidArgument, "label export needs 2 N^3 bytes and is limited to N <= " +
                                                std::to_string(kMaxDenseResolution));
  }
  const size_t n = size_t(g.resolution), L = size_t(g.leafSize);
  std::vector<uint16_t> out(n * n * n, kOutsideLabel);
  const LabelField& f = v.labels;
  parallelWalkVolume(v, g.height, [&](const WalkedElement& e) {
    const size_t x = size_t(e.origin[0]), y = size_t(e.origin[1]), z = size_t(e.origin[2]), edge = size_t(e.edge);
    const Label label = f.elementLabels[e.index];
    if (e.state() == ElementState::Full) {
      for (size_t k = 0; k < edge; ++k)
        for (size_t j = 0; j < edge; ++j) {
          uint16_t* row = out.data() + x + n * (y + j + n * (z + k));
          std::fill(row, row + edge, label);
        }
      return;
    }
    if (e.state() != ElementState::Boundary) return;
    const LeafLabels labels = leafLabels(v, e.index);
    for (size_t k = 0; k < L; ++k)
      for (size_t j = 0; j < L; ++j)
        for (size_t i = 0; i < L; ++i) out[x + i + n * (y + j + n * (z + k))] = labels[uint32_t(i + L * (j + L * k))];
  });
  return out;
}

namespace {
void writeLabelNrrdTo(const Volume& v, const std::vector<uint16_t>& labels, AtomicFile& out) {
  const std::string header = nrrdHeader(v, "uint16", "HDT part labels: 0 outside, parts 1 to 65535");
  out.write(header.data(), header.size());
  if (__BYTE_ORDER__ == __ORDER_LITTLE_ENDIAN__) {
    out.write(labels.data(), labels.size() * 2);
    return;
  }
  std::vector<uint8_t> bytes(labels.size() * 2);
  for (size_t i = 0; i < labels.size(); ++i) {
    bytes[2 * i] = uint8_t(labels[i]);
    bytes[2 * i + 1] = uint8_t(labels[i] >> 8);
  }
  out.write(bytes.data(), bytes.size());
}
} // namespace

void writeLabelNrrd(const Volume& v, const std::string& path) {
  const std::vector<uint16_t> labels = denseLabels(v); // refusals before the file exists
  AtomicFile out(path);
  writeLabelNrrdTo(v, labels, out);
  out.commit();
}

void writeLabelNrrd(const Volume& v, AtomicFile& out) { writeLabelNrrdTo(v, denseLabels(v), out); }

} // namespace hdt
