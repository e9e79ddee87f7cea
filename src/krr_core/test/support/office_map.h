/**
 * @file office_map.h
 * @brief The drawing of the bundled office site's map (the paper's Figure 3), kept with the
 * tests: nav_test_office_map checks that the committed maps/office.pgm and office_places.yaml are
 * exactly this drawing, and rewrites them when KRR_WRITE_OFFICE_MAP=1 (maps/README.md). The
 * office is data of its site; no program of the stack draws it.
 *
 * 15 m x 15 m at 0.05 m/px. Layout (metres): a corridor ring x,y in [3,12] (1.5 m wide) around
 * room3 (top half of the centre) and a closed lab; west of the ring, from south to north, room1,
 * the shop and room4; room2 south of the ring; room5 east of it. Blocking areas: BA1 on the
 * south corridor (3 m, between the shop and room2), BA2 on the east corridor south of room5's
 * door (1.5 m), BA3 on the north corridor (1.5 m, before room3's door) and BA4 on the east
 * corridor north of room5's door (3 m). Hence room1 and room4 are reached without crossing a BA,
 * room3 crosses BA3, room2 crosses BA1 (or detours through three BAs) and room5 crosses two BAs
 * (BA1+BA2 or BA3+BA4, 4.5 m of blocking area either way). Unvisited rooms are unknown space,
 * as in a map built by a real robot.
 */
#pragma once

#include <algorithm>
#include <cmath>
#include <cstdint>
#include <utility>
#include <vector>

#include "krr_core/nav/nav_grid.h"
#include "krr_core/nav/occupancy_grid.h"

