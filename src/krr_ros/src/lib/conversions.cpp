#include "krr_ros/conversions.h"

#include <algorithm>
#include <cmath>
#include <cstdio>
#include <set>

#include "krr_core/common/errors.h"
#include "krr_core/nav/nav_grid.h"

namespace krr_ros {

namespace {

const char* const kMoves[4] = {"up", "down", "left", "right"};

geometry_msgs::Quaternion yawQuaternion(double yaw) {
  geometry_msgs::Quaternion q;
  q.w = std::cos(yaw / 2);
  q.z = std::sin(yaw / 2);
  return q;
}

std::string atomField(std::size_t i, const std::string& field) {
  return "atoms[" + std::to_string(i) + "]." + field;
}

/// @brief A move from `from` can end in `to`: the same cell or a connected 4-neighbour.
bool isNeighbourOrSelf(const krr::nav::NavGrid& grid, int from, int to) {
  if (from == to) return true;
  for (int m = 0; m < krr::nav::kNumMoves; ++m)
    if (grid.neighbour(from, m) == to) return true;
  return false;
}

/// @brief Walkers can trap the robot on a move from `cell`: a connected neighbour lies in a
/// blocking area (the simulator's dynamics and navigation.plog's risky/1 agree on this).
bool nearBlockingArea(const krr::nav::NavGrid& grid, int cell) {
  for (int m = 0; m < krr::nav::kNumMoves; ++m) {
    const int n = grid.neighbour(cell, m);
    if (n >= 0 && grid.areaMask(n) != 0) return true;
  }
  return false;
}

}  // namespace

int moveIndex(const std::string& name) {
  for (int m = 0; m < 4; ++m)
    if (name == kMoves[m]) return m;
  return -1;
}

nav_msgs::OccupancyGrid toMsg(const krr::nav::OccupancyGrid& map, const std::string& frame,
                              const ros::Time& stamp) {
  nav_msgs::OccupancyGrid msg;
  msg.header.frame_id = frame;
  msg.header.stamp = stamp;
  msg.info.map_load_time = stamp;
  msg.info.resolution = static_cast<float>(map.resolution);
  msg.info.width = static_cast<std::uint32_t>(map.width);
  msg.info.height = static_cast<std::uint32_t>(map.height);
  msg.info.origin.position.x = map.origin_x;
  msg.info.origin.position.y = map.origin_y;
  msg.info.origin.orientation = yawQuaternion(map.origin_yaw);
  msg.data.assign(map.data.begin(), map.data.end());
  return msg;
}

geometry_msgs::PoseStamped poseMsg(const krr::nav::Point2& p, double yaw,
                                   const std::string& frame, const ros::Time& stamp) {
  geometry_msgs::PoseStamped msg;
  msg.header.frame_id = frame;
  msg.header.stamp = stamp;
  msg.pose.position.x = p.x;
  msg.pose.position.y = p.y;
  msg.pose.orientation = yawQuaternion(yaw);
  return msg;
}

nav_msgs::Path pathMsg(const std::vector<krr::nav::Point2>& points, const std::string& frame,
                       const ros::Time& stamp) {
  nav_msgs::Path path;
  path.header.frame_id = frame;
  path.header.stamp = stamp;
  double yaw = 0;
  for (std::size_t i = 0; i < points.size(); ++i) {
    if (i + 1 < points.size())
      yaw = std::atan2(points[i + 1].y - points[i].y, points[i + 1].x - points[i].x);
    path.poses.push_back(poseMsg(points[i], yaw, frame, stamp));
  }
  return path;
}

visualization_msgs::MarkerArray areaMarkers(const krr::nav::BlockageSimulator& sim,
                                            const krr::nav::Context& context,
                                            const std::string& frame, const ros::Time& stamp) {
  visualization_msgs::MarkerArray out;
  const krr::nav::NavGrid& grid = sim.grid();
  auto base = [&](const std::string& ns, int id, int type) {
    visualization_msgs::Marker m;
    m.header.frame_id = frame;
    m.header.stamp = stamp;
    m.ns = ns;
    m.id = id;
    m.type = type;
    m.action = visualization_msgs::Marker::ADD;
    m.pose.orientation.w = 1.0;
    m.frame_locked = true;
    return m;
  };
  // A white text 0.5 m above `at`, the same for areas and places.
  auto label = [&](const std::string& ns, std::size_t id, const geometry_msgs::Point& at,
                   const std::string& text) {
    auto m = base(ns, static_cast<int>(id), visualization_msgs::Marker::TEXT_VIEW_FACING);
    m.pose.position = at;
    m.pose.position.z = 0.5;
    m.scale.z = 0.4;
    m.color.r = m.color.g = m.color.b = m.color.a = 1.0f;
    m.text = text;
    out.markers.push_back(m);
  };
  for (std::size_t a = 0; a < grid.areas().size(); ++a) {
    const krr::nav::BlockingArea& ba = grid.areas()[a];
    const auto& cells = grid.areaCells(static_cast<int>(a));
    const double rate = cells.empty() ? 0.0 : sim.blockingRate(cells.front(), context);
    auto box = base("blocking_areas", static_cast<int>(a), visualization_msgs::Marker::CUBE);
    box.pose.position.x = (ba.rect.x0 + ba.rect.x1) / 2;
    box.pose.position.y = (ba.rect.y0 + ba.rect.y1) / 2;
    box.pose.position.z = 0.025;
    box.scale.x = ba.rect.x1 - ba.rect.x0;
    box.scale.y = ba.rect.y1 - ba.rect.y0;
    box.scale.z = 0.05;
    box.color.r = 1.0f;
    box.color.g = static_cast<float>(1.0 - rate);
    box.color.a = static_cast<float>(0.3 + 0.5 * rate);
    out.markers.push_back(box);
    char text[64];
    std::snprintf(text, sizeof text, "%s (br %.2f)", ba.name.c_str(), rate);
    label("blocking_area_labels", a, box.pose.position, text);
  }
  for (std::size_t p = 0; p < grid.places().size(); ++p) {
    const krr::nav::Place& place = grid.places()[p];
    auto disc = base("places", static_cast<int>(p), visualization_msgs::Marker::CYLINDER);
    disc.pose.position.x = place.point.x;
    disc.pose.position.y = place.point.y;
    disc.pose.position.z = 0.05;
    disc.scale.x = disc.scale.y = 0.4;
    disc.scale.z = 0.1;
    disc.color.b = 1.0f;
    disc.color.g = 0.6f;
    disc.color.a = 0.8f;
    out.markers.push_back(disc);
    label("place_labels", p, disc.pose.position, place.name);
  }
  return out;
}

std::vector<krr_msgs::LearnedAtom> toAtoms(
    const std::vector<krr::kb::NavigationKnowledge::LearnedEntry>& entries) {
  std::vector<krr_msgs::LearnedAtom> atoms;
  atoms.reserve(entries.size());
  for (const auto& e : entries) {
    krr_msgs::LearnedAtom a;
    a.cell = e.cell;
    a.move = (e.move >= 0 && e.move < 4) ? kMoves[e.move] : "";
    a.time = e.time;
    for (const auto& [value, k] : e.outcomes) {
      a.outcomes.push_back(value);
      a.counts.push_back(k);
    }
    a.samples = e.denominator;
    atoms.push_back(std::move(a));
  }
  return atoms;
}

std::map<std::string, std::vector<krr::mdp::KnownPair>> toKnownPairs(
    const std::vector<krr_msgs::LearnedAtom>& atoms, const krr::kb::NavStateSpace& space,
    const std::vector<std::string>& times) {
  std::map<std::string, std::vector<krr::mdp::KnownPair>> out;
  std::set<std::tuple<int, int, std::string>> seen;
  for (std::size_t i = 0; i < atoms.size(); ++i) {
    const krr_msgs::LearnedAtom& a = atoms[i];
    const int move = moveIndex(a.move);
    if (move < 0)
      throw krr::ConfigError(atomField(i, "move") + ": '" + a.move +
                             "' is not up, down, left or right");
    if (std::find(times.begin(), times.end(), a.time) == times.end())
      throw krr::UnknownSymbolError(atomField(i, "time") + ": '" + a.time +
                                    "' is not a value of sort time");
    krr::mdp::KnownPair kp;
    try {
      kp.state = space.stateOf(a.cell);
    } catch (const krr::Error& e) {
      throw krr::UnknownSymbolError(atomField(i, "cell") + ": " + e.what());
    }
    if (!seen.insert(std::make_tuple(a.cell, move, a.time)).second)
      throw krr::ConfigError("atoms[" + std::to_string(i) + "]: a second atom for cell " +
                             std::to_string(a.cell) + ", move " + a.move + ", time " + a.time);
    kp.action = static_cast<krr::mdp::ActionId>(move);
    if (a.outcomes.empty() || a.outcomes.size() != a.counts.size())
      throw krr::ConfigError(atomField(i, "outcomes") + ": " + std::to_string(a.outcomes.size()) +
                             " outcomes but " + std::to_string(a.counts.size()) +
                             " counts (need the same number, at least one)");
    if (a.samples <= 0 || a.samples > 1000000000L)
      throw krr::ConfigError(atomField(i, "samples") + ": " + std::to_string(a.samples) +
                             " is not in [1, 1e9]");
    long sum = 0;
    std::set<krr::mdp::StateId> outcome_states;
    for (std::size_t k = 0; k < a.outcomes.size(); ++k) {
      // Bounded by samples (<= 1e9) before summing: counts near INT64_MAX cannot overflow.
      if (a.counts[k] <= 0 || a.counts[k] > a.samples)
        throw krr::ConfigError(atomField(i, "counts[" + std::to_string(k) + "]") + ": " +
                               std::to_string(a.counts[k]) + " is not in [1, samples = " +
                               std::to_string(a.samples) + "]");
      krr::mdp::StateId s1;
      const std::string field = atomField(i, "outcomes[" + std::to_string(k) + "]");
      if (a.outcomes[k] == "trapped") {
        if (!nearBlockingArea(space.grid(), a.cell))
          throw krr::ConfigError(field + ": 'trapped' is impossible from cell " +
                                 std::to_string(a.cell) + " (no neighbour in a blocking area)");
        s1 = space.trappedState();
      } else {
        std::size_t used = 0;
        int cell = -1;
        try {
          cell = std::stoi(a.outcomes[k], &used);
        } catch (const std::exception&) {
          used = 0;
        }
        if (used == 0 || used != a.outcomes[k].size())
          throw krr::ConfigError(field + ": '" + a.outcomes[k] +
                                 "' is neither a cell id nor 'trapped'");
        try {
          s1 = space.stateOf(cell);
        } catch (const krr::Error& e) {
          throw krr::UnknownSymbolError(field + ": " + e.what());
        }
        if (!isNeighbourOrSelf(space.grid(), a.cell, cell))
          throw krr::ConfigError(field + ": cell " + a.outcomes[k] + " is neither cell " +
                                 std::to_string(a.cell) + " nor one of its neighbours");
      }
      if (!outcome_states.insert(s1).second)
        throw krr::ConfigError(atomField(i, "outcomes") + ": '" + a.outcomes[k] +
                               "' appears twice");
      sum += a.counts[k];
      kp.distribution.push_back({s1, static_cast<double>(a.counts[k]) /
                                         static_cast<double>(a.samples)});
    }
    if (sum != a.samples)
      throw krr::ConfigError(atomField(i, "counts") + ": they sum to " + std::to_string(sum) +
                             ", not to samples = " + std::to_string(a.samples));
    kp.samples = static_cast<std::uint32_t>(a.samples);
    out[a.time].push_back(std::move(kp));
  }
  return out;
}

void fillNavigationModel(const krr::kb::NavModel& model, const krr::kb::NavStateSpace& space,
                         krr_msgs::BuildTaskModel::Response* res) {
  const krr::mdp::SparseModel& m = model.dynamics;
  res->num_states = static_cast<std::uint32_t>(m.getS());
  res->num_actions = static_cast<std::uint32_t>(m.getA());
  res->state_cells.resize(m.getS());
  for (std::size_t s = 0; s < m.getS(); ++s)
    res->state_cells[s] = space.cellOf(static_cast<krr::mdp::StateId>(s));
  const std::size_t rows = m.getS() * m.getA();
  res->row_offsets.assign(m.rowStart(), m.rowStart() + rows + 1);
  res->next_states.assign(m.nextStates(), m.nextStates() + m.numTransitions());
  res->probabilities.assign(m.probabilities(), m.probabilities() + m.numTransitions());
  res->learned.assign(model.learned.begin(), model.learned.end());
  res->learned.resize(rows, 0);
  res->num_learned = static_cast<std::uint32_t>(model.numLearned());
  res->discount_used = m.getDiscount();
}

krr::mdp::SparseModel navigationModelFromMsg(const krr_msgs::BuildTaskModel::Response& res,
                                             const krr::kb::NavStateSpace& space) {
  const std::size_t S = space.numStates(), A = space.numActions();
  if (res.num_states != S || res.num_actions != A || res.state_cells.size() != S)
    throw krr::ConfigError("navigation model: " + std::to_string(res.num_states) + " states x " +
                           std::to_string(res.num_actions) + " actions, expected " +
                           std::to_string(S) + " x " + std::to_string(A) +
                           " (reasoner built for another grid?)");
  for (std::size_t s = 0; s < S; ++s)
    if (res.state_cells[s] != space.cellOf(static_cast<krr::mdp::StateId>(s)))
      throw krr::ConfigError("navigation model: state " + std::to_string(s) + " is cell " +
                             std::to_string(res.state_cells[s]) + ", expected cell " +
                             std::to_string(space.cellOf(static_cast<krr::mdp::StateId>(s))));
  if (res.row_offsets.size() != S * A + 1 || res.next_states.size() != res.probabilities.size() ||
      res.row_offsets.back() != res.next_states.size())
    throw krr::ConfigError("navigation model: malformed rows (" +
                           std::to_string(res.row_offsets.size()) + " offsets, " +
                           std::to_string(res.next_states.size()) + " next states, " +
                           std::to_string(res.probabilities.size()) + " probabilities)");
  std::vector<std::uint8_t> terminal(S, 0);
  terminal[space.trappedState()] = 1;
  const double discount = res.discount_used > 0 ? res.discount_used : 0.95;
  // The SparseModel constructor validates offsets, indices, ranges and row sums.
  return krr::mdp::SparseModel(S, A, discount, res.row_offsets, res.next_states, res.probabilities,
                               std::vector<double>(S * A, 0.0), terminal);
}

}  // namespace krr_ros
