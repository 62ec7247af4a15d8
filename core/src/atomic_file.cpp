#include "hdt/atomic_file.hpp"

#include "hdt/error.hpp"

#include <fcntl.h>
#include <sys/stat.h>
#include <unistd.h>

#include <atomic>
#include <cerrno>
#include <chrono>
#include <climits>
#include <cstdlib>
#include <cstring>

namespace hdt {
namespace {

[[noreturn]] void refuse(const std::string& path, const std::string& what) {
  throw Error(ErrorKind::OutputFailed, path + ": " + what);
}

std::string errnoText(const char* doing) { return std::string(doing) + ": " + std::strerror(errno); }

// What a write to `path` replaces: `path` itself, or the file a symbolic link
// points to. `mode` receives the permission bits to keep, or -1 for a new file.
std::string resolveTarget(const std::string& path, int& mode) {
  if (path.empty()) refuse("<empty name>", "no output file name");
  mode = -1;
  struct stat st {};
  if (::lstat(path.c_str(), &st) != 0) {
    if (errno == ENOENT) return path; // a new file (its directory is checked on creation)
    refuse(path, errnoText("cannot inspect"));
  }
  std::string target = path;
  if (S_ISLNK(st.st_mode)) {
    char resolved[PATH_MAX];
    if (::realpath(path.c_str(), resolved) == nullptr) {
      if (errno == ENOENT) refuse(path, "a symbolic link to a file that does not exist; not writing through it");
      refuse(path, errnoText("cannot resolve the symbolic link"));
    }
    target = resolved;
    if (::stat(target.c_str(), &st) != 0) refuse(path, errnoText("cannot inspect the link's target"));
  }
  if (!S_ISREG(st.st_mode)) {
    refuse(path, S_ISDIR(st.st_mode) ? "is a directory"
                                     : "exists and is not a regular file (a device, FIFO or socket); "
                                       "refusing to replace it");
  }
  mode = int(st.st_mode & 07777);
  return target;
}

std::string directoryOf(const std::string& file) {
  const size_t slash = file.find_last_of('/');
  if (slash == std::string::npos) return ".";
  return slash == 0 ? "/" : file.substr(0, slash);
}

// Creates "<dir>/.<name>.tmp-<unique>" exclusively, with mode 0666 minus the
// umask (as a new target would get). Returns the descriptor and sets `name`.
int createTemporary(const std::string& path, const std::string& target, std::string& name) {
  static std::atomic<unsigned> counter{0};
  const size_t slash = target.find_last_of('/');
  const std::string dir = directoryOf(target);
  const std::string base = slash == std::string::npos ? target : target.substr(slash + 1);
  for (int attempt = 0; attempt < 100; ++attempt) {
    const auto tick = std::chrono::steady_clock::now().time_since_epoch().count();
    name = (dir == "/" ? "" : dir) + "/." + base + ".tmp-" + std::to_string(::getpid()) + "-" +
           std::to_string(counter++) + "-" + std::to_string(uint64_t(tick) % 1000000);
    const int fd = ::open(name.c_str(), O_WRONLY | O_CREAT | O_EXCL | O_CLOEXEC, 0666);
    if (fd >= 0) return fd;
    if (errno != EEXIST) refuse(path, errnoText(("cannot create a file in " + dir).c_str()));
  }
  refuse(path, "cannot create a temporary file in " + dir);
}

void syncDirectory(const std::string& dir) {
  const int fd = ::open(dir.c_str(), O_RDONLY | O_DIRECTORY | O_CLOEXEC);
  if (fd < 0) return; // best effort: the rename itself has happened
  ::fsync(fd);
  ::close(fd);
}

} // namespace

void checkOutputWritable(const std::string& path) {
  int mode;
  const std::string target = resolveTarget(path, mode);
  std::string probe;
  const int fd = createTemporary(path, target, probe);
  ::close(fd);
  ::unlink(probe.c_str());
}

bool sameExistingFile(const std::string& a, const std::string& b) {
  struct stat sa {}, sb {};
  return ::stat(a.c_str(), &sa) == 0 && ::stat(b.c_str(), &sb) == 0 && sa.st_dev == sb.st_dev &&
         sa.st_ino == sb.st_ino;
}

AtomicFile::AtomicFile(const std::string& path) : path_(path) {
  int mode;
  target_ = resolveTarget(path, mode);
  const int fd = createTemporary(path, target_, temporary_);
  if (mode >= 0 && ::fchmod(fd, mode_t(mode)) != 0) {
    const std::string why = errnoText("cannot set the permissions");
    ::close(fd);
    ::unlink(temporary_.c_str());
    refuse(path, why);
  }
  file_ = ::fdopen(fd, "wb");
  if (file_ == nullptr) {
    const std::string why = errnoText("cannot open");
    ::close(fd);
    ::unlink(temporary_.c_str());
    refuse(path, why);
  }
}

AtomicFile::~AtomicFile() { discard(); }

void AtomicFile::discard() {
  if (file_ != nullptr) std::fclose(file_);
  file_ = nullptr;
  if (!temporary_.empty()) ::unlink(temporary_.c_str());
  temporary_.clear();
}

void AtomicFile::fail(const std::string& what) {
  discard();
  refuse(path_, what);
}

void AtomicFile::write(const void* data, size_t size) {
  if (file_ == nullptr) fail("write after commit");
  if (size != 0 && std::fwrite(data, 1, size, file_) != size) fail(errnoText("cannot write"));
}

void AtomicFile::commit() {
  if (file_ == nullptr) fail("commit twice");
  if (std::fflush(file_) != 0) fail(errnoText("cannot write"));
  if (::fsync(::fileno(file_)) != 0) fail(errnoText("cannot sync to disk"));
  std::FILE* f = file_;
  file_ = nullptr;
  if (std::fclose(f) != 0) fail(errnoText("cannot write"));
  if (std::rename(temporary_.c_str(), target_.c_str()) != 0) fail(errnoText("cannot replace the file"));
  temporary_.clear();
  syncDirectory(directoryOf(target_));
}

} // namespace hdt
