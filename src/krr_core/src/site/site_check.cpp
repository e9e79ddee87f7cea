#include "krr_core/site/site_check.h"

#include <algorithm>
#include <cctype>
#include <filesystem>
#include <set>
#include <utility>

#include "krr_core/common/files.h"
#include "krr_core/common/yaml_section.h"
#include "krr_core/dialog/dialog_config.h"
#include "krr_core/dialog/language.h"
#include "krr_core/nav/navigation_config.h"
#include "krr_core/plog/parser.h"

namespace krr {
namespace site {

namespace {

namespace fs = std::filesystem;

std::string join(const std::vector<std::string>& names, const char* separator = ", ") {
  std::string s;
  for (const std::string& n : names) s += (s.empty() ? "" : separator) + n;
  return s;
}

bool contains(const std::vector<std::string>& names, const std::string& name) {
  return std::find(names.begin(), names.end(), name) != names.end();
}

std::string lower(std::string s) {
  for (char& c : s) c = static_cast<char>(std::tolower(static_cast<unsigned char>(c)));
  return s;
}

/// @brief A path made comparable: absolute, `.`, `..` and symbolic links resolved, so that
/// config/office.plog under the root and office.plog beside dialog.yaml compare equal.
std::string resolved(const std::string& path) {
  std::error_code ec;
  const fs::path p = fs::weakly_canonical(fs::absolute(path), ec);
  return ec ? fs::absolute(path).lexically_normal().string() : p.string();
}

/// @brief `path` against `base` unless it is absolute, as the nodes resolve their parameters.
std::string against(const std::string& base, const std::string& path) {
  if (path.empty() || path[0] == '/' || base.empty()) return path;
  return base + "/" + path;
}

/**
 * @brief Collects findings; a loader's error becomes a finding of its file, so that the rules
 * not needing that file still run and every problem is reported in one go.
 */
class Checker {
 public:
  explicit Checker(SiteReport& report) : report_(report) {}

  void add(std::string file, std::string field, std::string value, std::string message) {
    report_.findings.push_back(
        {std::move(file), std::move(field), std::move(value), std::move(message)});
  }

  /// @brief f() or, if it throws krr::Error, a finding of `file` carrying the loader's message
  /// (which names the field and the value) and std::nullopt.
  template <class F>
  auto load(const std::string& file, F&& f) -> std::optional<decltype(f())> {
    try {
      return f();
    } catch (const ParseError& e) {
      // file:line:col, the place an editor jumps to.
      add(e.location().str(), "", "", e.message());
      return std::nullopt;
    } catch (const Error& e) {
      std::string message = e.what();
      // The loaders start with the file's name; the finding's str() writes it once.
      if (message.rfind(file + ": ", 0) == 0) message = message.substr(file.size() + 2);
      add(file, "", "", message);
      return std::nullopt;
    }
  }

