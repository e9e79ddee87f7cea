#include "krr_core/common/journal.h"

#include <sys/stat.h>
#include <unistd.h>

#include <ctime>
#include <dirent.h>
#include <sstream>

#include "krr_core/common/errors.h"
#include "krr_core/common/files.h"

namespace krr {

namespace {
const char* const kMagic = "krr-file-transaction 1";
}  // namespace

FileTransaction::FileTransaction(std::string journal_path) : journal_(std::move(journal_path)) {}

void FileTransaction::write(const std::string& path, const std::string& text) {
  for (auto& f : files_)
    if (f.first == path) {
      f.second = text;
      return;
    }
  files_.emplace_back(path, text);
}

void FileTransaction::commit() {
  // Each entry: "file <path bytes> <text bytes>\n<path><text>\n"; "end\n" marks completeness.
  std::ostringstream o;
  o << kMagic << "\n";
  for (const auto& [path, text] : files_)
    o << "file " << path.size() << " " << text.size() << "\n" << path << text << "\n";
  o << "end\n";
  writeFileAtomic(journal_, o.str());
  for (const auto& [path, text] : files_) writeFileAtomic(path, text);
  if (::unlink(journal_.c_str()) != 0) throw IoError("cannot remove journal " + journal_);
  files_.clear();
}

std::size_t FileTransaction::recover(const std::string& journal_path) {
  struct stat st;
  if (::stat(journal_path.c_str(), &st) != 0) return 0;
  const std::string j = readFile(journal_path);
  std::vector<std::pair<std::string, std::string>> files;
  std::size_t at = 0;
  int line = 1;
  auto fail = [&](const std::string& what) {
    throw ParseError({journal_path, line, 1}, "not a complete file-transaction journal: " + what);
  };
  const std::string magic = std::string(kMagic) + "\n";
  if (j.compare(0, magic.size(), magic) != 0) fail("bad first line");
  at = magic.size();
  ++line;
  while (true) {
    if (j.compare(at, 4, "end\n") == 0 && at + 4 == j.size()) break;
    const std::size_t eol = j.find('\n', at);
    if (eol == std::string::npos) fail("truncated");
    std::istringstream head(j.substr(at, eol - at));
    std::string word;
    unsigned long long plen = 0, tlen = 0;
    if (!(head >> word >> plen >> tlen) || word != "file") fail("expected 'file <n> <m>'");
    at = eol + 1;
    if (plen == 0 || plen > j.size() - at || tlen > j.size() - at - plen ||
        j.size() - at - plen - tlen < 1 || j[at + plen + tlen] != '\n')
      fail("entry sizes exceed the journal");
    files.emplace_back(j.substr(at, plen), j.substr(at + plen, tlen));
    for (std::size_t k = at; k < at + plen + tlen + 1; ++k) line += j[k] == '\n';
    at += plen + tlen + 1;
    ++line;
  }
  for (const auto& [path, text] : files) writeFileAtomic(path, text);
  if (::unlink(journal_path.c_str()) != 0) throw IoError("cannot remove journal " + journal_path);
  return files.size();
}

std::vector<std::string> removeOrphanTemporaries(const std::string& dir, double min_age_s) {
  std::vector<std::string> removed;
  DIR* d = ::opendir(dir.c_str());
  if (!d) return removed;
  const std::time_t now = std::time(nullptr);
  while (const dirent* e = ::readdir(d)) {
    const std::string name = e->d_name;
    if (name.size() != 11 || name.compare(0, 5, ".tmp_") != 0) continue;  // mkstemp: 6 chars
    const std::string path = dir + "/" + name;
    struct stat st;
    if (::lstat(path.c_str(), &st) != 0 || !S_ISREG(st.st_mode)) continue;
    if (std::difftime(now, st.st_mtime) < min_age_s) continue;
    if (::unlink(path.c_str()) == 0) removed.push_back(path);
  }
  ::closedir(d);
  return removed;
}

}  // namespace krr
