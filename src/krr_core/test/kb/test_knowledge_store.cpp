// The knowledge-update transaction without ROS: validation on scratch copies, the journal,
// refusals that change nothing, and recovery at start (exactly the acknowledged updates; a torn
// journal or learned file is set aside with its typed error).
//
// Domain KB: config/office.plog (P(curr_room(bob)=room2 | do(curr_person=bob)) = 0.8).
// Navigation KB: the 3 x 2 grid of nav_fixtures.h (cells 0..5, blocking area ba1 = cell 4).
#include <gtest/gtest.h>

#include <algorithm>
#include <filesystem>
#include <memory>
#include <string>
#include <vector>

#include "../support/nav_fixtures.h"
#include "krr_core/common/errors.h"
#include "krr_core/common/files.h"
#include "krr_core/kb/knowledge_store.h"
#include "krr_core/mdp/navigation_task.h"
#include "krr_core/plog/budget.h"

namespace {

namespace fs = std::filesystem;
using krr::kb::KnowledgeState;
using krr::kb::KnowledgeStore;
using krr::kb::KnowledgeUpdate;
using krr::kb::NavigationKnowledge;
using krr::kb::PreparedUpdate;

const char* const kBobQuery = "?{curr_room(bob)=room2} | do(curr_person=bob)";
const char* const kBob09 = "pr(curr_room(bob)=room2 | place(bob,room2)=true) = 9/10.";
const char* const kBob07 = "pr(curr_room(bob)=room2 | place(bob,room2)=true) = 7/10.";
constexpr int kRight = 3;

/// @brief A store over a fresh directory: office.plog, the tiny grid's navigation KB, and the
/// learned files learned_nav.plog / learned_domain.plog there.
struct Fixture {
  std::string dir = krr_test::tempDir("knowledge_store");
  std::string learned = dir + "/learned_nav.plog";
  std::string added = dir + "/learned_domain.plog";
  std::shared_ptr<const krr::nav::NavGrid> grid =
      std::make_shared<krr::nav::NavGrid>(krr_test::tinyGrid());

