/**
 * @file files.h
 * @brief Reading whole files and writing them atomically.
 *
 * Learned knowledge and results must never be lost to a crash or a full disk halfway through a
 * write, so every file the stack writes goes through writeFileAtomic: the data is written to a
 * temporary file in the same directory, flushed to disk, and renamed over the target.
 */
#pragma once

#include <cstdint>
#include <string>

namespace krr {

/// @brief The whole content of a regular file. @throws IoError naming the file if it cannot be
/// read, is not a regular file (device, pipe, directory: /dev/zero never ends) or is larger
/// than memoryBudget() (limits.h).
std::string readFile(const std::string& path);

/// @brief Replace path's content with data atomically (temp file + fsync + rename).
/// @throws IoError naming the file; the previous content is then left untouched.
void writeFileAtomic(const std::string& path, const std::string& data);

/// @brief Whether `path` names a regular file (following symlinks): what a reader of files
/// can open (not a directory, device or pipe). Never throws.
bool isRegularFile(const std::string& path);

/// @brief Directory part of a path ("." when there is none).
std::string dirName(const std::string& path);

/// @brief Create a directory and its parents (like mkdir -p). @throws IoError naming it.
void makeDirectories(const std::string& dir);

/// @brief Stable 64-bit FNV-1a hash of a text (cache keys: the same text, the same name on
/// every run and machine).
std::uint64_t stableHash(const std::string& text);


/**
 * @brief An exclusive advisory lock on a lock file (flock), held until destruction; the kernel
 * releases it if the process dies. Cache entries that are expensive to make (learned knowledge,
 * solved policies) are made under one, so parallel trial processes make each entry once and
 * the others wait and load it.
 */
class FileLock {
 public:
  /// @brief Create `path` if needed and lock it (blocks). @throws IoError naming it.
  explicit FileLock(const std::string& path);
  ~FileLock();
  FileLock(const FileLock&) = delete;
  FileLock& operator=(const FileLock&) = delete;

 private:
  int fd_;
};

}  // namespace krr
