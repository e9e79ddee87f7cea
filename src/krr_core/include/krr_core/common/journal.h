/**
 * @file journal.h
 * @brief Several files replaced as one: after a crash either every new content or every old
 * one is there, never a mix.
 *
 * One knowledge update can change two files (learned navigation knowledge and added domain
 * statements). writeFileAtomic makes each write atomic, but a kill between the two would leave
 * half an update. A FileTransaction first writes every new content into one journal file
 * (atomically: that write is the commit point), then replaces the files one by one, then
 * removes the journal. recover() at start-up completes a transaction that a crash interrupted.
 */
#pragma once

#include <string>
#include <utility>
#include <vector>

namespace krr {

class FileTransaction {
 public:
  /// @param journal_path where the journal is written (same file system as the targets).
  explicit FileTransaction(std::string journal_path);

  /// @brief Stage: `path` gets `text` at commit().
  void write(const std::string& path, const std::string& text);

  /**
   * @brief Write the journal (commit point), then every staged file, then remove the journal.
   * @throws IoError naming the file. If the journal could not be written nothing changed; if a
   * target could not be written the journal stays and recover() finishes the transaction.
   */
  void commit();

  /**
   * @brief Finish an interrupted transaction: when `journal_path` exists, write the files it
   * holds and remove it. @return how many files were written (0: no journal).
   * @throws ParseError (journal:line:1) for a journal that is not one this class wrote, and
   * IoError when a file cannot be written (the journal is then kept).
   */
  static std::size_t recover(const std::string& journal_path);

 private:
  std::string journal_;
  std::vector<std::pair<std::string, std::string>> files_;
};

/**
 * @brief Remove temporary files that writeFileAtomic left in `dir` when its process was killed
 * (".tmp_" plus six characters) and that are older than `min_age_s` seconds (younger ones may
 * belong to a write in progress). @return the paths removed.
 */
std::vector<std::string> removeOrphanTemporaries(const std::string& dir, double min_age_s = 10.0);

}  // namespace krr
