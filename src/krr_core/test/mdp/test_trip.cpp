#include <gtest/gtest.h>

#include <string>
#include <vector>

#include "krr_core/mdp/trip.h"

namespace krr {
namespace mdp {
namespace {

/// A scripted trip: move k does script[k - 1] ('.' on, 'g' reaches, 'x' fails, 's' cannot be
/// made); the moves made are recorded.
struct Script {
  std::string script;
  std::vector<std::size_t> made;
  TripMove operator()(std::size_t k) {
    made.push_back(k);
    TripMove m;
    const char c = k <= script.size() ? script[k - 1] : '.';
    m.reached = c == 'g';
    m.failed = c == 'x';
    m.stopped = c == 's';
    return m;
  }
};

TEST(Trip, ReachedFailedAndStoppedEndTheTripAtTheirMove) {
  Script a{"..g"};
  TripSummary t = runTrip(false, 10, std::ref(a));
  EXPECT_EQ(t.end, TripEnd::kReached);
  EXPECT_EQ(t.moves, 3u);
  EXPECT_EQ(a.made, (std::vector<std::size_t>{1, 2, 3}));

  Script b{".x.g"};
  t = runTrip(false, 10, std::ref(b));
  EXPECT_EQ(t.end, TripEnd::kFailed);
  EXPECT_EQ(t.moves, 2u);

  Script c{"..s"};  // a move that cannot be made is not counted
  t = runTrip(false, 10, std::ref(c));
  EXPECT_EQ(t.end, TripEnd::kStopped);
  EXPECT_EQ(t.moves, 2u);
}

TEST(Trip, TheStepLimitAllowsExactlyThatManyMoves) {
  Script a{"....g"};
  TripSummary t = runTrip(false, 4, std::ref(a));
  EXPECT_EQ(t.end, TripEnd::kStepLimit);
  EXPECT_EQ(t.moves, 4u);
  EXPECT_EQ(a.made.size(), 4u);
  Script b{"....g"};  // the limit's last move may still arrive
  t = runTrip(false, 5, std::ref(b));
  EXPECT_EQ(t.end, TripEnd::kReached);
  EXPECT_EQ(t.moves, 5u);
  Script c{"g"};
  t = runTrip(false, 0, std::ref(c));
  EXPECT_EQ(t.end, TripEnd::kStepLimit);
  EXPECT_TRUE(c.made.empty());
}

TEST(Trip, StartingAtTheGoalMakesNoMove) {
  Script a{"x"};
  const TripSummary t = runTrip(true, 10, std::ref(a));
  EXPECT_EQ(t.end, TripEnd::kReached);
  EXPECT_EQ(t.moves, 0u);
  EXPECT_TRUE(a.made.empty());
}

TEST(Trip, AnOutsideStopComesBeforeTheStepLimitAndTheNextMove) {
  Script a{"......"};
  int asked = 0;
  const TripSummary t = runTrip(false, 3, [&] { return ++asked == 3; }, std::ref(a));
  EXPECT_EQ(t.end, TripEnd::kStopped);
  EXPECT_EQ(t.moves, 2u);
  EXPECT_EQ(a.made.size(), 2u);
  // At the limit, a stop asked for wins: the robot reports the preemption, not the limit.
  Script b{"......"};
  int n = 0;
  const TripSummary u = runTrip(false, 2, [&] { return ++n == 3; }, std::ref(b));
  EXPECT_EQ(u.end, TripEnd::kStopped);
  EXPECT_EQ(u.moves, 2u);
  EXPECT_STREQ(toString(TripEnd::kStepLimit), "step_limit");
}

}  // namespace
}  // namespace mdp
}  // namespace krr
