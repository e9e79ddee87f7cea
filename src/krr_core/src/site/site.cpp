#include "krr_core/site/site.h"

#include <algorithm>
#include <filesystem>
#include <set>
#include <utility>

#include "krr_core/common/errors.h"
#include "krr_core/common/files.h"
#include "krr_core/common/limits.h"
#include "krr_core/common/yaml_section.h"
#include "krr_core/nav/occupancy_grid.h"

namespace krr {
namespace site {

namespace {

namespace fs = std::filesystem;

std::string comparable(const std::string& path) {
  std::error_code ec;
  const fs::path p = fs::weakly_canonical(fs::absolute(path), ec);
  return ec ? fs::absolute(path).lexically_normal().string() : p.string();
}

/// @brief site.yaml's file field `field` (default `fallback`), resolved against the folder and
/// required to exist. @throws ConfigError naming the manifest, the field and the value.
std::string siteFile(const YamlSection& top, const std::string& manifest, const std::string& dir,
                     const std::string& field, const std::string& fallback) {
  const std::string value = top.string(field, fallback);
  if (value.empty())
    throw ConfigError(manifest + ": field '" + field + "': value '' must name a file");
  const std::string path = value[0] == '/' ? value : dir + "/" + value;
  if (!fs::is_regular_file(path)) {
    throw ConfigError(manifest + ": field '" + field + "': value '" + value + "': no file " +
                      path + (top.has(field) ? "" : " (the default name; site.yaml may name "
                                                    "another)"));
  }
  return comparable(path);
}

/// @brief site.yaml's experiments: {experiment: {field: place}}, every value a name.
std::map<std::string, std::map<std::string, std::string>> readExperiments(
    const YAML::Node& node, const std::string& manifest) {
  std::map<std::string, std::map<std::string, std::string>> out;
  if (node.IsNull()) return out;
  if (!node.IsMap())
    throw ConfigError(manifest + ": field 'experiments': value '" + yamlText(node) +
                      "' must be a mapping experiment -> {field: place}");
  for (auto it = node.begin(); it != node.end(); ++it) {
    const std::string experiment = it->first.Scalar();
    const std::vector<std::string> known = experiment == "nav_transfer"
                                               ? std::vector<std::string>{"source", "target"}
                                           : experiment == "new_circumstances"
                                               ? std::vector<std::string>{"goal"}
                                               : std::vector<std::string>{};
    if (known.empty())
      throw ConfigError(manifest + ": field 'experiments." + experiment +
                        "': unknown experiment (nav_transfer, new_circumstances)");
    YamlSection s(it->second, manifest, "experiments." + experiment,
                  std::set<std::string>(known.begin(), known.end()));
    for (const std::string& f : known)
      if (s.has(f)) out[experiment][f] = s.string(f, "");
  }
  return out;
}

}  // namespace

Site Site::read(const std::string& dir, const std::string& base_config_dir) {
  if (!fs::is_directory(dir))
    throw ConfigError("site folder " + dir + ": no such directory");
  Site s;
  s.dir_ = comparable(dir);
  s.name_ = fs::path(s.dir_).filename().string();
  s.manifest_ = s.dir_ + "/" + kManifest;
  if (!fs::is_regular_file(s.manifest_))
    throw ConfigError("site folder " + s.dir_ + ": no " + kManifest +
                      " (a site folder holds site.yaml, the map, places.yaml, knowledge.plog "
                      "and language.yaml)");
  const YamlSection top(loadYamlFile(s.manifest_, "site manifest"), s.manifest_, "",
                        {"shop", "map", "places", "knowledge", "language", "domains", "areas",
                         "experiments"});
  const std::string base_nav = base_config_dir + "/navigation.yaml";
  const nav::NavigationConfig base = nav::loadNavigationConfig(base_nav);
  const std::string map = siteFile(top, s.manifest_, s.dir_, "map", "map.yaml");
  s.same_map_ = comparable(base.map) == map;
  s.places_ = siteFile(top, s.manifest_, s.dir_, "places", "places.yaml");
  s.knowledge_ = siteFile(top, s.manifest_, s.dir_, "knowledge", "knowledge.plog");
  s.language_ = siteFile(top, s.manifest_, s.dir_, "language", "language.yaml");
  s.map_ = map;
  nav::loadMap(map);  // the image it names exists and reads (MapError naming the file)
  if (top.has("shop")) {
    s.shop_ = top.requiredString("shop");
  } else if (!s.same_map_) {
    throw ConfigError(s.manifest_ + ": missing field 'shop': the place every delivery starts "
                      "from (only a site on " + base_nav + "'s own map inherits the base's)");
  }
  if (top.has("domains")) {
    s.domains_ = nav::readDomains(top.get("domains"), s.manifest_, "domains");
  } else if (!s.same_map_) {
    throw ConfigError(s.manifest_ + ": missing field 'domains': the site's map " + map +
                      " is not " + base_nav + "'s, whose domains cut another map (list {name: "
                      "{cols, rows, step_limit}})");
  }
  if (top.has("areas")) {
    s.areas_ = nav::readAreas(top.get("areas"), s.manifest_, "areas", base.simulator.times_of_day);
    s.own_areas_ = true;
  }
  s.navigation_ = s.navigationOver(base);
  s.dialog_ = s.dialogOver(dialog::loadDialogConfig(base_config_dir + "/dialog.yaml"));
  if (top.has("experiments")) s.experiments_ = readExperiments(top.get("experiments"), s.manifest_);
  return s;
}

Site Site::load(const std::string& dir, const std::string& base_config_dir) {
  Site s = read(dir, base_config_dir);
  requireConsistentSite(s.files());
  const std::vector<std::string> places = [&] {
    std::vector<std::string> names;
    for (const nav::Place& p : nav::loadPlaces(s.places()).places) names.push_back(p.name);
    return names;
  }();
  for (const auto& [experiment, fields] : s.experiments_) {
    for (const auto& [field, place] : fields) {
      if (std::find(places.begin(), places.end(), place) != places.end()) continue;
      throw ConfigError(s.manifest_ + ": field 'experiments." + experiment + "." + field +
                        "': value '" + place + "' is not a place of " + s.places());
    }
  }
  return s;
}

nav::NavigationConfig Site::navigationOver(nav::NavigationConfig base) const {
  base.map = map_;
  base.places = places_;
  if (!domains_.empty()) base.domains = domains_;
  // Without its own, a site on another map has no per-area overrides: the base's name
  // another map's areas.
  if (own_areas_ || !same_map_) base.simulator.areas = areas_;
  return base;
}

dialog::DialogConfig Site::dialogOver(dialog::DialogConfig base) const {
  base.office_plog = knowledge_;
  if (!shop_.empty()) base.shop = shop_;
  return base;
}

std::string Site::domainFile(const std::string& domain) const {
  navigation_.domain(domain);  // UnknownSymbolError naming the site's domains
  return domainFileBeside(navigation_.map, domain);
}

std::string Site::geometry(const std::string& domain) const {
  navigation_.domain(domain);
  return geometryFileBeside(navigation_.map, domain);
}

std::string Site::experimentPlace(const std::string& experiment, const std::string& field) const {
  const auto e = experiments_.find(experiment);
  if (e == experiments_.end()) return "";
  const auto f = e->second.find(field);
  return f == e->second.end() ? "" : f->second;
}

SiteFiles Site::files() const {
  SiteFiles f;
  f.navigation_config = manifest_;
  f.dialog_config = manifest_;
  f.language_config = language_;
  f.navigation = navigation_;
  f.dialog = dialog_;
  // The reasoner loads the site's knowledge (derived): rule 5 holds by construction.
  f.reasoner_domain_files = std::vector<std::string>{dialog_.office_plog};
  f.reasoner_source = manifest_;
  f.areas_field = "areas";
  f.shop = dialog_.shop;
  f.shop_source = manifest_ + ": field 'shop'";
  return f;
}

std::string domainFileBeside(const std::string& map_yaml, const std::string& name) {
  return fs::weakly_canonical(fs::path(dirName(map_yaml)) / (name + ".yaml")).string();
}

std::string geometryFileBeside(const std::string& map_yaml, const std::string& name) {
  return fs::weakly_canonical(fs::path(dirName(map_yaml)) / (name + "_geometry.plog")).string();
}

nav::NavGrid writeDomain(const nav::NavigationConfig& cfg, const nav::DomainConfig& d,
                         const nav::OccupancyGrid& map, const nav::PlacesFile& places) {
  // The config loaders already refuse such names; this guards the file names written below.
  if (!isPlainName(d.name))
    throw ConfigError("domain name '" + d.name + "' must be a plain identifier [A-Za-z0-9_-]+");
  nav::NavGridOptions opt;
  opt.cols = d.cols;
  opt.rows = d.rows;
  opt.max_blocked_fraction = cfg.max_blocked_fraction;
  nav::NavGrid grid = nav::NavGrid::fromMap(map, places, opt);
  writeFileAtomic(domainFileBeside(cfg.map, d.name),
                  grid.toYaml(d.name, fs::path(cfg.map).filename().string()));
  writeFileAtomic(geometryFileBeside(cfg.map, d.name), grid.toPlog(d.name));
  return grid;
}

}  // namespace site
}  // namespace krr
