#include "krr_core/site/scaffold.h"

#include <unistd.h>

#include <algorithm>
#include <cctype>
#include <cmath>
#include <cstring>
#include <filesystem>
#include <set>
#include <sstream>

#include <yaml-cpp/yaml.h>

#include "krr_core/common/cli.h"
#include "krr_core/common/errors.h"
#include "krr_core/common/files.h"
#include "krr_core/common/limits.h"  // isPlainName
#include "krr_core/common/yaml_section.h"
#include "krr_core/nav/grid_astar.h"
#include "krr_core/site/floor_plan.h"
#include "krr_core/site/site.h"

namespace krr {
namespace site {

namespace {

namespace fs = std::filesystem;

/// The symbols of the generated knowledge and of the navigation knowledge it is loaded with:
/// a name of the building equal to one of them would change what the rules mean.
const std::set<std::string> kReserved = {
    "random", "pr", "obs", "do", "not",  // P-log keywords
    "boolean", "true", "false", "time", "morning", "noon", "afternoon", "person", "item",
    "room", "place", "curr_person", "curr_item", "curr_room", "request", "act_item", "act_room",
    "act_person", "serve", "cell", "loc", "ba", "trapped", "leftof", "belowof", "place_cell",
    "in_ba"};

/// The lab's word lists (config/sites/lab/language.yaml): the scaffold's language file starts
/// from them.
const std::vector<std::string> kYes = {"yes", "yeah", "yep", "yup", "sure", "correct", "right",
                                       "that's right", "affirmative", "exactly", "indeed"};
const std::vector<std::string> kNo = {"no", "nope", "nah", "wrong", "incorrect", "negative"};
const std::vector<std::string> kIgnore = {
    "a", "an", "the", "some", "one", "for", "to", "of", "in", "at", "into", "please", "thanks",
    "thank", "you", "thank you", "i", "id", "im", "me", "my", "we", "our", "it", "its", "is",
    "was", "be", "would", "like", "want", "need", "love", "could", "can", "will", "should",
    "order", "deliver", "delivery", "bring", "take", "get", "send", "give", "drink", "and",
    "with", "ok", "okay", "hi", "hello", "hey", "oh", "um", "uh", "well", "just", "i'd like",
    "room", "office", "person", "item", "it's", "that", "this", "there", "he", "she", "him",
    "her", "his", "who", "what", "which", "cup", "bottle", "glass", "a cup of"};
const std::vector<std::string> kNumbers = {"zero",    "one",     "two",      "three",   "four",
                                           "five",    "six",     "seven",    "eight",   "nine",
                                           "ten",     "eleven",  "twelve",   "thirteen",
                                           "fourteen", "fifteen", "sixteen", "seventeen",
                                           "eighteen", "nineteen", "twenty"};

/// The dialog's speech model hears a wrong answer as another value of the sort (site_check.h).
const char* const kTwoValues =
    ": the dialog needs at least two of each (a misheard answer is another one)";

std::string join(const std::vector<std::string>& v, const std::string& sep = ", ") {
  std::string out;
  for (const std::string& s : v) out += (out.empty() ? "" : sep) + s;
  return out;
}

bool contains(const std::vector<std::string>& v, const std::string& s) {
  return std::find(v.begin(), v.end(), s) != v.end();
}

/// @brief A phrase as the language front end compares it: lower case, words separated by one
/// space at anything but letters, digits and apostrophes, "'s" dropped, apostrophes removed.
std::string normalised(const std::string& text) {
  std::vector<std::string> words;
  std::string cur;
  auto flush = [&] {
    if (cur.size() >= 2 && cur.compare(cur.size() - 2, 2, "'s") == 0) cur.resize(cur.size() - 2);
    cur.erase(std::remove(cur.begin(), cur.end(), '\''), cur.end());
    if (!cur.empty()) words.push_back(cur);
    cur.clear();
  };
  for (char c : text) {
    const char l = static_cast<char>(std::tolower(static_cast<unsigned char>(c)));
    if (std::isalnum(static_cast<unsigned char>(l)) || l == '\'') cur += l;
    else flush();
  }
  flush();
  return join(words, " ");
}

/// @brief A name as people say it: underscores become spaces ("mary_ann" -> "mary ann").
std::string spoken(std::string name) {
  std::replace(name.begin(), name.end(), '_', ' ');
  return name;
}

std::string plural(const std::string& word) {
  if (std::isdigit(static_cast<unsigned char>(word.back()))) return "";  // "item2": none
  auto ends = [&](const std::string& s) {
    return word.size() > s.size() && word.compare(word.size() - s.size(), s.size(), s) == 0;
  };
  if (ends("s") || ends("x") || ends("z") || ends("ch") || ends("sh")) return word + "es";
  if (ends("y") && word.size() >= 2 && !std::strchr("aeiou", word[word.size() - 2]))
    return word.substr(0, word.size() - 1) + "ies";
  return word + "s";
}

std::string quoted(const std::string& s) { return "\"" + s + "\""; }

/// @brief The site folder's name (the last component of `out`, a trailing '/' ignored).
std::string folderName(const std::string& out) {
  const fs::path p = fs::absolute(out).lexically_normal();
  return (p.filename().empty() ? p.parent_path() : p).filename().string();
}

/// @brief The site folder `out` as an absolute path without a trailing '/'.
fs::path folderPath(const std::string& out) {
  const fs::path p = fs::absolute(out).lexically_normal();
  return p.filename().empty() ? p.parent_path() : p;
}

/// @brief `name` must be a site constant; `what` names the option (and file) it came from.
void requireConstant(const std::string& what, const std::string& name) {
  if (isSiteConstant(name)) return;
  std::string why = "must be a P-log constant: a lower-case letter, then lower-case letters, "
                    "digits or '_'";
  if (kReserved.count(name))
    why = "is a symbol of the knowledge's own structure or a P-log keyword";
  throw ConfigError(what + ": value '" + name + "' " + why);
}

int parseInt(const std::string& option, const std::string& value, const std::string& part,
             int min) {
  std::size_t used = 0;
  int n = 0;
  try {
    n = std::stoi(part, &used);
  } catch (const std::exception&) {
    used = 0;
  }
  if (used == 0 || used != part.size() || n < min || n > 10000000)
    throw ConfigError(option + ": value '" + value + "': '" + part +
                      "' must be an integer of at least " + std::to_string(min));
  return n;
}

/// @brief The room's name split as <office|room>[_]<suffix>, or {"", ""}.
std::pair<std::string, std::string> officeStyle(const std::string& room) {
  for (const std::string prefix : {"office", "room"}) {
    if (room.rfind(prefix, 0) != 0 || room.size() == prefix.size()) continue;
    std::string suffix = room.substr(prefix.size());
    if (suffix[0] == '_') suffix = suffix.substr(1);
    const bool digits = !suffix.empty() && std::all_of(suffix.begin(), suffix.end(), [](char c) {
      return std::isdigit(static_cast<unsigned char>(c)) != 0;
    });
    const bool letter = suffix.size() == 1 && std::isalpha(static_cast<unsigned char>(suffix[0]));
    if (digits || letter) return {prefix, suffix};
  }
  return {"", ""};
}

/// @brief "option: what" of a loader's error, naming the value when the loader did not.
std::string optionError(const std::string& option, const std::string& value, const Error& e) {
  const std::string what = e.what();
  return option + ": " + (what.find(value) == std::string::npos ? "value '" + value + "': " : "") +
         what;
}

}  // namespace

bool isSiteConstant(const std::string& name) {
  if (name.empty() || !(name[0] >= 'a' && name[0] <= 'z') || kReserved.count(name)) return false;
  return std::all_of(name.begin(), name.end(), [](char c) {
    return (c >= 'a' && c <= 'z') || (c >= '0' && c <= '9') || c == '_';
  });
}

ScaffoldDomain parseScaffoldDomain(const std::string& option, const std::string& value) {
  const std::vector<std::string> parts = splitOption(value, ':');
  const std::size_t x = parts.size() >= 2 ? parts[1].find('x') : std::string::npos;
  if (parts.size() < 2 || parts.size() > 3 || x == std::string::npos)
    throw ConfigError(option + ": value '" + value + "' must be NAME:COLSxROWS[:STEP_LIMIT] "
                      "(e.g. lab_24x16:24x16:150)");
  ScaffoldDomain d;
  d.name = parts[0];
  if (!isPlainName(d.name))
    throw ConfigError(option + ": value '" + value + "': domain name '" + d.name +
                      "' must be a plain identifier [A-Za-z0-9_-]+ (it names files)");
  d.cols = parseInt(option, value, parts[1].substr(0, x), 1);
  d.rows = parseInt(option, value, parts[1].substr(x + 1), 1);
  if (parts.size() == 3) d.step_limit = parseInt(option, value, parts[2], 1);
  return d;
}

std::vector<std::pair<std::string, std::string>> parseOffices(const std::string& option,
                                                              const std::string& value) {
  std::vector<std::pair<std::string, std::string>> out;
  for (const std::string& item : splitOption(value)) {
    const std::size_t colon = item.find(':');
    if (colon == std::string::npos || colon == 0 || colon + 1 == item.size() ||
        item.find(':', colon + 1) != std::string::npos)
      throw ConfigError(option + ": value '" + item + "' must be PERSON:ROOM");
    out.emplace_back(item.substr(0, colon), item.substr(colon + 1));
  }
  return out;
}

Scaffold::Scaffold(ScaffoldOptions options) : o_(std::move(options)) {
  if (o_.out.empty()) throw ConfigError("--out: the site folder to write is required");
  if (!o_.rooms_from_text.empty()) {
    if (!o_.map.empty() || !o_.places.empty())
      throw ConfigError("--rooms-from-text: value '" + o_.rooms_from_text +
                        "': give either it or --map and --places");
    try {
      FloorPlan plan = loadFloorPlan(o_.rooms_from_text);
      map_ = std::move(plan.grid);
      places_ = std::move(plan.places);
    } catch (const Error& e) {
      throw ConfigError(optionError("--rooms-from-text", o_.rooms_from_text, e));
    }
    places_file_ = o_.rooms_from_text;
    validate();
    return;
  }
  if (o_.map.empty())
    throw ConfigError("--map: a map_server YAML file is required (or --rooms-from-text FILE)");
  if (o_.places.empty()) throw ConfigError("--places: a places file is required");
  places_file_ = o_.places;
  try {
    map_ = nav::loadMap(o_.map);
    const std::string image = nav::loadMapMetadata(o_.map).image;
    image_ = !image.empty() && image[0] == '/' ? image : dirName(o_.map) + "/" + image;
  } catch (const Error& e) {
    throw ConfigError(optionError("--map", o_.map, e));
  }
  try {
    places_ = nav::loadPlaces(o_.places);
  } catch (const Error& e) {
    throw ConfigError(optionError("--places", o_.places, e));
  }
  validate();
}

void Scaffold::validate() {
  validateNames();
  validateRoomsAndOffices();
  resolveDomains();
  std::error_code ec;
  if (!fs::is_directory(folderPath(o_.out).parent_path(), ec))
    throw ConfigError("--out: value '" + o_.out + "': no directory " +
                      folderPath(o_.out).parent_path().string() + " to create it in");
  if (fs::exists(o_.out, ec) && !fs::is_directory(o_.out, ec))
    throw ConfigError("--out: value '" + o_.out + "' exists and is not a directory");
  if (fs::is_directory(o_.out, ec) && !fs::is_empty(o_.out, ec) && !o_.force)
    throw ConfigError("--out: value '" + o_.out +
                      "' exists and is not empty (--force replaces it)");
}

void Scaffold::validateNames() {
  // Every name the knowledge or the geometry declares, with where it came from.
  std::map<std::string, std::string> seen;
  auto declare = [&](const std::string& what, const std::string& name) {
    requireConstant(what, name);
    const auto [it, fresh] = seen.emplace(name, what);
    if (!fresh)
      throw ConfigError(what + ": value '" + name + "' is a duplicate name (also in " +
                        it->second + "): every person, item, place and blocking area needs "
                        "its own name");
  };
  for (const std::string& p : o_.people) declare("--people", p);
  for (const std::string& i : o_.items) declare("--items", i);
  const std::string source =
      (o_.rooms_from_text.empty() ? "--places " : "--rooms-from-text ") + places_file_;
  for (const nav::Place& p : places_.places) declare(source + ": place", p.name);
  for (const nav::BlockingArea& a : places_.areas) declare(source + ": blocking area", a.name);
  if (o_.people.size() < 2)
    throw ConfigError("--people: value '" + join(o_.people) + "': " +
                      std::to_string(o_.people.size()) + " person" + kTwoValues);
  if (o_.items.size() < 2)
    throw ConfigError("--items: value '" + join(o_.items) + "': " +
                      std::to_string(o_.items.size()) + " item" + kTwoValues);
}

void Scaffold::validateRoomsAndOffices() {
  std::vector<std::string> places;
  for (const nav::Place& p : places_.places) places.push_back(p.name);
  if (o_.shop.empty()) throw ConfigError("--shop: the place deliveries start from is required");
  if (!contains(places, o_.shop))
    throw ConfigError("--shop: value '" + o_.shop + "' is not a place of " + places_file_ +
                      " (places: " + join(places) + ")");
  if (o_.rooms.empty()) {
    for (const std::string& p : places)
      if (p != o_.shop) rooms_.push_back(p);
  } else {
    for (const std::string& r : o_.rooms) {
      if (r == o_.shop)
        throw ConfigError("--rooms: value '" + r + "' is the shop (--shop): a place is either "
                          "the shop or a room");
      if (!contains(places, r))
        throw ConfigError("--rooms: value '" + r + "' is not a place of " + places_file_ +
                          " (places: " + join(places) + ")");
      if (contains(rooms_, r)) throw ConfigError("--rooms: value '" + r + "' is given twice");
      rooms_.push_back(r);
    }
  }
  if (rooms_.size() < 2)
    throw ConfigError((o_.rooms.empty() ? (o_.rooms_from_text.empty() ? "--places"
                                                                      : "--rooms-from-text")
                                        : "--rooms") +
                      std::string(": value '") + (o_.rooms.empty() ? places_file_ : join(o_.rooms)) +
                      "': " + std::to_string(rooms_.size()) + " room(s) besides the shop '" +
                      o_.shop + "'" + kTwoValues);
  std::set<std::string> placed;
  for (const auto& [person, room] : o_.offices) {
    const std::string value = "'" + person + ":" + room + "'";
    if (!contains(o_.people, person))
      throw ConfigError("--offices: value " + value + ": '" + person +
                        "' is not a person of --people (" + join(o_.people) + ")");
    if (room == o_.shop)
      throw ConfigError("--offices: value " + value + ": '" + room +
                        "' is the shop (--shop), not a room (rooms: " + join(rooms_) + ")");
    if (!contains(rooms_, room))
      throw ConfigError("--offices: value " + value + ": '" + room + "' is not a room (rooms: " +
                        join(rooms_) + ")");
    if (!placed.insert(person).second)
      throw ConfigError("--offices: value " + value + ": '" + person +
                        "' already has an office (one room per person: the request prior "
                        "gives it 8/10)");
  }
}

void Scaffold::resolveDomains() {
  if (!o_.domains.empty() && o_.cell > 0)
    throw ConfigError("--cell: give either --domain or --cell, not both");
  domains_ = o_.domains;
  const double width = map_.width * map_.resolution, height = map_.height * map_.resolution;
  if (domains_.empty()) {
    if (!(o_.cell > 0))
      throw ConfigError("--domain: a domain NAME:COLSxROWS[:STEP_LIMIT] or --cell METRES is "
                        "required");
    const double c = width / o_.cell, r = height / o_.cell;
    if (std::abs(c - std::round(c)) > 1e-6 || std::abs(r - std::round(r)) > 1e-6 ||
        std::round(c) < 1 || std::round(r) < 1) {
      std::ostringstream m;
      m << "--cell: value '" << o_.cell << "' does not divide the map (" << width << " m x "
        << height << " m): choose a cell size that does, or --domain NAME:COLSxROWS";
      throw ConfigError(m.str());
    }
    ScaffoldDomain d;
    d.cols = static_cast<int>(std::round(c));
    d.rows = static_cast<int>(std::round(r));
    d.name = folderName(o_.out) + "_" +
             std::to_string(d.cols) + "x" + std::to_string(d.rows);
    if (!isPlainName(d.name))
      d.name = "site_" + std::to_string(d.cols) + "x" + std::to_string(d.rows);
    domains_.push_back(d);
  }
  std::set<std::string> names;
  for (ScaffoldDomain& d : domains_) {
    const std::string what = "--domain: value '" + d.name + "'";
    if (!names.insert(d.name).second) throw ConfigError(what + " is given twice");
    nav::NavGridOptions opt;
    opt.cols = d.cols;
    opt.rows = d.rows;
    nav::NavGrid grid;
    try {
      grid = nav::NavGrid::fromMap(map_, places_, opt);
    } catch (const Error& e) {
      throw ConfigError(what + ": " + e.what());
    }
    nav::GridAStar astar(grid);
    const std::vector<int> dist = astar.distancesTo(grid.placeCell(o_.shop));
    int longest = 0;
    for (const std::string& room : rooms_) {
      const int moves = dist[static_cast<std::size_t>(grid.placeCell(room))];
      if (moves < 0)
        throw ConfigError(what + ": room '" + room + "' cannot be reached from the shop '" +
                          o_.shop + "' on its " + std::to_string(d.cols) + " x " +
                          std::to_string(d.rows) + " grid (a door narrower than a cell, or a "
                          "wall off the cell edges? see the README's Grid)");
      longest = std::max(longest, moves);
      if (&d == &domains_.front()) moves_[room] = moves;
    }
    if (d.step_limit == 0) d.step_limit = std::max(10, (5 * longest + 9) / 10 * 10);
  }
  farthest_ = nearest_ = rooms_.front();
  for (const std::string& r : rooms_) {
    if (moves_[r] > moves_[farthest_]) farthest_ = r;
    if (moves_[r] < moves_[nearest_]) nearest_ = r;
  }
  if (nearest_ == farthest_ && rooms_.size() > 1)
    nearest_ = rooms_.front() == farthest_ ? rooms_[1] : rooms_.front();
}

std::string Scaffold::siteYaml() const {
  std::ostringstream s;
  s << "# Site " << folderName(o_.out)
    << ": generated by make_site from "
    << (image_.empty() ? o_.rooms_from_text + " (the map drawn from it)"
                       : o_.map + " and " + o_.places) << ".\n"
    << "# Its files are the default names of this folder: map.yaml + its image, places.yaml,\n"
    << "# knowledge.plog, language.yaml; make_site also cut the domains (<domain>.yaml and\n"
    << "# <domain>_geometry.plog). Edit freely; after changing the map, the places or the\n"
    << "# domains: make_nav_domain --site DIR. Then check_site --site DIR.\n"
    << "shop: " << o_.shop << "            # where every delivery starts: a place, no room\n\n"
    << "# Navigation domains cut from the map (cell = map size / cols, rows); step limit per\n"
    << "# trip: 5 x the longest route from the shop unless given. Moves from the shop on "
    << domains_[0].name << ":\n#  ";
  for (const std::string& r : rooms_) s << " " << r << " " << moves_.at(r);
  s << "\ndomains:\n";
  for (const ScaffoldDomain& d : domains_)
    s << "  " << d.name << ": {cols: " << d.cols << ", rows: " << d.rows
      << ", step_limit: " << d.step_limit << "}\n";
  s << "\n# Per-area simulator overrides (navigation.yaml's simulator.areas format), e.g.\n"
    << "# areas:\n#   <blocking area>: {time_of_day: {noon: 2.0}}\n";
  s << "\n# Places of this site for the navigation experiments: the farthest room from the shop\n"
    << "# as the target / goal, the nearest as the source.\n"
    << "experiments:\n  nav_transfer: {source: " << nearest_ << ", target: " << farthest_
    << "}\n  new_circumstances: {goal: " << farthest_ << "}\n";
  return s.str();
}

std::string Scaffold::knowledgePlog() const {
  const std::string site = folderName(o_.out);
  std::ostringstream s;
  s << "% Site " << site << ": rigid and dialog knowledge, generated by make_site in the\n"
    << "% lab's structure (config/sites/lab/knowledge.plog). Edit freely; check_site --site DIR.\n"
    << "%\n% Service requests are <item, room, person>: " << o_.items.size() << " items x "
    << rooms_.size() << " rooms x " << o_.people.size() << " persons = "
    << o_.items.size() * rooms_.size() * o_.people.size() << " requests.\n"
    << "% Room names are the places of places.yaml (the " << o_.shop
    << ", where deliveries start, is no room).\n\n"
    << "boolean = {true, false}.\n"
    << "time = {morning, noon, afternoon}.\n"
    << "person = {" << join(o_.people) << "}.\n"
    << "item = {" << join(o_.items) << "}.\n"
    << "room = {" << join(rooms_) << "}.\n"
    << "#domain person(P), item(I), room(R).\n\n"
    << "% Where people work (human knowledge).\n"
    << "place : person, room -> boolean.\n";
  for (const auto& [person, room] : o_.offices) s << "place(" << person << ", " << room << ").\n";
  if (o_.offices.empty()) s << "% (no offices given: every room is equally likely)\n";
  s << "\n% The hidden service request.\n"
    << "curr_person : person.\n"
    << "curr_item : person -> item.\n"
    << "curr_room : person -> room.\n"
    << "random(curr_person).\n"
    << "random(curr_item(P)).\n"
    << "random(curr_room(P)).\n\n"
    << "% People request deliveries to their own offices with probability 0.8.\n"
    << "pr(curr_room(P)=R | place(P,R)=true) = 8/10.\n\n"
    << "request(I, R, P) :- curr_item(P)=I, curr_room(P)=R, curr_person=P.\n\n"
    << "% Delivery actions: serve(I,R,P) holds when the act_ attributes select it.\n"
    << "act_item : item.\n"
    << "act_room : room.\n"
    << "act_person : person.\n"
    << "serve : item, room, person -> boolean.\n"
    << "serve(I, R, P) :- act_item=I, act_room=R, act_person=P.\n\n";
  const std::string person = o_.offices.empty() ? o_.people.front() : o_.offices.front().first;
  const std::string room = o_.offices.empty() ? rooms_.front() : o_.offices.front().second;
  s << "?{curr_room(" << person << ")=" << room << "} | do(curr_person=" << person << ").\n"
    << "?{request(" << o_.items.front() << ", " << room << ", " << person << ")}.\n";
  return s.str();
}

std::vector<std::string> Scaffold::wordList(const std::vector<std::string>& words) const {
  std::set<std::string> names;
  for (const auto* list : {&o_.people, &o_.items, &rooms_})
    for (const std::string& n : *list) names.insert(normalised(n));
  for (const nav::Place& p : places_.places) names.insert(normalised(p.name));
  std::vector<std::string> out;
  for (const std::string& w : words)
    if (!names.count(normalised(w))) out.push_back(w);
  return out;
}

std::vector<std::pair<std::string, std::string>> Scaffold::synonyms() const {
  std::set<std::string> taken;  // normalised phrases that already mean something
  for (const auto* list : {&o_.people, &o_.items, &rooms_})
    for (const std::string& n : *list) taken.insert(normalised(n));
  for (const auto* list : {&kYes, &kNo, &kIgnore})
    for (const std::string& w : wordList(*list)) taken.insert(normalised(w));
  std::vector<std::pair<std::string, std::string>> out;
  auto add = [&](const std::string& phrase, const std::string& target) {
    if (taken.insert(normalised(phrase)).second) out.emplace_back(phrase, target);
  };
  for (const auto& [person, room] : o_.offices) {
    add(spoken(person) + "'s office", room);
    add(spoken(person) + "'s room", room);
  }
  for (const std::string& room : rooms_) {
    const auto [prefix, suffix] = officeStyle(room);
    if (prefix.empty()) continue;
    const bool digits = std::isdigit(static_cast<unsigned char>(suffix[0])) != 0;
    for (const std::string p : {"office", "room"}) {
      add(p + (digits ? "" : " ") + suffix, room);
      const int n = digits && suffix.size() <= 2 ? std::stoi(suffix) : -1;
      if (n >= 0 && n < static_cast<int>(kNumbers.size())) add(p + " " + kNumbers[n], room);
    }
  }
  for (const std::string& item : o_.items)
    if (!plural(spoken(item)).empty()) add(plural(spoken(item)), item);
  return out;
}

std::string Scaffold::languageYaml() const {
  // A flow sequence, wrapped at about 95 columns and indented under its key.
  auto list = [](const std::string& key, const std::vector<std::string>& words) {
    std::string out, line = key + ": [";
    for (std::size_t i = 0; i < words.size(); ++i) {
      const std::string w = quoted(words[i]) + (i + 1 < words.size() ? "," : "]");
      if (line.size() + 1 + w.size() > 95 && line.back() != '[') {
        out += line + "\n";
        line = std::string(key.size() + 3, ' ') + w;
      } else {
        line += (line.back() == '[' ? "" : " ") + w;
      }
    }
    return out + (words.empty() ? line + "]" : line);
  };
  std::ostringstream s;
  s << "# Language front end of the dialog manager (krr::dialog::LanguageFrontEnd, see\n"
    << "# src/krr_core/include/krr_core/dialog/language.h for the full rules), generated by\n"
    << "# make_site. Words are lower-cased (no capitalised forms needed), punctuation separates\n"
    << "# words, \"" << o_.people.front() << "'s\" reads as \"" << o_.people.front()
    << "\", '_' in a name as a space. The model's own names\n"
    << "# are always understood: items " << join(o_.items) << "; rooms " << join(rooms_)
    << ";\n# people " << join(o_.people) << ". Add nicknames and other words people use below.\n\n"
    << list("yes", wordList(kYes)) << "\n"
    << list("no", wordList(kNo)) << "\n\n"
    << "# Understood and carrying no information.\n"
    << list("ignore", wordList(kIgnore)) << "\n\n"
    << "# phrase -> a value name of the model (items, rooms, persons). Unknown targets are "
       "refused.\n";
  const auto syn = synonyms();
  s << "synonyms:" << (syn.empty() ? " {}\n" : "\n");
  for (const auto& [phrase, target] : syn) s << "  " << quoted(phrase) << ": " << target << "\n";
  s << "\n# Longer utterances are truncated (with a note).\nmax_utterance_chars: 500\n";
  return s.str();
}

SiteReport Scaffold::write(const std::string& base_config_dir) const {
  const fs::path target = folderPath(o_.out);
  std::string pattern =
      (target.parent_path() / ("." + target.filename().string() + ".new-XXXXXX")).string();
  if (!::mkdtemp(&pattern[0])) throw IoError("--out: cannot create a directory beside " + o_.out);
  const fs::path tmp = pattern;
  fs::path old;  // a replaced folder (--force), kept until the new one is in place
  std::error_code ec;
  try {
    if (image_.empty()) {  // drawn from --rooms-from-text
      nav::saveMap(map_, (tmp / "map.yaml").string(), "map.pgm");
      writeFileAtomic((tmp / "places.yaml").string(),
                      "# Places and blocking areas drawn by make_site from " + o_.rooms_from_text +
                          " (metres, map frame).\n" + nav::placesToYaml(places_));
    } else {
      const std::string ext = fs::path(image_).extension().string();
      YAML::Node map = loadYamlFile(o_.map, "map");
      map["image"] = "map" + ext;
      YAML::Emitter e;
      e << map;
      writeFileAtomic((tmp / "map.yaml").string(), "# map_server map, copied by make_site from " +
                                                       o_.map + "\n" + e.c_str() + "\n");
      writeFileAtomic((tmp / ("map" + ext)).string(), readFile(image_));
      writeFileAtomic((tmp / "places.yaml").string(), readFile(o_.places));
    }
    writeFileAtomic((tmp / "site.yaml").string(), siteYaml());
    writeFileAtomic((tmp / "knowledge.plog").string(), knowledgePlog());
    writeFileAtomic((tmp / "language.yaml").string(), languageYaml());
    const Site site = Site::read(tmp.string(), base_config_dir);
    requireConsistentSite(site.files());
    // The domains as make_nav_domain cuts them, so the folder runs as it is.
    const nav::NavigationConfig& navigation = site.navigation();
    const nav::OccupancyGrid map = nav::loadMap(navigation.map);
    const nav::PlacesFile places = nav::loadPlaces(navigation.places);
    for (const nav::DomainConfig& d : navigation.domains) writeDomain(navigation, d, map, places);
    if (fs::exists(target)) {
      if (fs::is_empty(target)) {
        fs::remove(target);
      } else {  // --force (checked in the constructor): the old folder goes once the new is in
        old = target.parent_path() / ("." + target.filename().string() + ".old-" +
                                      std::to_string(::getpid()));
        fs::rename(target, old);
      }
    }
    fs::rename(tmp, target);
    if (!old.empty()) fs::remove_all(old, ec);
  } catch (const fs::filesystem_error& e) {
    fs::remove_all(tmp, ec);
    if (!old.empty() && !fs::exists(target, ec)) fs::rename(old, target, ec);  // put it back
    throw IoError("--out: value '" + o_.out + "': cannot write the site folder: " + e.what());
  } catch (...) {
    fs::remove_all(tmp, ec);
    throw;
  }
  return requireConsistentSite(Site::read(target.string(), base_config_dir).files());
}

}  // namespace site
}  // namespace krr
