// Tests of dialogSpecFromKnowledge: the dialog prior computed by P-log reasoning.
#include <gtest/gtest.h>

#include <string>

#include "krr_core/common/errors.h"
#include "krr_core/common/files.h"
#include "krr_core/dialog/request_prior.h"

namespace krr {
namespace dialog {
namespace {

TEST(RequestPrior, OfficeKnowledgeBaseGivesTheOwnOfficePrior) {
  plog::Reasoner kb;
  kb.loadFile(std::string(KRR_TEST_DATA_DIR) + "/../../../../config/office.plog");
  const DialogSpec spec = dialogSpecFromKnowledge(kb, "office.plog");
  EXPECT_EQ(spec.items, (std::vector<std::string>{"coke", "coffee", "soda"}));
  EXPECT_EQ(spec.rooms, (std::vector<std::string>{"room1", "room2", "room3", "room4", "room5"}));
  EXPECT_EQ(spec.persons, (std::vector<std::string>{"john", "bob"}));
  // place(john, room5), place(bob, room2), pr(curr_room(P)=R | place(P,R)) = 8/10.
  const Eigen::VectorXd expected = ownOfficePrior(3, 5, {4, 1}, 0.8);
  ASSERT_EQ(spec.prior.size(), expected.size());
  for (Eigen::Index s = 0; s < expected.size(); ++s)
    EXPECT_NEAR(spec.prior(s), expected(s), 1e-12) << s;
  EXPECT_NO_THROW(DialogPomdp{spec});
}

TEST(RequestPrior, ChangedKnowledgeChangesThePrior) {
  // Bob moved to room4: the prior follows the knowledge base, not a hand-written vector.
  std::string text =
      readFile(std::string(KRR_TEST_DATA_DIR) + "/../../../../config/office.plog");
  const std::string fact = "place(bob, room2).";
  ASSERT_NE(text.find(fact), std::string::npos);
  text.replace(text.find(fact), fact.size(), "place(bob, room4).");
  plog::Reasoner kb;
  kb.loadString(text, "office_bob_room4.plog");
  const DialogSpec spec = dialogSpecFromKnowledge(kb, "office_bob_room4.plog");
  const Eigen::VectorXd expected = ownOfficePrior(3, 5, {4, 3}, 0.8);
  for (Eigen::Index s = 0; s < expected.size(); ++s)
    EXPECT_NEAR(spec.prior(s), expected(s), 1e-12) << s;
}

TEST(RequestPrior, MissingSortsAreNamed) {
  plog::Reasoner kb;
  kb.loadString("color = {red, blue}.\n", "colors.plog");
  try {
    dialogSpecFromKnowledge(kb, "colors.plog");
    ADD_FAILURE() << "accepted a KB without the dialog sorts";
  } catch (const UnknownSymbolError& e) {
    EXPECT_NE(std::string(e.what()).find("colors.plog"), std::string::npos) << e.what();
    EXPECT_NE(std::string(e.what()).find("item"), std::string::npos) << e.what();
  }
}

}  // namespace
}  // namespace dialog
}  // namespace krr
