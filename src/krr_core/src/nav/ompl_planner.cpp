#include "krr_core/nav/ompl_planner.h"

#include <ompl/base/PlannerTerminationCondition.h>
#include <ompl/base/spaces/RealVectorStateSpace.h>
#include <ompl/geometric/PathGeometric.h>
#include <ompl/geometric/PathSimplifier.h>
#include <ompl/geometric/SimpleSetup.h>
#include <ompl/geometric/planners/prm/PRM.h>
#include <ompl/geometric/planners/rrt/RRTConnect.h>
#include <ompl/util/Console.h>
#include <ompl/util/RandomNumbers.h>

#include <algorithm>
#include <atomic>
#include <cmath>
#include <mutex>
#include <sstream>

#include "krr_core/common/errors.h"
#include "krr_core/common/random.h"

namespace ob = ompl::base;
namespace og = ompl::geometric;

namespace krr {
namespace nav {

namespace {

std::mutex g_seed_mutex;
bool g_seeded = false;
std::uint64_t g_root_seed = 0;
std::atomic<bool> g_planner_created{false};

std::string pt(const Point2& p) {
  std::ostringstream o;
  o.precision(6);
  o << "(" << p.x << ", " << p.y << ")";
  return o.str();
}

}  // namespace

bool seedOmpl(std::uint64_t root_seed) {
  std::lock_guard<std::mutex> lock(g_seed_mutex);
  if (g_seeded) {
    if (root_seed != g_root_seed) {
      throw ConfigError("seedOmpl: OMPL was already seeded from root seed " +
                        std::to_string(g_root_seed) + "; it cannot be reseeded with " +
                        std::to_string(root_seed) + " in the same process");
    }
    return false;
  }
  if (g_planner_created) {
    throw ConfigError("seedOmpl: an OMPL planner already exists, so OMPL's generators are "
                      "already seeded; call seedOmpl before creating any planner");
  }
  ompl::msg::setLogLevel(ompl::msg::LOG_NONE);
  std::uint32_t s = static_cast<std::uint32_t>(deriveSeed(root_seed, "ompl") & 0x7fffffffu);
  if (s == 0) s = 1;  // OMPL rejects seed 0
  ompl::RNG::setSeed(s);
  g_seeded = true;
  g_root_seed = root_seed;
  return true;
}

struct OmplPlanner::Impl {
  OccupancyGrid map;
  double radius_check = 0.0;  // robot radius + half the motion-checking spacing (metres)
  double half_diag = 0.0;     // half a pixel diagonal (metres)
  std::vector<float> dist;    // per pixel: distance from its centre to the nearest non-free pixel
  int window = 0;             // pixels scanned around a state in the exact check
  double cos_yaw = 1.0, sin_yaw = 0.0, inv_res = 1.0;
  double radius_px2 = 0.0;    // (radius_check / resolution)^2
  std::shared_ptr<ob::RealVectorStateSpace> space;
  std::unique_ptr<og::SimpleSetup> ss;
  std::unique_ptr<og::PathSimplifier> simplifier;
  bool prm = false;

  bool blockedPixel(int i, int j) const { return map.at(i, j) != kFree; }

  // Exact distance (pixels) from map point (u,v) to the square of pixel (i,j).
  static double squareDist(double u, double v, int i, int j) {
    const double dx = u < i ? i - u : (u > i + 1 ? u - (i + 1) : 0.0);
    const double dy = v < j ? j - v : (v > j + 1 ? v - (j + 1) : 0.0);
    return std::sqrt(dx * dx + dy * dy);
  }

  // Exact clearance (pixels) of map point (u,v), capped at `cap` pixels.
  double exactClearancePx(double u, double v, int cap) const {
    const int ci = static_cast<int>(std::floor(u)), cj = static_cast<int>(std::floor(v));
    double best = cap;
    for (int j = cj - cap; j <= cj + cap; ++j) {
      for (int i = ci - cap; i <= ci + cap; ++i) {
        if (blockedPixel(i, j)) best = std::min(best, squareDist(u, v, i, j));
      }
    }
    return best;
  }

