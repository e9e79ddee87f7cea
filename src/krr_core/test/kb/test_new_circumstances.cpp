// "New circumstances": merging knowledge learned under different times of day through P-log.
//
// 1. On the 3 x 2 tiny geometry (test/data/kb/tiny_geometry.plog, cell 4 = ba1) the merged
//    model for "morning or noon" must be the mixture of the per-setting models, weighted by the
//    KB's prior over curr_time restricted to {morning, noon}, computed here by hand.
// 2. On a 9 x 5 map with a short route through a blocking area that walkers crowd at noon and
//    two longer free detours, the merged controller must beat the random-pick baseline.
#include <gtest/gtest.h>
#include <unistd.h>

#include <algorithm>

#include "krr_core/common/errors.h"
#include "krr_core/common/files.h"
#include "krr_core/kb/new_circumstances.h"

namespace {

using krr::kb::NavDomain;
using krr::kb::NavigationKnowledge;
using krr::mdp::StateId;

const std::string kData = KRR_TEST_DATA_DIR;
const std::string kNavPlog = kData + "/../../../../config/navigation.plog";
const std::string kGeometry = kData + "/kb/tiny_geometry.plog";
constexpr int kUp = 0, kRight = 3;

krr::nav::NavGrid tinyGrid() {
  krr::nav::OccupancyGrid map;
  map.width = 3;
  map.height = 2;
  map.resolution = 1.0;
  map.data.assign(6, krr::nav::kFree);
  krr::nav::PlacesFile places;
  places.places.push_back({"shop", {0.5, 0.5}, false, {}});
  places.places.push_back({"room1", {2.5, 1.5}, false, {}});
  places.areas.push_back({"ba1", {1.0, 1.0, 2.0, 2.0}});
  krr::nav::NavGridOptions opt;
  opt.cols = 3;
  opt.rows = 2;
  return krr::nav::NavGrid::fromMap(map, places, opt);
}

/// Known pair (cell, move) learned from outcome cells (-1 = trapped), one sample each.
krr::mdp::KnownPair pairOf(const NavigationKnowledge& kb, int cell, int move,
                           const std::vector<std::pair<int, int>>& outcome_counts) {
  const auto& sp = kb.space();
  krr::mdp::KnownPair kp;
  kp.state = sp.stateOf(cell);
  kp.action = static_cast<krr::mdp::ActionId>(move);
  std::uint32_t n = 0;
  for (const auto& oc : outcome_counts) n += static_cast<std::uint32_t>(oc.second);
  for (const auto& [c, k] : outcome_counts)
    kp.distribution.push_back({c < 0 ? sp.trappedState() : sp.stateOf(c), double(k) / n});
  std::sort(kp.distribution.begin(), kp.distribution.end(),
            [](const krr::mdp::Outcome& a, const krr::mdp::Outcome& b) { return a.state < b.state; });
  kp.samples = n;
  return kp;
}

double p(const krr::kb::NavModel& m, const NavigationKnowledge& kb, int cell, int move, int to) {
  const StateId s1 = to < 0 ? kb.space().trappedState() : kb.space().stateOf(to);
  return m.dynamics.getTransitionProbability(kb.space().stateOf(cell), move, s1);
}

TEST(NewCircumstances, MergedModelIsTheMixtureWeightedByThePriorOverTime) {
  NavigationKnowledge kb(tinyGrid(), {kGeometry, kNavPlog});
  // The KB's prior over the time of day (human knowledge): morning 1/2, noon 1/5, afternoon
  // 3/10. Given "morning or noon", the weights are 5/7 and 2/7.
  kb.reasoner().addStatements("pr(curr_time=morning) = 1/2.\npr(curr_time=noon) = 1/5.\n");
  const double wm = 0.5 / 0.7, wn = 0.2 / 0.7;
  // Learned: (3, right) in the morning: 4 x3, 3 x1, trapped x1; at noon: 4 x1, trapped x3.
  // (0, right) at noon only: 1 x4. (3, right) in the afternoon: trapped x2 (must not count).
  kb.addLearned({pairOf(kb, 3, kRight, {{4, 3}, {3, 1}, {-1, 1}})}, "morning");
  kb.addLearned({pairOf(kb, 3, kRight, {{4, 1}, {-1, 3}}), pairOf(kb, 0, kRight, {{1, 4}})}, "noon");
  kb.addLearned({pairOf(kb, 3, kRight, {{-1, 2}})}, "afternoon");

  const auto merged = kb.buildModel({"morning", "noon"});
  // By hand, from the learned frequencies.
  EXPECT_NEAR(p(merged, kb, 3, kRight, 4), wm * 3 / 5 + wn * 1 / 4, 1e-12);
  EXPECT_NEAR(p(merged, kb, 3, kRight, 3), wm * 1 / 5, 1e-12);
  EXPECT_NEAR(p(merged, kb, 3, kRight, -1), wm * 1 / 5 + wn * 3 / 4, 1e-12);
  EXPECT_NEAR(p(merged, kb, 3, kRight, 0), 0.0, 1e-12);
  // (0, right): human knowledge in the morning (1 gets 0.8; 0 and 3 share 0.2), learned at noon.
  EXPECT_NEAR(p(merged, kb, 0, kRight, 1), wm * 0.8 + wn * 1.0, 1e-12);
  EXPECT_NEAR(p(merged, kb, 0, kRight, 3), wm * 0.1, 1e-12);
  // (1, up) into ba1: human knowledge in both: walkers 0.3 (morning) / 0.5 (noon), a blocked
  // robot is trapped with 0.3.
  EXPECT_NEAR(p(merged, kb, 1, kUp, -1), wm * 0.3 * 0.3 + wn * 0.5 * 0.3, 1e-12);
  // Learned in both settings (3, right) counts as learned; (0, right) only at noon does not.
  EXPECT_TRUE(merged.learned[kb.space().stateOf(3) * 4 + kRight]);
  EXPECT_FALSE(merged.learned[kb.space().stateOf(0) * 4 + kRight]);

  // Every entry of the merged model is the same mixture of the per-setting models.
  const auto m = kb.buildModel({"morning"}), n = kb.buildModel({"noon"});
  const std::size_t S = kb.space().numStates();
  for (StateId s = 0; s + 1 < S; ++s)
    for (krr::mdp::ActionId a = 0; a < 4; ++a)
      for (StateId s1 = 0; s1 < S; ++s1)
        EXPECT_NEAR(merged.dynamics.getTransitionProbability(s, a, s1),
                    wm * m.dynamics.getTransitionProbability(s, a, s1) +
                        wn * n.dynamics.getTransitionProbability(s, a, s1),
                    1e-12)
            << "s " << s << " a " << a << " s1 " << s1;
}

// 9 x 5 map, walls on rows 1 and 3 except at both ends:
//   row 4: . . . D D D . . .
//   row 3: . # # # # # # # .
//   row 2: S . . B B B . . G      B: ba1, crowded at noon (x8)
//   row 1: . # # # # # # # .
//   row 0: . . . D D D . . .      D: ba2 / ba3, busier in the morning (x3) than at noon
NavDomain corridors() {
  krr::nav::OccupancyGrid map;
  map.width = 9;
  map.height = 5;
  map.resolution = 1.0;
  map.data.assign(45, krr::nav::kFree);
  for (int c = 1; c <= 7; ++c) {
    map.data[static_cast<size_t>(map.index(c, 1))] = krr::nav::kOccupied;
    map.data[static_cast<size_t>(map.index(c, 3))] = krr::nav::kOccupied;
  }
  krr::nav::PlacesFile places;
  places.places.push_back({"shop", {0.5, 2.5}, false, {}});
  places.places.push_back({"room1", {8.5, 2.5}, false, {}});
  places.areas.push_back({"ba1", {3.0, 2.0, 6.0, 3.0}});
  places.areas.push_back({"ba2", {3.0, 4.0, 6.0, 5.0}});
  places.areas.push_back({"ba3", {3.0, 0.0, 6.0, 1.0}});
  krr::nav::NavGridOptions opt;
  opt.cols = 9;
  opt.rows = 5;
  NavDomain d;
  d.domain.name = "corridors";
  d.domain.step_limit = 60;
  d.config.simulator.trap_reference_cell_size = 0;  // trap probability per blocked step as is
  d.config.simulator.trap_probability = 0.3;
  // With br 0.1: morning ba1 0.1, ba2/ba3 0.3; noon ba1 0.8, ba2/ba3 0.1.
  d.config.simulator.areas["ba1"].time_factor = {{"noon", 8.0}, {"afternoon", 8.0}};
  for (const char* a : {"ba2", "ba3"})
    d.config.simulator.areas[a].time_factor = {{"morning", 3.0}, {"afternoon", 3.0}};
  d.grid = std::make_shared<krr::nav::NavGrid>(krr::nav::NavGrid::fromMap(map, places, opt));
  d.space = std::make_shared<krr::kb::NavStateSpace>(*d.grid);
  d.simulator = std::make_shared<krr::nav::BlockageSimulator>(*d.grid, d.config.simulator);
  char tmpl[] = "/tmp/krr_newcirc_XXXXXX";
  const std::string geometry = std::string(::mkdtemp(tmpl)) + "/geometry.plog";
  krr::writeFileAtomic(geometry, d.grid->toPlog("corridors"));
  d.knowledge_files = {geometry, kNavPlog};
  return d;
}

krr::kb::NewCircumstancesOptions smallOptions() {
  krr::kb::NewCircumstancesOptions o;
  o.goal = "room1";
  o.learn_times = {"morning", "noon"};
  o.blocking_rate = 0.1;
  o.learn_episodes = 60;
  o.convergence_episodes = 15;
  o.rmax.known_threshold = 3;
  o.rmax.optimism = krr::mdp::Optimism::kSelfLoop;
  o.rmax.refine_known = true;
  return o;
}

TEST(NewCircumstances, MergedControllerBeatsTheRandomPickOfPerSettingControllers) {
  const NavDomain d = corridors();
  const auto o = smallOptions();
  const auto res = krr::kb::runNewCircumstances(d, o, 5, 0, 8, 2);
  ASSERT_EQ(res.size(), 8u);
  double merged = 0, baseline = 0;
  std::size_t differs = 0;
  std::string rows = krr::kb::newCircumstancesCsvHeader(o) + "\n";
  for (const auto& t : res) {
    rows += krr::kb::newCircumstancesCsvRow(t) + "\n";
    merged += t.expected_merged / res.size();
    baseline += t.expected_baseline / res.size();
    differs += t.differs_from[0];
    EXPECT_TRUE(t.setting == "morning" || t.setting == "noon");
    EXPECT_GT(t.learned_pairs[0], 0u);
  }
  // Morning: the short route; noon: a detour (ba1 at 0.8 is deadly). Not knowing the time,
  // the merged model takes a detour, fair in both settings (true success about 0.8); the
  // baseline takes the short route at noon a quarter of the time (about 0.65).
  EXPECT_GE(differs, 6u) << "the merged controller should leave the morning route\n" << rows;
  EXPECT_GT(merged, baseline + 0.1) << "merged " << merged << " baseline " << baseline << "\n"
                                     << rows;
  EXPECT_GT(merged, 0.7);
}

TEST(NewCircumstances, TrialsDependOnlyOnSeedAndIndex) {
  const NavDomain d = corridors();
  const auto o = smallOptions();
  const auto all = krr::kb::runNewCircumstances(d, o, 9, 0, 4, 1);
  const auto tail = krr::kb::runNewCircumstances(d, o, 9, 2, 2, 2);
  for (std::size_t i = 0; i < 2; ++i)
    EXPECT_EQ(krr::kb::newCircumstancesCsvRow(all[i + 2]), krr::kb::newCircumstancesCsvRow(tail[i]));
  EXPECT_EQ(all[2].index, 2u);
  // Column count of a row matches the header.
  const std::string h = krr::kb::newCircumstancesCsvHeader(o), r = krr::kb::newCircumstancesCsvRow(all[0]);
  EXPECT_EQ(std::count(h.begin(), h.end(), ','), std::count(r.begin(), r.end(), ','));
}

TEST(NewCircumstances, LeastKnownSelectorLearnsThroughProcedureOne) {
  const NavDomain d = corridors();
  auto o = smallOptions();
  o.selector = "least_known";
  o.places = {"room1"};
  o.learn_tasks = 2;
  o.learn_episodes = 20;
  NavigationKnowledge kb(*d.grid, d.knowledge_files);
  const auto t = krr::kb::runNewCircumstancesTrial(d, kb, o, 3, 0);
  ASSERT_EQ(t.learned_pairs.size(), 2u);
  EXPECT_GT(t.learned_pairs[0], 0u);
  EXPECT_GE(t.expected_merged, 0.0);
  EXPECT_LE(t.expected_merged, 1.0);
}

TEST(NewCircumstances, OptionsFileIsValidated) {
  char tmpl[] = "/tmp/krr_newcirc_opt_XXXXXX";
  const std::string dir = ::mkdtemp(tmpl);
  auto load = [&](const std::string& text) {
    krr::writeFileAtomic(dir + "/o.yaml", text);
    return krr::kb::loadNewCircumstancesOptions(dir + "/o.yaml");
  };
  auto o = load("goal: room5\nunknown_times: [noon, afternoon]\nrmax: {known_threshold: 7}\n"
                "plan: {discount: 1}\n");
  EXPECT_EQ(o.goal, "room5");
  EXPECT_EQ(o.unknown_times, (std::vector<std::string>{"noon", "afternoon"}));
  EXPECT_EQ(o.rmax.known_threshold, 7u);
  EXPECT_EQ(o.plan_discount, 1.0);
  auto expectError = [&](const std::string& text, const std::string& what) {
    try {
      load(text);
      ADD_FAILURE() << "no ConfigError for " << text;
    } catch (const krr::ConfigError& e) {
      EXPECT_NE(std::string(e.what()).find(what), std::string::npos) << e.what();
      EXPECT_NE(std::string(e.what()).find("o.yaml"), std::string::npos) << e.what();
    }
  };
  expectError("gaol: room5\n", "unknown field 'gaol'");
  expectError("unknown_times: [evening]\n", "unknown_times");
  expectError("learn_episodes: -3\n", "learn_episodes");
  expectError("rmax: {optimism: maybe}\n", "rmax.optimism");
  expectError("plan: {discount: 2}\n", "plan.discount");
  expectError("goal: shop\n", "same as start");
  expectError("selector: [a]\n", "selector");
  EXPECT_THROW(krr::kb::loadNewCircumstancesOptions(dir + "/missing.yaml"), krr::IoError);
}

}  // namespace
