// The MDP model contract (krr_core/mdp/model_concept.h): the product models satisfy it and a
// type missing a member does not. Mostly compile-time checks; a failing one stops the build.
#include <gtest/gtest.h>

#include <utility>
#include <vector>

#include "krr_core/mdp/grid_model.h"
#include "krr_core/mdp/model_concept.h"
#include "krr_core/mdp/navigation_task.h"
#include "krr_core/mdp/rmax_model.h"
#include "krr_core/mdp/solvers.h"
#include "krr_core/mdp/sparse_model.h"

using namespace krr::mdp;

namespace {

// Every member of the contract, as a template to knock members out of.
struct Complete {
  std::size_t getS() const { return 2; }
  std::size_t getA() const { return 1; }
  double getDiscount() const { return 0.9; }
  double getTransitionProbability(StateId, ActionId, StateId s1) const { return s1 == 1; }
  double getExpectedReward(StateId s, ActionId) const { return s == 0 ? 1.0 : 0.0; }
  bool isTerminal(StateId s) const { return s == 1; }
  std::vector<Outcome> successors(StateId, ActionId) const { return {Outcome{1, 1.0}}; }
};

struct NoDiscount {
  std::size_t getS() const { return 2; }
  std::size_t getA() const { return 1; }
  double getTransitionProbability(StateId, ActionId, StateId) const { return 0.0; }
  double getExpectedReward(StateId, ActionId) const { return 0.0; }
};

struct NoTransition {
  std::size_t getS() const { return 2; }
  std::size_t getA() const { return 1; }
  double getDiscount() const { return 0.9; }
  double getExpectedReward(StateId, ActionId) const { return 0.0; }
};

// A reward that is not a number.
struct BadReward {
  std::size_t getS() const { return 2; }
  std::size_t getA() const { return 1; }
  double getDiscount() const { return 0.9; }
  double getTransitionProbability(StateId, ActionId, StateId) const { return 0.0; }
  std::vector<int> getExpectedReward(StateId, ActionId) const { return {}; }
};

// An MDP model without successor lists (like the grid layout).
struct NoSuccessors {
  std::size_t getS() const { return 2; }
  std::size_t getA() const { return 1; }
  double getDiscount() const { return 0.9; }
  double getTransitionProbability(StateId, ActionId, StateId) const { return 0.0; }
  double getExpectedReward(StateId, ActionId) const { return 0.0; }
  bool isTerminal(StateId) const { return false; }
};

// Successors that are not outcomes.
struct BadSuccessors : NoSuccessors {
  std::vector<int> successors(StateId, ActionId) const { return {1}; }
};

// The product models.
static_assert(is_successor_model_v<SparseModel>, "SparseModel");
static_assert(is_successor_model_v<RMaxModel>, "RMaxModel (R-Max's planning view)");
using NavigationTaskModel = decltype(makeNavigationTask(
    std::declval<const SparseModel&>(), std::declval<const std::vector<StateId>&>(),
    std::declval<const std::vector<StateId>&>(), std::declval<const NavigationReward&>()));
static_assert(is_successor_model_v<NavigationTaskModel>, "the navigation task model");
static_assert(is_mdp_model_v<GridModel>, "GridModel");
static_assert(is_mdp_model_v<GridModelF>, "GridModelF");
static_assert(!is_successor_model_v<GridModel>, "the grid layout has its own solver");

// The contract, member by member.
static_assert(is_successor_model_v<Complete>, "complete");
static_assert(!is_mdp_model_v<NoDiscount>, "getDiscount missing");
static_assert(!is_mdp_model_v<NoTransition>, "getTransitionProbability missing");
static_assert(!is_mdp_model_v<BadReward>, "getExpectedReward not a number");
static_assert(!is_mdp_model_v<int>, "not a class");
static_assert(is_mdp_model_v<NoSuccessors> && !is_successor_model_v<NoSuccessors>, "no successors");
static_assert(!is_successor_model_v<BadSuccessors>, "successors not outcomes");

#if defined(__cpp_concepts) && __cpp_concepts >= 201907L
static_assert(SuccessorModel<SparseModel> && SuccessorModel<RMaxModel> && MdpModel<GridModel>);
static_assert(!MdpModel<NoDiscount> && !SuccessorModel<NoSuccessors>);
#endif

}  // namespace

TEST(ModelConcept, TraitsAgreeWithTheCompileTimeChecks) {
  EXPECT_TRUE(is_successor_model<SparseModel>::value);
  EXPECT_TRUE(is_mdp_model<GridModel>::value);
  EXPECT_FALSE(is_mdp_model<NoTransition>::value);
  EXPECT_FALSE(is_successor_model<NoSuccessors>::value);
}

TEST(ModelConcept, AnyModelOfTheContractIsSolvedByTheGenericSolver) {
  // The hand-written model: V(0) = R(0) + 0.9 * V(1) = 1 (state 1 terminal).
  const Solution s = valueIterationView(Complete(), SolverOptions());
  ASSERT_TRUE(s.converged);
  EXPECT_DOUBLE_EQ(s.values[0], 1.0);
  EXPECT_DOUBLE_EQ(s.values[1], 0.0);
}