  // True iff some non-free pixel's square is closer than radius_check to map point (u,v).
  bool obstacleWithin(double u, double v) const {
    const int ci = static_cast<int>(u), cj = static_cast<int>(v);
    for (int j = cj - window; j <= cj + window; ++j) {
      const double dy = v < j ? j - v : (v > j + 1 ? v - (j + 1) : 0.0);
      if (dy * dy >= radius_px2) continue;
      for (int i = ci - window; i <= ci + window; ++i) {
        const double dx = u < i ? i - u : (u > i + 1 ? u - (i + 1) : 0.0);
        if (dx * dx + dy * dy < radius_px2 && blockedPixel(i, j)) return true;
      }
    }
    return false;
  }

  bool valid(double x, double y) const {
    const double dx = x - map.origin_x, dy = y - map.origin_y;
    const double u = (cos_yaw * dx + sin_yaw * dy) * inv_res;
    const double v = (-sin_yaw * dx + cos_yaw * dy) * inv_res;
    if (!(u >= 0.0 && v >= 0.0 && u < map.width && v < map.height)) return false;
    const int i = static_cast<int>(u), j = static_cast<int>(v);
    const double d = dist[static_cast<size_t>(map.index(i, j))];
    if (d - half_diag >= radius_check) return true;
    if (d + half_diag < radius_check) return false;
    return !obstacleWithin(u, v);
  }
};

OmplPlanner::OmplPlanner(const OccupancyGrid& map, const PlannerConfig& config,
                         std::uint64_t root_seed)
    : impl_(new Impl), config_(config) {
  if (!(config_.robot_radius >= 0.0) || !std::isfinite(config_.robot_radius)) {
    throw ConfigError("OMPL planner: field 'robot_radius': value " +
                      std::to_string(config_.robot_radius) + " must be >= 0");
  }
  if (!(config_.timeout > 0.0)) {
    throw ConfigError("OMPL planner: field 'timeout': value " + std::to_string(config_.timeout) +
                      " must be > 0");
  }
  if (!(config_.interpolation_step > 0.0)) {
    throw ConfigError("OMPL planner: field 'interpolation_step': value " +
                      std::to_string(config_.interpolation_step) + " must be > 0");
  }
  if (config_.algorithm != "rrtconnect" && config_.algorithm != "prm") {
    throw ConfigError("OMPL planner: field 'algorithm': unknown value '" + config_.algorithm + "'");
  }
  if (map.width <= 0 || map.height <= 0 || !(map.resolution > 0.0)) {
    throw MapError("OMPL planner: empty map");
  }
  seedOmpl(root_seed);
  g_planner_created = true;
  Impl& m = *impl_;
  m.map = map;
  const double res = map.resolution;
  const double check_step = res / 4.0;
  m.radius_check = config_.robot_radius + 0.5 * check_step;
  m.half_diag = res * std::sqrt(0.5);
  m.window = static_cast<int>(std::ceil(m.radius_check / res)) + 2;
  m.cos_yaw = std::cos(map.origin_yaw);
  m.sin_yaw = std::sin(map.origin_yaw);
  m.inv_res = 1.0 / res;
  m.radius_px2 = (m.radius_check / res) * (m.radius_check / res);
  // Distance transform by brute force over a window: exact up to `window` pixels, capped there.
  m.dist.assign(map.data.size(), static_cast<float>(m.window * res));
  for (int j = 0; j < map.height; ++j) {
    for (int i = 0; i < map.width; ++i) {
      m.dist[static_cast<size_t>(map.index(i, j))] =
          static_cast<float>(m.exactClearancePx(i + 0.5, j + 0.5, m.window) * res);
    }
  }
  // Bounds: bounding box of the (possibly rotated) map.
  double xs[4], ys[4];
  const double corners[4][2] = {{0, 0}, {1.0 * map.width, 0}, {0, 1.0 * map.height},
                                {1.0 * map.width, 1.0 * map.height}};
  for (int k = 0; k < 4; ++k) {
    Point2 p = map.mapToWorld(corners[k][0], corners[k][1]);
    xs[k] = p.x;
    ys[k] = p.y;
  }
  m.space = std::make_shared<ob::RealVectorStateSpace>(2);
  ob::RealVectorBounds bounds(2);
  bounds.setLow(0, *std::min_element(xs, xs + 4));
  bounds.setHigh(0, *std::max_element(xs, xs + 4));
  bounds.setLow(1, *std::min_element(ys, ys + 4));
  bounds.setHigh(1, *std::max_element(ys, ys + 4));
  m.space->setBounds(bounds);
  m.space->setLongestValidSegmentFraction(check_step / m.space->getMaximumExtent());
  m.ss.reset(new og::SimpleSetup(m.space));
  Impl* ip = impl_.get();
  m.ss->setStateValidityChecker([ip](const ob::State* s) {
    const auto* rv = s->as<ob::RealVectorStateSpace::StateType>();
    return ip->valid(rv->values[0], rv->values[1]);
  });
  ob::SpaceInformationPtr si = m.ss->getSpaceInformation();
  m.prm = config_.algorithm == "prm";
  if (m.prm) {
    m.ss->setPlanner(std::make_shared<og::PRM>(si));
  } else {
    auto rrt = std::make_shared<og::RRTConnect>(si);
    if (config_.range > 0.0) rrt->setRange(config_.range);
    m.ss->setPlanner(rrt);
  }
  m.ss->setup();
  m.simplifier.reset(new og::PathSimplifier(si));
}

OmplPlanner::~OmplPlanner() = default;

bool OmplPlanner::isValid(const Point2& p) const { return impl_->valid(p.x, p.y); }

double OmplPlanner::clearance(const Point2& p) const {
  double u = 0.0, v = 0.0;
  impl_->map.worldToMap(p, &u, &v);
  const int cap = std::max(impl_->map.width, impl_->map.height);
  // Scan outward in growing windows: cheap when an obstacle is near.
  for (int w = 4;; w *= 2) {
    const double d = impl_->exactClearancePx(u, v, std::min(w, cap + 2));
    if (d < w || w > cap + 2) return d * impl_->map.resolution;
  }
}

bool OmplPlanner::cellAnchor(const NavGrid& grid, int cell, Point2* out) const {
  if (!grid.valid(cell)) return false;
  const Point2 c = grid.cellCentre(cell);
  if (isValid(c)) {
    *out = c;
    return true;
  }
  // Candidate points on a res/2 lattice inside the cell, nearest to the centre first.
  const double step = impl_->map.resolution * 0.5;
  const int nx = std::max(1, static_cast<int>(grid.cellWidth() / step));
  const int ny = std::max(1, static_cast<int>(grid.cellHeight() / step));
  double best = 1e300;
  bool found = false;
  for (int b = 0; b < ny; ++b) {
    for (int a = 0; a < nx; ++a) {
      const double dx = (a + 0.5) * grid.cellWidth() / nx - 0.5 * grid.cellWidth();
      const double dy = (b + 0.5) * grid.cellHeight() / ny - 0.5 * grid.cellHeight();
      const double d2 = dx * dx + dy * dy;
      if (d2 >= best) continue;
      // The cell centre offset is along the grid axes (grid yaw = map yaw).
      const double yaw = impl_->map.origin_yaw;
      const Point2 p{c.x + std::cos(yaw) * dx - std::sin(yaw) * dy,
                     c.y + std::sin(yaw) * dx + std::cos(yaw) * dy};
      if (isValid(p)) {
        best = d2;
        *out = p;
        found = true;
      }
    }
  }
  return found;
}

std::vector<Point2> OmplPlanner::plan(const Point2& start, const Point2& goal, double timeout) {
  Impl& m = *impl_;
  if (!m.valid(start.x, start.y)) {
    throw NoPathError("OMPL planner: invalid start state " + pt(start) +
                      ": outside the map or closer than robot_radius " +
                      std::to_string(config_.robot_radius) + " m to an occupied/unknown cell");
  }
  if (!m.valid(goal.x, goal.y)) {
    throw NoPathError("OMPL planner: invalid goal state " + pt(goal) +
                      ": outside the map or closer than robot_radius " +
                      std::to_string(config_.robot_radius) + " m to an occupied/unknown cell");
  }
  ob::SpaceInformationPtr si = m.ss->getSpaceInformation();
  ob::ScopedState<ob::RealVectorStateSpace> s(m.space), g(m.space);
  s[0] = start.x;
  s[1] = start.y;
  g[0] = goal.x;
  g[1] = goal.y;
  og::PathGeometric path(si);
  if (si->checkMotion(s.get(), g.get())) {
    path.append(s.get());
    path.append(g.get());
  } else {
    ++planner_calls_;
    if (m.prm) {
      m.ss->getPlanner()->as<og::PRM>()->clearQuery();
      m.ss->getProblemDefinition()->clearSolutionPaths();
    } else {
      m.ss->clear();
    }
    m.ss->setStartAndGoalStates(s, g);
    const double t = timeout > 0.0 ? timeout : config_.timeout;
    ob::PlannerTerminationCondition ptc = ob::plannerOrTerminationCondition(
        ob::timedPlannerTerminationCondition(t),
        ob::exactSolnPlannerTerminationCondition(m.ss->getProblemDefinition()));
    ob::PlannerStatus status = m.ss->solve(ptc);
    if (status != ob::PlannerStatus::EXACT_SOLUTION) {
      throw NoPathError("OMPL planner: no path from " + pt(start) + " to " + pt(goal) +
                        " found within " + std::to_string(t) + " s (goal unreachable for a robot "
                        "of radius " + std::to_string(config_.robot_radius) + " m?)");
    }
    path = m.ss->getSolutionPath();
    if (config_.simplify) {
      m.simplifier->reduceVertices(path);
      m.simplifier->shortcutPath(path);
      m.simplifier->reduceVertices(path);
    }
  }
  // Interpolate each segment separately so that no step exceeds interpolation_step.
  std::vector<Point2> out;
  for (size_t k = 0; k < path.getStateCount(); ++k) {
    const auto* rv = path.getState(k)->as<ob::RealVectorStateSpace::StateType>();
    const Point2 q{rv->values[0], rv->values[1]};
    if (!out.empty()) {
      const Point2 p = out.back();
      const double len = std::hypot(q.x - p.x, q.y - p.y);
      const int n = static_cast<int>(std::ceil(len / config_.interpolation_step));
      for (int i = 1; i < n; ++i) {
        const double t = static_cast<double>(i) / n;
        out.push_back(Point2{p.x + t * (q.x - p.x), p.y + t * (q.y - p.y)});
      }
    }
    out.push_back(q);
  }
  return out;
}

std::vector<Point2> OmplPlanner::planCellMove(const NavGrid& grid, int from_cell, int to_cell,
                                              double timeout) {
  Point2 a, b;
  if (!cellAnchor(grid, from_cell, &a)) {
    throw NoPathError("OMPL planner: invalid start state: cell " + std::to_string(from_cell) +
                      " has no point where the robot fits");
  }
  if (!cellAnchor(grid, to_cell, &b)) {
    throw NoPathError("OMPL planner: invalid goal state: cell " + std::to_string(to_cell) +
                      " has no point where the robot fits");
  }
  return plan(a, b, timeout);
}

std::vector<Point2> OmplPlanner::planRoute(const NavGrid& grid, const std::string& from,
                                           const std::string& to, double timeout) {
  const Point2 a = grid.places()[static_cast<size_t>(grid.placeIndex(from))].point;
  const Point2 b = grid.places()[static_cast<size_t>(grid.placeIndex(to))].point;
  return plan(a, b, timeout);
}

}  // namespace nav
}  // namespace krr