namespace krr_test {

/// @brief The drawn office: the occupancy grid plus its places and blocking areas.
struct OfficeMap {
  krr::nav::OccupancyGrid grid;
  krr::nav::PlacesFile places;
};

namespace office_map_detail {

using krr::nav::BlockingArea;
using krr::nav::kFree;
using krr::nav::kOccupied;
using krr::nav::kUnknown;
using krr::nav::OccupancyGrid;
using krr::nav::Place;
using krr::nav::PlacesFile;
using krr::nav::Point2;
using krr::nav::Rect;

inline constexpr double kRes = 0.05;   // m/px
inline constexpr int kSize = 300;      // 15 m

inline int px(double metres) { return static_cast<int>(std::lround(metres / kRes)); }

inline void fill(OccupancyGrid& g, double x0, double y0, double x1, double y1, std::int8_t v) {
  for (int j = std::max(0, px(y0)); j < std::min(g.height, px(y1)); ++j) {
    for (int i = std::max(0, px(x0)); i < std::min(g.width, px(x1)); ++i) {
      g.data[static_cast<size_t>(g.index(i, j))] = v;
    }
  }
}

using Gaps = std::vector<std::pair<double, double>>;

inline bool inGap(int k, const Gaps& gaps) {
  for (const auto& d : gaps) {
    if (k >= px(d.first) && k < px(d.second)) return true;
  }
  return false;
}

/// 2-px wall centred on the vertical line x from y0 to y1, with door gaps [d0, d1).
inline void wallV(OccupancyGrid& g, double x, double y0, double y1, const Gaps& doors = {}) {
  for (int j = px(y0) - 1; j < px(y1) + 1; ++j) {
    if (inGap(j, doors)) continue;
    for (int i = px(x) - 1; i <= px(x); ++i) {
      if (g.inBounds(i, j)) g.data[static_cast<size_t>(g.index(i, j))] = kOccupied;
    }
  }
}

/// 2-px wall centred on the horizontal line y from x0 to x1, with door gaps [d0, d1).
inline void wallH(OccupancyGrid& g, double y, double x0, double x1, const Gaps& doors = {}) {
  for (int i = px(x0) - 1; i < px(x1) + 1; ++i) {
    if (inGap(i, doors)) continue;
    for (int j = px(y) - 1; j <= px(y); ++j) {
      if (g.inBounds(i, j)) g.data[static_cast<size_t>(g.index(i, j))] = kOccupied;
    }
  }
}

inline Place place(const char* name, double x, double y, Rect room) {
  Place p;
  p.name = name;
  p.point = Point2{x, y};
  p.has_room = true;
  p.room = room;
  return p;
}

}  // namespace office_map_detail

/// @brief Draw the office map deterministically (no randomness, no files).
inline OfficeMap makeOfficeMap() {
  using namespace office_map_detail;
  OfficeMap m;
  OccupancyGrid& g = m.grid;
  g.width = kSize;
  g.height = kSize;
  g.resolution = kRes;
  g.data.assign(static_cast<size_t>(kSize) * kSize, kUnknown);

  // Free space: the corridor ring and the six rooms the robot has mapped.
  fill(g, 3.0, 3.0, 4.5, 12.0, kFree);     // west corridor
  fill(g, 3.0, 3.0, 12.0, 4.5, kFree);     // south corridor
  fill(g, 3.0, 10.5, 12.0, 12.0, kFree);   // north corridor
  fill(g, 10.5, 3.0, 12.0, 12.0, kFree);   // east corridor
  const Rect room1{0.0, 1.5, 3.0, 6.0}, shop{0.0, 6.0, 3.0, 9.0}, room4{0.0, 9.0, 3.0, 13.5};
  const Rect room2{6.0, 0.0, 10.5, 3.0}, room3{4.5, 7.5, 10.5, 10.5}, room5{12.0, 4.5, 15.0, 9.0};
  for (const Rect& r : {room1, shop, room4, room2, room3, room5}) fill(g, r.x0, r.y0, r.x1, r.y1, kFree);

  // Walls between rooms and corridors, with doors (gaps chosen so no cell centre of the 30x30
  // or 50x50 domain lies on a door edge).
  wallV(g, 3.0, 1.5, 13.5, {{4.1, 5.5}, {6.55, 8.45}, {9.6, 11.0}});  // room1, shop, room4 doors
  wallH(g, 6.0, 0.0, 3.0);                 // room1 | shop
  wallH(g, 9.0, 0.0, 3.0);                 // shop | room4
  wallH(g, 3.0, 6.0, 10.5, {{7.55, 8.95}});    // room2 door
  wallH(g, 10.5, 4.5, 10.5, {{6.6, 8.4}});    // room3 door
  wallV(g, 4.5, 7.5, 10.5);                // room3 | west corridor
  wallV(g, 10.5, 7.5, 10.5);               // room3 | east corridor
  wallV(g, 12.0, 4.5, 9.0, {{6.05, 7.45}});    // room5 door

  // Furniture (desks, the shop counter), away from doors and place points.
  fill(g, 0.3, 1.8, 1.3, 2.4, kOccupied);     // room1 desk
  fill(g, 0.3, 6.6, 0.7, 8.4, kOccupied);     // shop counter
  fill(g, 0.3, 12.6, 1.3, 13.2, kOccupied);   // room4 desk
  fill(g, 9.2, 0.3, 10.2, 0.9, kOccupied);    // room2 desk
  fill(g, 9.0, 8.0, 10.0, 9.0, kOccupied);    // room3 table
  fill(g, 13.8, 7.9, 14.6, 8.6, kOccupied);   // room5 desk

  // Outer walls: the 2-px border, and unknown space within 2 px of free space.
  for (int j = 0; j < kSize; ++j) {
    for (int i = 0; i < kSize; ++i) {
      if ((i < 2 || j < 2 || i >= kSize - 2 || j >= kSize - 2) &&
          g.data[static_cast<size_t>(g.index(i, j))] == kFree) {
        g.data[static_cast<size_t>(g.index(i, j))] = kOccupied;
      }
    }
  }
  std::vector<std::int8_t> snapshot = g.data;
  for (int j = 0; j < kSize; ++j) {
    for (int i = 0; i < kSize; ++i) {
      if (snapshot[static_cast<size_t>(g.index(i, j))] != kUnknown) continue;
      bool near_free = false;
      for (int dj = -2; dj <= 2 && !near_free; ++dj) {
        for (int di = -2; di <= 2 && !near_free; ++di) {
          if (g.inBounds(i + di, j + dj) &&
              snapshot[static_cast<size_t>(g.index(i + di, j + dj))] == kFree) {
            near_free = true;
          }
        }
      }
      if (near_free) g.data[static_cast<size_t>(g.index(i, j))] = kOccupied;
    }
  }

  m.places.places = {place("shop", 1.6, 7.6, shop),     place("room1", 1.6, 3.85, room1),
                     place("room2", 8.35, 1.6, room2),  place("room3", 7.6, 9.1, room3),
                     place("room4", 1.6, 11.35, room4), place("room5", 13.6, 6.85, room5)};
  m.places.areas = {BlockingArea{"ba1", Rect{4.5, 3.0, 7.5, 4.5}},
                    BlockingArea{"ba2", Rect{10.5, 4.5, 12.0, 6.0}},
                    BlockingArea{"ba3", Rect{4.5, 10.5, 6.0, 12.0}},
                    BlockingArea{"ba4", Rect{10.5, 7.5, 12.0, 10.5}}};
  return m;
}

}  // namespace krr_test
