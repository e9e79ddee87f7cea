#include "krr_core/common/files.h"

#include <fcntl.h>
#include <sys/file.h>
#include <sys/stat.h>
#include <unistd.h>

#include <cerrno>
#include <cstdlib>
#include <cstdio>
#include <cstring>
#include <fstream>
#include <sstream>
#include <vector>

#include "krr_core/common/errors.h"
#include "krr_core/common/limits.h"

namespace krr {

namespace {

/// @brief What kind of file st is, for the "not a regular file" error.
const char* fileKind(const struct stat& st) {
  if (S_ISDIR(st.st_mode)) return "a directory";
  if (S_ISCHR(st.st_mode)) return "a character device";
  if (S_ISBLK(st.st_mode)) return "a block device";
  if (S_ISFIFO(st.st_mode)) return "a pipe";
  if (S_ISSOCK(st.st_mode)) return "a socket";
  return "not a regular file";
}

}  // namespace

std::string readFile(const std::string& path) {
  // O_NONBLOCK: opening a FIFO without a writer must not hang; it is refused just below.
  const int fd = ::open(path.c_str(), O_RDONLY | O_CLOEXEC | O_NONBLOCK);
  if (fd < 0) throw IoError(path + ": cannot open for reading: " + std::strerror(errno));
  struct stat st {};
  if (::fstat(fd, &st) != 0) {
    const int e = errno;
    ::close(fd);
    throw IoError(path + ": cannot stat: " + std::strerror(e));
  }
  // Devices and pipes have no size and may never end (image: /dev/zero), so they are refused.
  if (!S_ISREG(st.st_mode)) {
    ::close(fd);
    throw IoError(path + ": is " + fileKind(st) + ", expected a regular file");
  }
  const std::size_t budget = memoryBudget();
  if (static_cast<std::size_t>(st.st_size) > budget) {
    ::close(fd);
    throw IoError(path + ": file of " + formatBytes(static_cast<std::size_t>(st.st_size)) +
                  " exceeds the memory budget of " + formatBytes(budget) +
                  " (set KRR_MEMORY_BUDGET_MIB to raise it)");
  }
  std::string out;
  out.reserve(static_cast<std::size_t>(st.st_size));
  char buf[65536];
  for (;;) {
    const ssize_t n = ::read(fd, buf, sizeof buf);
    if (n < 0) {
      if (errno == EINTR) continue;
      const int e = errno;
      ::close(fd);
      throw IoError(path + ": read error: " + std::strerror(e));
    }
    if (n == 0) break;
    out.append(buf, static_cast<std::size_t>(n));
    // A file that grows while it is read is still held to the budget.
    if (out.size() > budget) {
      ::close(fd);
      throw IoError(path + ": file exceeds the memory budget of " + formatBytes(budget));
    }
  }
  ::close(fd);
  return out;
}

bool isRegularFile(const std::string& path) {
  struct stat st;
  return ::stat(path.c_str(), &st) == 0 && S_ISREG(st.st_mode);
}

std::string dirName(const std::string& path) {
  auto pos = path.find_last_of('/');
  if (pos == std::string::npos) return ".";
  if (pos == 0) return "/";
  return path.substr(0, pos);
}

FileLock::FileLock(const std::string& path) : fd_(::open(path.c_str(), O_RDWR | O_CREAT | O_CLOEXEC, 0644)) {
  if (fd_ < 0) throw IoError(path + ": cannot open lock file: " + std::strerror(errno));
  while (::flock(fd_, LOCK_EX) != 0) {
    if (errno == EINTR) continue;
    const int e = errno;
    ::close(fd_);
    throw IoError(path + ": cannot lock: " + std::strerror(e));
  }
}

FileLock::~FileLock() {
  ::flock(fd_, LOCK_UN);
  ::close(fd_);
}

void writeFileAtomic(const std::string& path, const std::string& data) {
  std::string tmpl = dirName(path) + "/.tmp_XXXXXX";
  std::string tmp(tmpl);
  int fd = ::mkstemp(&tmp[0]);
  if (fd < 0) throw IoError(path + ": cannot create temporary file: " + std::strerror(errno));
  const char* p = data.data();
  size_t left = data.size();
  while (left > 0) {
    ssize_t n = ::write(fd, p, left);
    if (n < 0) {
      if (errno == EINTR) continue;
      int e = errno;
      ::close(fd);
      ::unlink(tmp.c_str());
      throw IoError(path + ": write failed: " + std::strerror(e));
    }
    p += n;
    left -= static_cast<size_t>(n);
  }
  if (::fsync(fd) != 0 || ::fchmod(fd, 0644) != 0) {
    int e = errno;
    ::close(fd);
    ::unlink(tmp.c_str());
    throw IoError(path + ": sync failed: " + std::strerror(e));
  }
  ::close(fd);
  if (::rename(tmp.c_str(), path.c_str()) != 0) {
    int e = errno;
    ::unlink(tmp.c_str());
    throw IoError(path + ": rename failed: " + std::strerror(e));
  }
}


void makeDirectories(const std::string& dir) {
  if (dir.empty()) return;
  std::string path;
  std::size_t pos = 0;
  while (pos != std::string::npos) {
    pos = dir.find('/', pos + 1);
    path = dir.substr(0, pos);
    if (path.empty()) continue;
    struct stat st;
    if (::stat(path.c_str(), &st) == 0) {
      if (!S_ISDIR(st.st_mode)) throw IoError("directory: " + path + " is not a directory");
      continue;
    }
    if (::mkdir(path.c_str(), 0755) != 0 && errno != EEXIST)
      throw IoError("directory: cannot create " + path + ": " + std::strerror(errno));
  }
}

std::uint64_t stableHash(const std::string& text) {
  std::uint64_t h = 14695981039346656037ULL;  // FNV-1a 64-bit offset basis
  for (unsigned char c : text) {
    h ^= c;
    h *= 1099511628211ULL;
  }
  return h;
}

}  // namespace krr