 private:
  SiteReport& report_;
};

/// @brief The values of sort `name` of a parsed program, or std::nullopt when it has none.
std::optional<std::vector<std::string>> sortValues(const plog::Program& program,
                                                   const std::string& name) {
  const plog::SortDecl* sort = program.findSort(name);
  if (!sort) return std::nullopt;
  std::vector<std::string> values;
  for (const plog::Term& t : sort->values) values.push_back(plog::toString(t));
  return values;
}

/// @brief The reasoner's domain_files as its node config writes them.
std::optional<std::vector<std::string>> reasonerDomainFiles(const SiteFiles& files,
                                                            Checker& check) {
  const auto root = check.load(files.reasoner_config, [&] {
    return loadYamlFile(files.reasoner_config, "reasoner node config");
  });
  if (!root) return std::nullopt;
  if (!root->IsMap()) {
    check.add(files.reasoner_config, "", yamlText(*root), "must be a mapping of parameters");
    return std::nullopt;
  }
  const YAML::Node list = (*root)["domain_files"];
  // Not set: the reasoner loads the dialog's knowledge.office (its default, krr_ros's
  // reasoner_node), the one home of the knowledge file's name.
  if (!list) return std::nullopt;
  std::vector<std::string> out;
  bool ok = list.IsSequence();
  if (ok) {
    for (const YAML::Node& f : list) {
      if (!f.IsScalar()) ok = false;
      else out.push_back(f.Scalar());
    }
  }
  if (!ok) {
    check.add(files.reasoner_config, "domain_files", yamlText(list),
              "value '" + yamlText(list) + "' must be a list of P-log files");
    return std::nullopt;
  }
  return out;
}

}  // namespace

SiteFiles SiteFiles::inConfigDir(const std::string& config_dir) {
  SiteFiles f;
  f.navigation_config = config_dir + "/navigation.yaml";
  f.dialog_config = config_dir + "/dialog.yaml";
  f.language_config = config_dir + "/language.yaml";
  f.reasoner_config = config_dir + "/reasoner_node.yaml";
  f.root = fs::path(resolved(config_dir)).parent_path().string();
  return f;
}

std::string Finding::str() const {
  return file + (field.empty() ? "" : ": field '" + field + "'") + ": " + message;
}

std::string SiteReport::summary() const {
  return "site consistent: " + std::to_string(rooms.size()) + " rooms with places (" +
         join(rooms) + "), shop '" + shop + "', " + std::to_string(areas.size()) +
         " blocking areas (" + join(areas) + "), " + std::to_string(synonyms) +
         " synonyms, the reasoner and the dialog load " + knowledge;
}

InconsistentSiteError::InconsistentSiteError(std::vector<Finding> findings)
    : ConfigError([&] {
        std::string text = "the site's files disagree (" + std::to_string(findings.size()) +
                           (findings.size() == 1 ? " finding" : " findings") + "):";
        for (const Finding& f : findings) text += "\n  " + f.str();
        return text;
      }()),
      findings_(std::move(findings)) {}

SiteReport checkSite(const SiteFiles& files) {
  SiteReport report;
  Checker check(report);

  // The files. Each unreadable one is a finding; the rules that need it are skipped.
  const auto nav = files.navigation ? files.navigation : check.load(files.navigation_config, [&] {
    return nav::loadNavigationConfig(files.navigation_config);
  });
  if (nav) report.places_file = nav->places;
  std::optional<nav::PlacesFile> places;
  if (nav)
    places = check.load(nav->places, [&] { return nav::loadPlaces(nav->places); });
  if (places) {
    for (const nav::Place& p : places->places) report.places.push_back(p.name);
    for (const nav::BlockingArea& a : places->areas) report.areas.push_back(a.name);
  }
  const auto dialog = files.dialog ? files.dialog : check.load(files.dialog_config, [&] {
    return dialog::loadDialogConfig(files.dialog_config);
  });
  std::optional<plog::Program> knowledge;
  if (dialog) {
    report.knowledge = dialog->office_plog;
    knowledge = check.load(dialog->office_plog, [&] {
      return plog::parseProgram(readFile(dialog->office_plog), dialog->office_plog);
    });
  }
  // The sorts the dialog's requests are made of: item, room, person.
  std::optional<std::vector<std::string>> sorts[3];
  const char* const kSorts[3] = {"item", "room", "person"};
  if (knowledge) {
    for (int s = 0; s < 3; ++s) {
      sorts[s] = sortValues(*knowledge, kSorts[s]);
      if (!sorts[s])
        check.add(report.knowledge, std::string("sort ") + kSorts[s], "",
                  std::string("no sort '") + kSorts[s] + "': the dialog's requests are <item, "
                  "room, person>");
    }
  }
  // The speech model (config/dialog.plog) hears a wrong answer as another value of the sort.
  for (int s = 0; s < 3; ++s) {
    if (!sorts[s] || sorts[s]->size() >= 2) continue;
    check.add(report.knowledge, std::string("sort ") + kSorts[s], join(*sorts[s]),
              std::string("the dialog needs at least two values of each of item, room and "
                          "person (a misheard answer is another value of the sort); sort '") +
                  kSorts[s] + "' has " + std::to_string(sorts[s]->size()) +
                  (sorts[s]->empty() ? "" : ": '" + join(*sorts[s]) + "'"));
  }
  const auto& rooms = sorts[1];
  if (rooms) report.rooms = *rooms;

  // 2 (first, so that rule 1 can leave the shop out of the places that are no rooms).
  if (dialog || !files.shop.empty()) {
    const bool flag = !files.shop.empty();
    report.shop = flag ? files.shop : dialog->shop;
    if (places && !contains(report.places, report.shop)) {
      check.add(flag ? files.shop_source : files.dialog_config, flag ? "" : "navigation.shop",
                report.shop,
                "'" + report.shop + "' is not a place of " + report.places_file + " (places: " +
                    join(report.places) + ")");
    }
  }

  // 1. Every room of the knowledge has a place to drive to.
  if (rooms && places) {
    std::vector<std::string> noRoom;
    for (const std::string& p : report.places)
      if (!contains(*rooms, p) && p != report.shop) noRoom.push_back(p);
    for (const std::string& r : *rooms) {
      if (contains(report.places, r)) continue;
      check.add(report.places_file, "places", r,
                "no place '" + r + "' for the room of that name in " + report.knowledge +
                    " (sort room)" +
                    (noRoom.empty() ? "" : "; places that are no room: " + join(noRoom)));
    }
  }

  // 3. Per-area simulator settings name blocking areas of the map.
  if (nav && places) {
    for (const auto& area : nav->simulator.areas) {
      if (contains(report.areas, area.first)) continue;
      check.add(files.navigation_config, files.areas_field + "." + area.first, area.first,
                "'" + area.first + "' is not a blocking area of " + report.places_file +
                    " (blocking areas: " + (report.areas.empty() ? "none" : join(report.areas)) +
                    ")");
    }
  }

  // 4. Every synonym names a value of the knowledge; all stale ones are listed.
  const auto language = check.load(files.language_config, [&] {
    return dialog::loadLanguageConfig(files.language_config);
  });
  if (language) report.synonyms = language->synonyms.size();
  if (language && sorts[0] && sorts[1] && sorts[2]) {
    std::set<std::string> values;
    std::vector<std::string> names;
    for (const auto& sort : sorts)
      for (const std::string& v : *sort) {
        values.insert(lower(v));
        names.push_back(v);
      }
    bool stale = false;
    for (const auto& [phrase, target] : language->synonyms) {
      if (values.count(lower(target))) continue;
      stale = true;
      check.add(files.language_config, "synonyms." + phrase, target,
                "'" + target + "' is no item, room or person of " + report.knowledge +
                    " (its names: " + join(names) + ")");
    }
    // What else the dialog's front end refuses (a phrase with two meanings), as it would.
    if (!stale) {
      check.load(files.language_config, [&] {
        return dialog::LanguageFrontEnd(*sorts[0], *sorts[1], *sorts[2], *language,
                                        files.language_config)
            .lexiconSize();
      });
    }
  }

  // 5. The reasoner loads the dialog's knowledge.
  std::optional<std::vector<std::string>> domainFiles = files.reasoner_domain_files;
  if (!domainFiles && !files.reasoner_config.empty())
    domainFiles = reasonerDomainFiles(files, check);
  if (dialog && domainFiles) {
    const std::string office = resolved(dialog->office_plog);
    bool found = false;
    for (const std::string& f : *domainFiles)
      found = found || resolved(against(files.root, f)) == office;
    if (!found) {
      const std::string file =
          !files.reasoner_domain_files ? files.reasoner_config
          : files.reasoner_source.empty() ? std::string("reasoner parameters")
                                          : files.reasoner_source;
      const std::string value = "[" + join(*domainFiles) + "]";
      const std::string base = files.root.empty() ? "" : " (resolved against " + files.root + ")";
      check.add(file, "domain_files", value,
                "value '" + value + "'" + base +
                    " does not include " + files.dialog_config + "'s knowledge.office " + office +
                    ": the reasoner and the dialog would reason about different buildings");
    }
  }
  return report;
}

SiteReport requireConsistentSite(const SiteFiles& files) {
  SiteReport report = checkSite(files);
  if (!report.consistent()) throw InconsistentSiteError(report.findings);
  return report;
}

}  // namespace site
}  // namespace krr
