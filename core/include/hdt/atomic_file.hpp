// Writing an output file so that a failure never loses data.
//
// The bytes go to a temporary file in the target's directory; commit() flushes
// it, fsyncs it and renames it over the target (then fsyncs the directory).
// Until that rename the target is untouched: a failed write, a full disk, a
// file-size limit or a kill mid-write leave the old file (or no file) behind,
// never a truncated one. On failure only the temporary file is removed.
//
// Targets that are not regular files (device nodes, FIFOs, sockets,
// directories) are refused and never unlinked. A symbolic link is followed:
// the file it points to is replaced and the link itself stays (a dangling
// link is refused). A replaced file keeps its permission bits; a new one gets
// 0666 minus the umask. Hard links to the old file keep the old contents.
#pragma once

#include <cstdio>
#include <string>

namespace hdt {

// Throws Error(OutputFailed) unless `path` could be written by AtomicFile:
// the target is a regular file or absent (a link is followed), and a file can
// be created in its directory (tried by creating and removing a temporary).
// For checking outputs before a long computation.
void checkOutputWritable(const std::string& path);

// True when `a` and `b` name the same existing file (same device and inode).
bool sameExistingFile(const std::string& a, const std::string& b);

class AtomicFile {
public:
  // Creates the temporary file; throws Error(OutputFailed) naming `path`.
  explicit AtomicFile(const std::string& path);
  ~AtomicFile(); // without commit(): removes the temporary file
  AtomicFile(const AtomicFile&) = delete;
  AtomicFile& operator=(const AtomicFile&) = delete;

  std::FILE* stream() { return file_; }
  // Writes all of `data`; throws Error(OutputFailed).
  void write(const void* data, size_t size);
  // Flush, fsync, rename over the target. Throws Error(OutputFailed); the
  // target is then unchanged and the temporary file removed.
  void commit();

  const std::string& path() const { return path_; }

private:
  [[noreturn]] void fail(const std::string& what);
  void discard();

  std::string path_;      // as the caller named it (for messages)
  std::string target_;    // the file that gets replaced (a link resolved)
  std::string temporary_;
  std::FILE* file_ = nullptr;
};

} // namespace hdt