  std::unique_ptr<KnowledgeStore> store() const {
    krr::kb::KnowledgeStoreOptions o;
    o.domain_files = {krr_test::repoPath("config/office.plog")};
    o.learned_file = learned;
    o.domain_learned_file = added;
    return std::make_unique<KnowledgeStore>(
        o, grid,
        std::vector<std::string>{std::string(KRR_TEST_DATA_DIR) + "/kb/tiny_geometry.plog",
                                 krr_test::repoPath("config/navigation.plog")});
  }
  /// @brief Every file of the directory with its content: "nothing changed on disk".
  std::vector<std::pair<std::string, std::string>> disk() const {
    std::vector<std::pair<std::string, std::string>> out;
    for (const auto& e : fs::directory_iterator(dir))
      out.emplace_back(e.path().filename().string(),
                       e.is_regular_file() ? krr::readFile(e.path().string()) : "<dir>");
    std::sort(out.begin(), out.end());
    return out;
  }
};

krr::plog::GroundingLimits anyPhase(const char*) { return {}; }

/// @brief R-Max's known pair (3, right) at cell outcomes (-1: trapped).
std::vector<krr::mdp::KnownPair> learnedCell3Right(const NavigationKnowledge& kb,
                                                   const std::vector<int>& outcomes) {
  const auto& sp = kb.space();
  auto task = krr::mdp::makeNavigationRMaxTask(sp.numStates(), 4, {sp.placeState("room1")},
                                               {sp.trappedState()}, krr::mdp::NavigationReward());
  krr::mdp::RMaxModel model(task, 0.95, static_cast<std::uint32_t>(outcomes.size()), 40.0);
  for (int c : outcomes)
    model.observe(sp.stateOf(3), kRight, c < 0 ? sp.trappedState() : sp.stateOf(c));
  return model.knownPairs();
}

/// @brief `u` prepared on a fresh navigation KB at `state` (built only when asked; kept in
/// `scratch`, which a caller discards on refusal).
PreparedUpdate prepareOnScratch(const KnowledgeStore& store, const KnowledgeState& state,
                                const KnowledgeUpdate& u,
                                std::unique_ptr<NavigationKnowledge>& scratch) {
  return store.prepare(
      u, state,
      [&]() -> NavigationKnowledge& {
        scratch = store.buildNavigationKb(state.learned_text);
        return *scratch;
      },
      anyPhase);
}

/// @brief The update prepared on a scratch navigation KB at `state` and committed.
KnowledgeState apply(const KnowledgeStore& store, const KnowledgeState& state,
                     const KnowledgeUpdate& u, PreparedUpdate* prepared = nullptr) {
  std::unique_ptr<NavigationKnowledge> scratch;
  PreparedUpdate p = prepareOnScratch(store, state, u, scratch);
  KnowledgeState next = store.commit(p, state);
  if (prepared) *prepared = std::move(p);
  return next;
}

KnowledgeUpdate statementsUpdate(const std::string& statements) {
  KnowledgeUpdate u;
  u.source = "test";
  u.statements = statements;
  return u;
}

TEST(KnowledgeStore, AnAcceptedUpdateIsAppliedAndWrittenThroughTheJournal) {
  Fixture f;
  auto store = f.store();
  auto opened = store->open();
  EXPECT_EQ(opened.state.total_learned, 0u);
  EXPECT_NEAR(opened.domain->probability(kBobQuery), 0.8, 1e-12);
  ASSERT_EQ(store->times(), (std::vector<std::string>{"morning", "noon", "afternoon"}));

  KnowledgeUpdate u = statementsUpdate(kBob09);
  u.pairs["noon"] = learnedCell3Right(*opened.nav, {4, 4, 3, -1});
  PreparedUpdate p;
  const KnowledgeState next = apply(*store, opened.state, u, &p);
  EXPECT_EQ(p.statements_added, 1u);
  EXPECT_EQ(p.atoms_added, 1u);
  EXPECT_EQ(next.domain_version, opened.state.domain_version + 1);
  EXPECT_EQ(next.nav_version, opened.state.nav_version + 1);
  EXPECT_EQ(next.num_added, 1u);
  EXPECT_EQ(next.total_learned, 1u);
  // On disk: both files, and no journal left once the transaction is complete.
  EXPECT_EQ(krr::readFile(f.added), std::string("% added by test\n") + kBob09 + "\n");
  EXPECT_EQ(krr::readFile(f.learned), next.learned_text);
  EXPECT_NE(next.learned_text.find("curr_cell=3, act_move=right, curr_time=noon) = 2/4."),
            std::string::npos)
      << next.learned_text;
  EXPECT_FALSE(fs::exists(store->journalPath()));
  // In memory: the prepared domain KB and one rebuilt from the new state answer with it.
  EXPECT_NEAR(p.domain->probability(kBobQuery), 0.9, 1e-12);
  EXPECT_NEAR(store->buildDomainKb(next.added_text)->probability(kBobQuery), 0.9, 1e-12);
  // The KB open() returned is the caller's: the store did not touch it.
  EXPECT_NEAR(opened.domain->probability(kBobQuery), 0.8, 1e-12);
}

TEST(KnowledgeStore, ARefusedUpdateChangesNothingInMemoryOrOnDisk) {
  Fixture f;
  auto store = f.store();
  auto opened = store->open();
  // One accepted update first, so that there is something on disk to keep.
  KnowledgeUpdate first;
  first.source = "test";
  first.pairs["morning"] = learnedCell3Right(*opened.nav, {4, 4});
  const KnowledgeState state = apply(*store, opened.state, first);
  const auto disk = f.disk();

  struct Case {
    KnowledgeUpdate update;
    const char* needle;
  };
  std::vector<Case> cases;
  cases.push_back({KnowledgeUpdate(), "neither atoms, area knowledge nor statements"});
  cases.push_back({statementsUpdate("pr(curr_room(bob"), "<update from test>:1:"});
  cases.push_back({statementsUpdate("pr(mood(bob)=happy) = 1/2."), "undeclared attribute 'mood'"});
  cases.push_back({statementsUpdate("pr(curr_room(bob)=room9 | place(bob,room2)=true) = 1/2."),
                   "unknown value 'room9'"});
  cases.push_back(
      {statementsUpdate("pr(curr_room(bob)=room3 | place(bob,room2)=true) = 5/10."),
       "incoherent"});
  cases.push_back({statementsUpdate("obs(curr_person=john). obs(curr_person=bob)."),
                   "incoherent"});
  KnowledgeUpdate midnight;
  midnight.area_time = "midnight";
  midnight.area_statements = "learned_noise(midnight).";
  cases.push_back({midnight, "area_time 'midnight'"});
  KnowledgeUpdate bad_area;
  bad_area.area_time = "noon";
  bad_area.area_statements = "pr(walkers(ba9)=true | curr_time=noon) = 1/4.";
  cases.push_back({bad_area, "ba9"});
  KnowledgeUpdate bad_time;
  bad_time.pairs["midnight"] = learnedCell3Right(*opened.nav, {4});
  cases.push_back({bad_time, "'midnight'"});
  // A valid pair with invalid statements: all or nothing.
  KnowledgeUpdate mixed = statementsUpdate("pr(curr_room(bob");
  mixed.pairs["noon"] = learnedCell3Right(*opened.nav, {4});
  cases.push_back({mixed, "<update from test>:1:"});

  for (const Case& c : cases) {
    std::unique_ptr<NavigationKnowledge> scratch;
    try {
      prepareOnScratch(*store, state, c.update, scratch);
      ADD_FAILURE() << "accepted: " << c.needle;
    } catch (const krr::Error& e) {
      EXPECT_NE(std::string(e.what()).find(c.needle), std::string::npos) << e.what();
    }
    EXPECT_EQ(f.disk(), disk) << c.needle;
  }
  // The refused statements reached no KB in use, and a restart sees the accepted update only.
  EXPECT_NEAR(opened.domain->probability(kBobQuery), 0.8, 1e-12);
  auto reopened = f.store()->open();
  EXPECT_EQ(reopened.state.learned_text, state.learned_text);
  EXPECT_EQ(reopened.state.num_added, 0u);
  EXPECT_NEAR(reopened.domain->probability(kBobQuery), 0.8, 1e-12);
}

TEST(KnowledgeStore, APhaseOverItsBudgetIsRefusedBeforeAnythingIsWritten) {
  Fixture f;
  auto store = f.store();
  auto opened = store->open();
  const auto disk = f.disk();
  bool asked_for_scratch = false;
  EXPECT_THROW(store->prepare(statementsUpdate(kBob09), opened.state,
                              [&]() -> NavigationKnowledge& {
                                asked_for_scratch = true;
                                return *opened.nav;
                              },
                              [](const char* phase) -> krr::plog::GroundingLimits {
                                throw krr::plog::BudgetExceededError(
                                    std::string("no time left for ") + phase);
                              }),
               krr::plog::BudgetExceededError);
  EXPECT_FALSE(asked_for_scratch);  // statements only: the navigation KB is never needed
  EXPECT_EQ(f.disk(), disk);
}

TEST(KnowledgeStore, AJournalThatCannotBeWrittenChangesNoFile) {
  Fixture f;
  auto store = f.store();
  auto opened = store->open();
  const KnowledgeState state = apply(*store, opened.state, statementsUpdate(kBob09));
  // The journal's path is taken by a directory: the commit point cannot be reached.
  fs::create_directory(store->journalPath());
  const auto disk = f.disk();
  KnowledgeUpdate u = statementsUpdate(kBob07);
  u.pairs["noon"] = learnedCell3Right(*opened.nav, {4});
  std::string restore_error;
  std::unique_ptr<NavigationKnowledge> scratch;
  const PreparedUpdate p = prepareOnScratch(*store, state, u, scratch);
  EXPECT_THROW(store->commit(p, state, &restore_error), krr::IoError);
  EXPECT_NE(restore_error, "");  // the write-back needs the journal too
  // Every file as it was, and no temporary left behind by the atomic writes.
  EXPECT_EQ(f.disk(), disk);
}

TEST(KnowledgeStore, RestartRecoversExactlyTheAcknowledgedUpdates) {
  Fixture f;
  KnowledgeState acknowledged;
  {
    auto store = f.store();
    auto opened = store->open();
    KnowledgeState s = apply(*store, opened.state, statementsUpdate(kBob09));
    EXPECT_THROW(apply(*store, s, statementsUpdate("pr(curr_room(bob")), krr::ParseError);
    KnowledgeUpdate nav;
    nav.source = "learner";
    nav.pairs["noon"] = learnedCell3Right(*opened.nav, {4, 4, 3, -1});
    nav.area_time = "noon";
    nav.area_statements = "pr(walkers(ba1)=true | curr_time=noon) = 1/4.\n";
    s = apply(*store, s, nav);
    acknowledged = s;
    // A commit that fails half-way (the added-statements file cannot be replaced: a directory
    // holds its path) is not acknowledged; its write-back fails on the same file and leaves
    // the old contents in the journal.
    const std::string held = f.added + ".held";
    fs::rename(f.added, held);
    fs::create_directory(f.added);
    KnowledgeUpdate late = statementsUpdate(kBob07);
    late.pairs["morning"] = learnedCell3Right(*opened.nav, {4});
    std::string restore_error;
    std::unique_ptr<NavigationKnowledge> scratch;
    const PreparedUpdate p = prepareOnScratch(*store, s, late, scratch);
    EXPECT_THROW(store->commit(p, s, &restore_error), krr::IoError);
    EXPECT_NE(restore_error.find(f.added), std::string::npos) << restore_error;
    ASSERT_TRUE(fs::exists(store->journalPath()));
    fs::remove(f.added);  // the obstacle goes (a file system that was full frees up)
    fs::rename(held, f.added);
  }
  auto reopened = f.store()->open();
  EXPECT_EQ(reopened.report.journal_files, 2u);  // the write-back finished from its journal
  EXPECT_TRUE(reopened.report.set_aside.empty());
  EXPECT_FALSE(fs::exists(f.store()->journalPath()));
  EXPECT_EQ(reopened.state.added_text, acknowledged.added_text);
  EXPECT_EQ(reopened.state.num_added, 1u);
  EXPECT_EQ(reopened.state.learned_text, acknowledged.learned_text);
  EXPECT_EQ(reopened.state.total_learned, acknowledged.total_learned);
  EXPECT_NE(reopened.state.learned_text.find("walkers(ba1)"), std::string::npos);
  EXPECT_EQ(reopened.nav->learnedPairCount("morning"), 0u);
  EXPECT_NEAR(reopened.domain->probability(kBobQuery), 0.9, 1e-12);
}

TEST(KnowledgeStore, ATornJournalIsSetAsideWithAParseErrorNotACrash) {
  Fixture f;
  KnowledgeState acknowledged;
  {
    auto store = f.store();
    auto opened = store->open();
    acknowledged = apply(*store, opened.state, statementsUpdate(kBob09));
  }
  // A journal cut off in the middle of an entry, as a torn write would leave it.
  const std::string journal = f.learned + ".journal";
  krr::writeFileAtomic(journal, "krr-file-transaction 1\nfile " +
                                    std::to_string(f.added.size()) + " 4000\n" + f.added +
                                    "% added by");
  auto store = f.store();
  KnowledgeStore::Opened opened;
  ASSERT_NO_THROW(opened = store->open());
  ASSERT_EQ(opened.report.set_aside.size(), 1u);
  const auto& aside = opened.report.set_aside[0];
  EXPECT_EQ(aside.path, journal);
  EXPECT_THROW(std::rethrow_exception(aside.error), krr::ParseError);
  EXPECT_NE(aside.why.find("not a complete file-transaction journal"), std::string::npos)
      << aside.why;
  ASSERT_FALSE(aside.aside.empty());
  EXPECT_TRUE(fs::exists(aside.aside));
  EXPECT_FALSE(fs::exists(journal));
  // Nothing of the torn journal was applied: the acknowledged knowledge is intact.
  EXPECT_EQ(opened.state.added_text, acknowledged.added_text);
  EXPECT_EQ(krr::readFile(f.added), acknowledged.added_text);
}

TEST(KnowledgeStore, ALearnedFileThatDoesNotLoadIsSetAsideWithItsError) {
  Fixture f;
  krr::writeFileAtomic(f.learned, "pr(next_cell=4 | curr_cell=3, act_move=right");
  krr::writeFileAtomic(f.added, "pr(curr_room(bob)=room3 | place(bob,room2)=true) = 5/10.\n");
  auto opened = f.store()->open();
  ASSERT_EQ(opened.report.set_aside.size(), 2u);
  EXPECT_EQ(opened.report.set_aside[0].path, f.added);
  EXPECT_THROW(std::rethrow_exception(opened.report.set_aside[0].error),
               krr::IncoherentError);
  EXPECT_EQ(opened.report.set_aside[1].path, f.learned);
  EXPECT_THROW(std::rethrow_exception(opened.report.set_aside[1].error), krr::ParseError);
  EXPECT_FALSE(fs::exists(f.learned));
  EXPECT_FALSE(fs::exists(f.added));
  EXPECT_EQ(opened.state.learned_text, "");
  EXPECT_EQ(opened.state.num_added, 0u);
  EXPECT_NEAR(opened.domain->probability(kBobQuery), 0.8, 1e-12);
}

TEST(KnowledgeStore, RefusesFilesItCannotKeepApart) {
  Fixture f;
  f.added = f.learned;
  EXPECT_THROW(f.store(), krr::ConfigError);
}

}  // namespace
