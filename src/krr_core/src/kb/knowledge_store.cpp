#include "krr_core/kb/knowledge_store.h"

#include <algorithm>
#include <ctime>
#include <filesystem>
#include <set>
#include <system_error>

#include "krr_core/common/errors.h"
#include "krr_core/common/files.h"
#include "krr_core/common/journal.h"
#include "krr_core/plog/grounder.h"

namespace krr {
namespace kb {

namespace {

bool blank(const std::string& s) { return s.find_first_not_of(" \t\r\n") == std::string::npos; }

/// @brief Move a file that cannot be used to "<path>.corrupt-<UTC time>", out of the way but
/// kept for inspection, and record it with the error that made it unusable.
void setAside(const std::string& path, const std::exception& e, StartReport& report) {
  char stamp[32];
  const std::time_t now = std::time(nullptr);
  std::strftime(stamp, sizeof(stamp), "%Y%m%dT%H%M%S", std::gmtime(&now));
  StartReport::SetAside s;
  s.path = path;
  s.aside = path + ".corrupt-" + stamp;
  s.error = std::current_exception();
  s.why = e.what();
  std::error_code ec;
  std::filesystem::rename(path, s.aside, ec);
  if (ec) s.aside.clear();
  report.set_aside.push_back(std::move(s));
}

}  // namespace

bool KnowledgeUpdate::hasAreas() const { return !blank(area_statements); }
bool KnowledgeUpdate::hasStatements() const { return !blank(statements); }

KnowledgeStore::KnowledgeStore(KnowledgeStoreOptions options,
                               std::shared_ptr<const nav::NavGrid> grid,
                               std::vector<std::string> navigation_files)
    : options_(std::move(options)),
      grid_(std::move(grid)),
      navigation_files_(std::move(navigation_files)) {
  if (options_.domain_files.empty())
    throw ConfigError("knowledge store: at least one domain P-log file is required");
  if (options_.learned_file.empty() || options_.domain_learned_file.empty() ||
      options_.learned_file == options_.domain_learned_file)
    throw ConfigError("knowledge store: the learned file '" + options_.learned_file +
                      "' and the added-statements file '" + options_.domain_learned_file +
                      "' must be two non-empty, different paths");
  if (!grid_) throw ConfigError("knowledge store: no navigation grid");
  for (const std::string& f : options_.domain_files) domain_texts_.emplace_back(f, readFile(f));
}

KnowledgeStore::Opened KnowledgeStore::open() {
  Opened o;
  try {
    o.report.journal_files = FileTransaction::recover(journalPath());
  } catch (const ParseError& e) {
    setAside(journalPath(), e, o.report);  // torn or foreign: nothing of it is trusted
  }
  for (const std::string& f : {options_.learned_file, options_.domain_learned_file})
    for (std::string& orphan : removeOrphanTemporaries(dirName(f)))
      o.report.orphans.push_back(std::move(orphan));
  o.domain = loadDomainKb(o.state, o.report);
  o.nav = loadNavigationKb(o.state, o.report);
  times_ = o.nav->reasoner().sortValues("time");
  return o;
}

std::unique_ptr<plog::Reasoner> KnowledgeStore::buildDomainKb(const std::string& added) const {
  auto kb = std::make_unique<plog::Reasoner>();
  kb->setLimits(options_.limits);
  kb->setBackend(options_.backend);
  kb->loadString(domain_texts_.front().second, domain_texts_.front().first);
  for (std::size_t i = 1; i < domain_texts_.size(); ++i)
    kb->addStatements(domain_texts_[i].second, "", domain_texts_[i].first);
  if (!added.empty()) kb->addStatements(added, "added", options_.domain_learned_file);
  return kb;
}

std::unique_ptr<NavigationKnowledge> KnowledgeStore::buildNavigationKb(
    const std::string& learned) const {
  auto nav = std::make_unique<NavigationKnowledge>(*grid_, navigation_files_);
  nav->reasoner().setLimits(options_.limits);
  nav->reasoner().setBackend(options_.backend);
  if (!learned.empty()) nav->loadLearnedText(learned, options_.learned_file);
  return nav;
}

std::unique_ptr<plog::Reasoner> KnowledgeStore::loadDomainKb(KnowledgeState& state,
                                                             StartReport& report) const {
  const std::string& file = options_.domain_learned_file;
  if (std::filesystem::exists(file)) {
    const std::string added = readFile(file);
    try {
      auto with = buildDomainKb("");
      state.num_added = with->addStatements(added, "added", file);
      with->answerProgramQueries();
      state.added_text = added;
      return with;
    } catch (const Error& e) {
      setAside(file, e, report);
      state.num_added = 0;
    }
  }
  return buildDomainKb("");
}

std::unique_ptr<NavigationKnowledge> KnowledgeStore::loadNavigationKb(KnowledgeState& state,
                                                                      StartReport& report) const {
  const std::string& file = options_.learned_file;
  if (std::filesystem::exists(file)) {
    try {
      auto nav = buildNavigationKb(readFile(file));
      nav->buildModel({});  // a file that loads but gives no model is as unusable
      state.learned_text = nav->learnedText();
      state.total_learned = nav->learnedEntries().size();
      return nav;
    } catch (const Error& e) {
      setAside(file, e, report);
    }
  }
  state.learned_text.clear();
  state.total_learned = 0;
  return buildNavigationKb("");
}

std::unique_ptr<plog::Reasoner> KnowledgeStore::checkStatements(const KnowledgeUpdate& update,
                                                                const KnowledgeState& state,
                                                                const PhaseLimits& limits,
                                                                std::size_t& added) const {
  const std::string tag = "update" + std::to_string(++updates_);
  const std::string where = "<update from " + update.source + ">";
  // On a new copy: no KB in use is touched by statements that are refused.
  auto kb = buildDomainKb(state.added_text);
  kb->setLimits(limits("the statements' check"));
  added = kb->addStatements(update.statements, tag, where);
  try {
    kb->answerProgramQueries();
  } catch (const plog::BudgetExceededError&) {
    throw;
  } catch (const Error& e) {
    throw IncoherentError(std::string("the statements make the domain knowledge base "
                                      "incoherent: ") + e.what());
  }
  // The KB's own queries may not reach the new statements (relevance cone), so the whole
  // program is ground once under the budget: a runaway rule is refused here instead of failing
  // every later query that touches it.
  std::set<std::string> all;
  for (const auto& a : kb->program().attributes) all.insert(a.name);
  try {
    plog::groundProgram(kb->program(), all, limits("grounding the statements"));
  } catch (const plog::BudgetExceededError&) {
    throw;
  } catch (const Error&) {
    // outside the native grounder's fragment: the query check above decides
  }
  kb->setLimits(options_.limits);
  return kb;
}

PreparedUpdate KnowledgeStore::prepare(const KnowledgeUpdate& update, const KnowledgeState& state,
                                       const ScratchNavigation& scratch,
                                       const PhaseLimits& limits) const {
  const bool areas = update.hasAreas();
  if (update.pairs.empty() && !areas && !update.hasStatements())
    throw ConfigError("the update holds neither atoms, area knowledge nor statements");
  auto isTime = [&](const std::string& t) {
    return std::find(times_.begin(), times_.end(), t) != times_.end();
  };
  if (areas && !isTime(update.area_time))
    throw ConfigError("area_time '" + update.area_time + "' is not a time of day of the "
                      "navigation knowledge base");
  for (const auto& entry : update.pairs)
    if (!isTime(entry.first))
      throw UnknownSymbolError("learned pairs for time '" + entry.first +
                               "': not a value of sort time");
  PreparedUpdate p;
  p.statements = update.hasStatements();
  p.navigation = update.changesNavigation();
  p.added_text = state.added_text;
  if (p.statements) {
    p.domain = checkStatements(update, state, limits, p.statements_added);
    p.added_text += "% added by " + (update.source.empty() ? "?" : update.source) + "\n" +
                    update.statements + "\n";
  }
  p.learned_text = state.learned_text;
  p.total_learned = state.total_learned;
  if (p.navigation) {
    NavigationKnowledge& nav = scratch();
    nav.reasoner().setLimits(limits("applying the learned knowledge"));
    for (const auto& [time, list] : update.pairs) p.atoms_added += nav.addLearned(list, time);
    if (areas) nav.setLearnedAreas(update.area_time, update.area_statements);
    nav.reasoner().setLimits(options_.limits);
    p.learned_text = nav.learnedText();
    p.total_learned = nav.learnedEntries().size();
  }
  return p;
}

KnowledgeState KnowledgeStore::commit(const PreparedUpdate& update, const KnowledgeState& state,
                                      std::string* restore_error) const {
  const std::string& learned = options_.learned_file;
  const std::string& added = options_.domain_learned_file;
  try {
    makeDirectories(dirName(learned));
    makeDirectories(dirName(added));
    FileTransaction t(journalPath());
    t.write(learned, update.learned_text);
    if (update.statements) t.write(added, update.added_text);
    t.commit();
  } catch (...) {
    // The old contents back, through a journal of their own (it replaces the update's).
    try {
      FileTransaction undo(journalPath());
      undo.write(learned, state.learned_text);
      if (update.statements) undo.write(added, state.added_text);
      undo.commit();
    } catch (const std::exception& e) {
      if (restore_error) *restore_error = e.what();
    }
    throw;
  }
  KnowledgeState next = state;
  next.added_text = update.added_text;
  next.num_added += update.statements_added;
  next.learned_text = update.learned_text;
  next.total_learned = update.total_learned;
  if (update.statements) ++next.domain_version;
  if (update.navigation) ++next.nav_version;
  return next;
}

}  // namespace kb
}  // namespace krr
