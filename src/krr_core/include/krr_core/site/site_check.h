/**
 * @file site_check.h
 * @brief The site consistency check: the names a building's configuration repeats across its
 * files must agree, checked before anything is written or started.
 *
 * A site's names (rooms, the shop, blocking areas, people, items) are written in several files
 * the stack already reads: the navigation config (config/navigation.yaml) and the places file
 * it names, the dialog config (config/dialog.yaml) and the knowledge its knowledge.office names
 * (config/office.plog), the language file (config/language.yaml) and the reasoner node's
 * domain_files (config/reasoner_node.yaml). A name changed in one file and not in another used
 * to surface late and one at a time: the reasoner silently loading another building's
 * knowledge, a query failing with "unknown value", a stale blocking area in the simulator, one
 * stale synonym per run. checkSite() reads them all and reports every disagreement at once:
 *
 *  1. rooms: every value of the knowledge's `room` sort has a place in the places file (the
 *     robot must be able to drive there); the message lists the places that are no rooms
 *     (besides the shop), where a renamed room usually hides;
 *  2. shop: the dialog config's navigation.shop (or the shop given on the command line) is a
 *     place of the places file: every delivery starts there;
 *  3. blocking areas: every key of the navigation config's simulator.areas is a blocking area
 *     of the places file (an override of an area the map lacks is another building's);
 *  4. synonyms: every synonym target of the language file is an item, room or person of the
 *     knowledge (case-insensitive, as the language front end reads them), all stale ones
 *     listed; and the front end builds from the file and the knowledge;
 *  5. knowledge: the reasoner's domain_files, when given, include the dialog's
 *     knowledge.office, compared as resolved paths, so the reasoner and the dialog reason about
 *     the same building (not given: the reasoner loads knowledge.office itself);
 *  6. sorts: the knowledge has at least two values of each of item, room and person (the
 *     speech model, config/dialog.plog, hears a misheard answer as another value of the sort;
 *     with one value its probabilities would not sum to 1).
 *
 * A file that cannot be read is a finding too, and the rules that need it are skipped.
 * Every finding names the file, the field and the value.
 *
 * A node checks at start with the files it was given (its parameters win over the defaults;
 * the nodes' one helper is krr_ros/site_check.h):
 * @code
 *   krr::site::SiteFiles files = krr::site::SiteFiles::inConfigDir(base_dir + "/config");
 *   files.navigation_config = params.navigation_config;  // every node
 *   files.dialog_config = params.dialog_config;      // dialog_node
 *   files.language_config = params.language_config;  // dialog_node
 *   files.reasoner_domain_files = params.domain_files;  // reasoner_node (resolved paths)
 *   krr::site::requireConsistentSite(files);  // throws one ConfigError listing every finding
 * @endcode
 */
#pragma once

#include <optional>
#include <string>
#include <vector>

#include "krr_core/common/errors.h"
#include "krr_core/dialog/dialog_config.h"
#include "krr_core/nav/nav_grid.h"
#include "krr_core/nav/navigation_config.h"

namespace krr {
namespace site {

/// @brief The files a site's names are read from, as the stack's programs and nodes read them.
struct SiteFiles {
  std::string navigation_config;  ///< navigation.yaml: names the map and the places file
  std::string dialog_config;      ///< dialog.yaml: navigation.shop, knowledge.office
  std::string language_config;    ///< language.yaml: synonyms
  /// reasoner_node.yaml whose domain_files the reasoner loads ("" when reasoner_domain_files
  /// is given or the reasoner is not checked).
  std::string reasoner_config;
  /// The directory the reasoner resolves relative domain_files against (its ~base_dir: the
  /// repository root).
  std::string root;
  /// The reasoner's domain_files as a running node has them (its parameters, resolved),
  /// instead of reading reasoner_config: the launch file may have overridden the file's.
  std::optional<std::vector<std::string>> reasoner_domain_files;
  /// What a finding on reasoner_domain_files names as its file (a node: "parameters of
  /// /reasoner"); "" = "reasoner parameters".
  std::string reasoner_source;
  /// The shop given on the command line (e.g. make_nav_domain --shop), instead of the dialog
  /// config's; `shop_source` names where it came from ("option --shop").
  std::string shop;
  std::string shop_source;
  /// The navigation and dialog configs already loaded (a site folder's, site.h: the base
  /// configs with the site's names), instead of loading navigation_config / dialog_config;
  /// those paths still name them in messages.
  std::optional<nav::NavigationConfig> navigation;
  std::optional<dialog::DialogConfig> dialog;
  /// The field of navigation_config holding the per-area overrides (a site.yaml's: "areas").
  std::string areas_field = "simulator.areas";

  /**
   * @brief The files of a configuration directory laid out as the repository's config/:
   * navigation.yaml, dialog.yaml, language.yaml and reasoner_node.yaml in `config_dir`, the
   * root its parent (reasoner_node.yaml's paths are relative to the repository root).
   */
  static SiteFiles inConfigDir(const std::string& config_dir);
};

/// @brief One disagreement: what to edit (file, field) and the value found there.
struct Finding {
  std::string file;     ///< the file to fix
  std::string field;    ///< the field in it ("places", "synonyms.office6", "navigation.shop")
  std::string value;    ///< the value found there
  std::string message;  ///< what is wrong, naming the value and the file it disagrees with
  /// @brief "file: field 'field': message", the format of the loaders' errors.
  std::string str() const;
};

/// @brief What checkSite() read and found: the names for a summary, and the findings.
struct SiteReport {
  std::string knowledge;            ///< the dialog's knowledge.office (resolved)
  std::string places_file;          ///< the places file of the navigation config
  std::vector<std::string> rooms;   ///< the knowledge's room sort
  std::vector<std::string> places;  ///< the places file's places
  std::vector<std::string> areas;   ///< the places file's blocking areas
  std::string shop;                 ///< the shop checked
  std::size_t synonyms = 0;         ///< synonyms of the language file
  std::vector<Finding> findings;    ///< every disagreement, in rule order

  bool consistent() const { return findings.empty(); }
  /// @brief One line for a consistent site: what was checked and the names it agreed on.
  std::string summary() const;
};

/// @brief An inconsistent site: a ConfigError whose what() lists every finding, one per line,
/// with the findings kept for callers that present them otherwise.
class InconsistentSiteError : public ConfigError {
 public:
  explicit InconsistentSiteError(std::vector<Finding> findings);
  const std::vector<Finding>& findings() const { return findings_; }

 private:
  std::vector<Finding> findings_;
};

/// @brief Read the site's files and apply every rule of the file comment; never throws for
/// the site's content (unreadable files are findings).
SiteReport checkSite(const SiteFiles& files);

/**
 * @brief The check a program or node runs before it writes or starts anything: checkSite(),
 * and one error listing every finding when there is any.
 * @return the report of a consistent site (for a summary line or a log message).
 * @throws InconsistentSiteError (a krr::ConfigError) listing all findings.
 */
SiteReport requireConsistentSite(const SiteFiles& files);

}  // namespace site
}  // namespace krr
