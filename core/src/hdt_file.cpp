// The .hdt file format (docs/hdt-format.md): writer and validating reader,
// the public entry points (hdt/hdt_file.hpp). The work is in the files of
// namespace hdt_file_detail, one responsibility each:
//   hdt_file_format.hpp/.cpp   the constants, section ids, byte encoding, CRC-32
//   hdt_file_checks.hpp/.cpp   the format's rules on a volume (and validateVolume)
//   hdt_file_zstd.hpp/.cpp     zstd frames and the leaf data's zstd blocks
//   hdt_file_encode.hpp/.cpp   a volume's sections encoded, every header known
//   hdt_file_write.hpp/.cpp    the encoded sections emitted, the checks beside
//   hdt_file_read.hpp/.cpp     the file header and the required sections, read
//   hdt_file_read_optional.cpp the optional sections (labels, arrays, unknown)
//
// The reader checks in file order, and every check that bounds a later
// allocation comes before it: section lengths against the bytes left in the
// file, the element count against the element section, the leaf data against
// the number of Boundary elements. A violated rule throws Invalid, which the
// entry points turn into hdt::Error naming the file.
//
// The writer runs the same checks on the volume first (it must never produce a
// file the reader refuses), computes every section header, then writes; the
// bulk (elements, leaf words) goes from the volume's own arrays to the output
// without an intermediate copy on little-endian hosts, or through zstd.
#include "hdt/hdt_file.hpp"

#include "hdt/atomic_file.hpp"
#include "hdt/error.hpp"
#include "hdt_file_encode.hpp"
#include "hdt_file_format.hpp"
#include "hdt_file_read.hpp"
#include "hdt_file_write.hpp"
#include "hdt_leaf_encoder.hpp"

#include <sys/stat.h>

#include <cerrno>
#include <cstdio>
#include <cstring>
#include <memory>
#include <new>

namespace hdt {
using namespace hdt_file_detail;

namespace {

Volume readNamed(Source& in, const std::string& name) {
  try {
    return readVolume(in);
  } catch (const Invalid& e) {
    throw Error(ErrorKind::BadInput, name + ": " + e.what());
  } catch (const std::bad_alloc&) {
    throw Error(ErrorKind::OutOfResources, name + ": not enough memory to load the volume");
  }
}

struct FileClose {
  void operator()(std::FILE* f) const { std::fclose(f); }
};

} // namespace

std::vector<uint8_t> serializeHdt(const Volume& volume, const HdtWriteOptions& options, HdtLeafEncoder* streamed) {
  const std::string name = "<memory>";
  const EncodedVolume e = prepare(volume, options, name, streamed);
  std::vector<uint8_t> bytes;
  try {
    bytes.reserve(toSize(encodedSize(e, volume)));
    VectorSink sink(bytes);
    emit(e, volume, sink);
  } catch (const std::bad_alloc&) {
    throw Error(ErrorKind::OutOfResources, name + ": out of memory while serializing the volume");
  }
  return bytes;
}

void writeHdt(const Volume& volume, AtomicFile& out, const HdtWriteOptions& options, HdtLeafEncoder* streamed) {
  if (writeStreaming(volume, out.stream(), out.path(), options, streamed)) return;
  const EncodedVolume e = prepare(volume, options, out.path(), streamed);
  FileSink sink(out.stream(), out.path());
  emit(e, volume, sink);
}

void writeHdt(const Volume& volume, const std::string& path, const HdtWriteOptions& options,
              HdtLeafEncoder* streamed) {
  // The bytes go to a temporary file renamed over `path` only once complete
  // (atomic_file.hpp): a refused volume leaves no file behind.
#if defined(HDT_HAVE_ZSTD)
  if (streamed && streamingLeafBlocks(*streamed, volume.leafWords, options)) {
    AtomicFile out(path);
    writeStreaming(volume, out.stream(), path, options, streamed);
    out.commit();
    return;
  }
#endif
  // Encode first, then create the file.
  const EncodedVolume e = prepare(volume, options, path, streamed);
  AtomicFile out(path);
  FileSink sink(out.stream(), path);
  emit(e, volume, sink);
  out.commit();
}

Volume deserializeHdt(const uint8_t* data, size_t size, const std::string& name) {
  if (data == nullptr && size != 0) throw Error(ErrorKind::InvalidArgument, name + ": null data");
  MemorySource in(data, size);
  return readNamed(in, name);
}

Volume readHdt(const std::string& path) {
  std::unique_ptr<std::FILE, FileClose> f(std::fopen(path.c_str(), "rb"));
  if (!f) throw Error(ErrorKind::BadInput, path + ": cannot open: " + std::strerror(errno));
  struct stat st;
  if (fstat(fileno(f.get()), &st) != 0 || !S_ISREG(st.st_mode)) {
    throw Error(ErrorKind::BadInput, path + ": not a regular file");
  }
  FileSource in(f.get(), uint64_t(st.st_size));
  return readNamed(in, path);
}

} // namespace hdt
