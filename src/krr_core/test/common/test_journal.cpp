// FileTransaction: several files replaced as one, also across a crash.
#include <gtest/gtest.h>
#include <sys/stat.h>
#include <unistd.h>

#include <fstream>
#include <utime.h>

#include "krr_core/common/errors.h"
#include "krr_core/common/files.h"
#include "krr_core/common/journal.h"

namespace {

std::string tempDir() {
  char tmpl[] = "/tmp/krr_journal_XXXXXX";
  return ::mkdtemp(tmpl);
}

bool exists(const std::string& p) {
  struct stat st;
  return ::stat(p.c_str(), &st) == 0;
}

TEST(FileTransaction, CommitWritesEveryFileAndRemovesTheJournal) {
  const std::string d = tempDir();
  krr::writeFileAtomic(d + "/a", "old a");
  krr::FileTransaction t(d + "/journal");
  t.write(d + "/a", "new a\nwith lines\n");
  t.write(d + "/b", "");  // empty content is a content
  t.write(d + "/a", "newer a");  // the last staged text wins
  t.commit();
  EXPECT_EQ(krr::readFile(d + "/a"), "newer a");
  EXPECT_EQ(krr::readFile(d + "/b"), "");
  EXPECT_FALSE(exists(d + "/journal"));
  EXPECT_EQ(krr::FileTransaction::recover(d + "/journal"), 0u);
}

TEST(FileTransaction, RecoverFinishesATransactionThatStoppedHalfway) {
  const std::string d = tempDir();
  krr::writeFileAtomic(d + "/a", "old a");
  // The second target's directory does not exist yet: commit() writes the journal and the
  // first file, then fails, as a crash between the two writes would leave it.
  krr::FileTransaction t(d + "/journal");
  t.write(d + "/a", "new a");
  t.write(d + "/sub/b", "new\nb");
  EXPECT_THROW(t.commit(), krr::IoError);
  EXPECT_EQ(krr::readFile(d + "/a"), "new a");
  EXPECT_TRUE(exists(d + "/journal"));
  krr::makeDirectories(d + "/sub");
  EXPECT_EQ(krr::FileTransaction::recover(d + "/journal"), 2u);
  EXPECT_EQ(krr::readFile(d + "/a"), "new a");
  EXPECT_EQ(krr::readFile(d + "/sub/b"), "new\nb");
  EXPECT_FALSE(exists(d + "/journal"));
}

TEST(FileTransaction, AForeignOrTruncatedJournalIsAParseErrorAndChangesNothing) {
  const std::string d = tempDir();
  krr::writeFileAtomic(d + "/a", "old a");
  const std::string good = "krr-file-transaction 1\nfile " + std::to_string((d + "/a").size()) +
                           " 5\n" + d + "/a" + "new a\nend\n";
  for (const std::string& bad :
       {std::string("hello\n"), good.substr(0, good.size() - 4), good.substr(0, 30),
        std::string("krr-file-transaction 1\nfile 99999 5\nxx\nend\n"),
        std::string("krr-file-transaction 1\nfile -1 5\n\nend\n")}) {
    krr::writeFileAtomic(d + "/journal", bad);
    EXPECT_THROW(krr::FileTransaction::recover(d + "/journal"), krr::ParseError) << bad;
    EXPECT_EQ(krr::readFile(d + "/a"), "old a");
    EXPECT_TRUE(exists(d + "/journal")) << "kept for inspection";
  }
  krr::writeFileAtomic(d + "/journal", good);
  EXPECT_EQ(krr::FileTransaction::recover(d + "/journal"), 1u);
  EXPECT_EQ(krr::readFile(d + "/a"), "new a");
}

TEST(FileTransaction, OnlyOldOrphanTemporariesAreRemoved) {
  const std::string d = tempDir();
  krr::writeFileAtomic(d + "/.tmp_AbC123", "orphan");
  krr::writeFileAtomic(d + "/.tmp_young1", "in progress");
  krr::writeFileAtomic(d + "/.tmp_toolongname", "not ours");
  krr::writeFileAtomic(d + "/keep.plog", "knowledge");
  struct utimbuf old;
  old.actime = old.modtime = ::time(nullptr) - 3600;
  ASSERT_EQ(::utime((d + "/.tmp_AbC123").c_str(), &old), 0);
  ASSERT_EQ(::utime((d + "/.tmp_toolongname").c_str(), &old), 0);
  ASSERT_EQ(::utime((d + "/keep.plog").c_str(), &old), 0);
  const auto removed = krr::removeOrphanTemporaries(d, 10.0);
  ASSERT_EQ(removed.size(), 1u);
  EXPECT_EQ(removed[0], d + "/.tmp_AbC123");
  EXPECT_TRUE(exists(d + "/.tmp_young1"));
  EXPECT_TRUE(exists(d + "/.tmp_toolongname"));
  EXPECT_TRUE(exists(d + "/keep.plog"));
  EXPECT_TRUE(krr::removeOrphanTemporaries(d + "/missing").empty());
}

}  // namespace
