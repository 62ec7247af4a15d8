// Dense export: the tree walked once (volume_walk.hpp), each element writing
// its own block of the N^3 array (uniform elements as runs of one value, leaves
// decoded four voxels at a time). Blocks are disjoint, so subtrees fill in parallel.
#include "hdt/dense.hpp"

#include "hdt/atomic_file.hpp"

#include "hdt/error.hpp"
#include "hdt/volume_walk.hpp"


#include <array>
#include <cerrno>
#include <charconv>
#include <cstdio>
#include <cstring>
#include <memory>

namespace hdt {
namespace {

// The 4 voxel states packed in one byte of a leaf word -> 4 output bytes.
struct FourVoxels {
  std::array<std::array<uint8_t, 4>, 256> bytes;
  FourVoxels() {
    for (int b = 0; b < 256; ++b)
      for (int i = 0; i < 4; ++i) bytes[b][i] = uint8_t((b >> (2 * i)) & 3);
  }
};

class DenseFill {
public:
  DenseFill(const Volume& v, uint8_t* out)
      : v_(v), out_(out), N_(size_t(v.grid.resolution)), L_(v.grid.leafSize) {}

  // One element of the walk: its own block of the array.
  void operator()(const WalkedElement& e) const {
    const size_t x = size_t(e.origin[0]), y = size_t(e.origin[1]), z = size_t(e.origin[2]);
    switch (e.state()) {
    case ElementState::Full: fill(x, y, z, size_t(e.edge), uint8_t(VoxelState::Inside)); return;
    case ElementState::Boundary: leaf(e.payload(), x, y, z); return;
    default: return; // Empty: the array starts out all Outside
    }
  }

private:
  uint8_t* at(size_t x, size_t y, size_t z) const { return out_ + x + N_ * (y + N_ * z); }

  void fill(size_t x, size_t y, size_t z, size_t edge, uint8_t value) const {
    for (size_t k = 0; k < edge; ++k)
      for (size_t j = 0; j < edge; ++j) std::memset(at(x, y + j, z + k), value, edge);
  }

  // Rows of L voxels are L / 4 bytes of consecutive leaf words (types.hpp layout).
  void leaf(uint64_t index, size_t x, size_t y, size_t z) const {
    static const FourVoxels table;
    const uint32_t* words = v_.leaf(index);
    for (int k = 0; k < L_; ++k)
      for (int j = 0; j < L_; ++j) {
        uint8_t* row = at(x, y + size_t(j), z + size_t(k));
        const uint32_t first = uint32_t(L_) * uint32_t(j + L_ * k); // leaf-linear index of the row
        for (int i = 0; i < L_; i += 4) {
          const uint32_t voxel = first + uint32_t(i);
          const uint32_t byte = (words[voxel >> 4] >> (2 * (voxel & 15u))) & 0xFFu;
          std::memcpy(row + i, table.bytes[byte].data(), 4);
        }
      }
  }

  const Volume& v_;
  uint8_t* out_;
  size_t N_;
  int L_;
};

// Shortest text that reads back as the same double.
std::string number(double v) {
  char buf[32];
  const auto r = std::to_chars(buf, buf + sizeof buf, v);
  return std::string(buf, r.ptr);
}

} // namespace

std::vector<uint8_t> denseStates(const Volume& volume) {
  const GridSpec& g = volume.grid;
  const int N = g.resolution;
  if (N > kMaxDenseResolution) {
    throw Error(ErrorKind::InvalidArgument,
                "dense export needs N^3 bytes and is limited to N <= " + std::to_string(kMaxDenseResolution) +
                    " (this volume has N = " + std::to_string(N) + ")");
  }
  const uint64_t R = uint64_t(g.rootGrid);
  if (N < 1 || R < 1 || g.leafSize % 4 != 0 || volume.levelStart.size() != size_t(g.height) + 2 ||
      volume.elements.size() < R * R * R) {
    throw Error(ErrorKind::InvalidArgument, "dense export: the volume is empty or malformed");
  }
  const size_t n = size_t(N);
  std::vector<uint8_t> out(n * n * n, uint8_t(VoxelState::Outside));
  const DenseFill fill(volume, out.data());
  // Blocks are disjoint, so the walk's concurrent visits never touch the same byte.
  parallelWalkVolume(volume, g.height, fill);
  return out;
}

std::string nrrdHeader(const Volume& volume, const char* type, const char* comment) {
  const GridSpec& g = volume.grid;
  const std::string N = std::to_string(g.resolution), s = number(g.voxelSize);
  // NRRD's "space origin" is the centre of sample (0, 0, 0), not its corner.
  std::string origin;
  for (int a = 0; a < 3; ++a) origin += (a ? "," : "") + number(g.origin[a] + 0.5 * g.voxelSize);

  // Field order matters to strict readers: "dimension" before the per-axis
  // fields, "space dimension" before "space directions" / "space origin".
  // Values must not contain blanks inside the parentheses (VTK splits there).
  // clang-format off
  return "NRRD0004\n"
                             "# " + std::string(comment) + "\n"
                             "type: " + type + "\n"
                             "dimension: 3\n"
                             "space dimension: 3\n"
                             "sizes: " + N + " " + N + " " + N + "\n"
                             "space directions: (" + s + ",0,0) (0," + s + ",0) (0,0," + s + ")\n"
                             "kinds: domain domain domain\n"
                             "endian: little\n"
                             "encoding: raw\n"
                             "space origin: (" + origin + ")\n"
                             "\n";
  // clang-format on
}

namespace {
void writeNrrdTo(const Volume& volume, const std::vector<uint8_t>& states, AtomicFile& out) {
  const std::string header = nrrdHeader(volume, "uint8", "HDT voxel states: 0 outside, 1 inside, 2 surface");
  out.write(header.data(), header.size());
  out.write(states.data(), states.size());
}
} // namespace

void writeNrrd(const Volume& volume, const std::string& path) {
  const std::vector<uint8_t> states = denseStates(volume); // refusals before the file exists
  AtomicFile out(path); // the target is replaced only once the file is complete
  writeNrrdTo(volume, states, out);
  out.commit();
}

void writeNrrd(const Volume& volume, AtomicFile& out) { writeNrrdTo(volume, denseStates(volume), out); }

} // namespace hdt
