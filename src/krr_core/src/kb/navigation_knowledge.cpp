#include "krr_core/kb/navigation_knowledge.h"

#include <algorithm>
#include <cmath>
#include <set>
#include <sstream>

#include "krr_core/common/errors.h"
#include "krr_core/common/files.h"
#include "krr_core/plog/parser.h"

namespace krr {
namespace kb {

namespace {

const char* const kMoveNames[4] = {"up", "down", "left", "right"};

int moveIndex(const std::string& name) {
  for (int m = 0; m < 4; ++m)
    if (name == kMoveNames[m]) return m;
  return -1;
}

/// @brief Exact fractions k_i/d of a distribution estimated from counts; the k_i sum to d, so
/// the written pr-atoms sum to exactly 1 and never trip the reasoner's coherence check.
std::vector<long> toFractions(const std::vector<double>& p, std::uint32_t samples, long* denom) {
  std::vector<long> k;
  auto fits = [&](long d) {
    k.assign(p.size(), 0);
    long sum = 0;
    for (size_t i = 0; i < p.size(); ++i) {
      k[i] = std::lround(p[i] * static_cast<double>(d));
      if (std::fabs(static_cast<double>(k[i]) / static_cast<double>(d) - p[i]) > 1e-9) return false;
      sum += k[i];
    }
    return sum == d;
  };
  if (samples > 0 && fits(samples)) {
    *denom = samples;
    return k;
  }
  for (long d = 1; d <= 1000; ++d) {
    if (fits(d)) {
      *denom = d;
      return k;
    }
  }
  // Not a ratio of small counts: millionths, the largest outcome absorbing the remainder.
  const long d = 1000000;
  k.assign(p.size(), 0);
  long sum = 0;
  size_t big = 0;
  for (size_t i = 0; i < p.size(); ++i) {
    k[i] = std::lround(p[i] * static_cast<double>(d));
    sum += k[i];
    if (p[i] > p[big]) big = i;
  }
  k[big] += d - sum;
  *denom = d;
  return k;
}

std::string termText(const plog::Term& t) { return plog::toString(t); }

}  // namespace

// ---------------------------------------------------------------------------------------------
NavStateSpace::NavStateSpace(const nav::NavGrid& grid)
    : grid_(std::make_shared<nav::NavGrid>(grid)),
      cells_(grid.freeCells()),
      state_of_cell_(static_cast<size_t>(grid.numCells()), -1) {
  for (size_t s = 0; s < cells_.size(); ++s)
    state_of_cell_[static_cast<size_t>(cells_[s])] = static_cast<std::int32_t>(s);
}

mdp::StateId NavStateSpace::stateOf(int cell) const {
  if (cell < 0 || cell >= grid_->numCells() || state_of_cell_[static_cast<size_t>(cell)] < 0)
    throw UnknownSymbolError("cell " + std::to_string(cell) +
                             " is not a free cell of the navigation grid");
  return static_cast<mdp::StateId>(state_of_cell_[static_cast<size_t>(cell)]);
}

std::size_t NavModel::numLearned() const {
  return static_cast<std::size_t>(std::count(learned.begin(), learned.end(), 1));
}

// ---------------------------------------------------------------------------------------------
NavigationKnowledge::NavigationKnowledge(const nav::NavGrid& grid,
                                         const std::vector<std::string>& knowledge_files)
    : space_(grid) {
  if (knowledge_files.empty()) throw ConfigError("navigation knowledge: no P-log files given");
  reasoner_.loadFile(knowledge_files.front());
  for (size_t i = 1; i < knowledge_files.size(); ++i)
    reasoner_.addStatements(readFile(knowledge_files[i]), "", knowledge_files[i]);

  const plog::Program& prog = reasoner_.program();
  for (const char* attr : {"curr_cell", "next_cell", "act_move", "curr_time", "learned"}) {
    if (!prog.findAttribute(attr))
      throw ConfigError("navigation knowledge: the program does not declare attribute '" +
                        std::string(attr) + "' (files: " + knowledge_files.front() + " ...)");
  }
  // The cell sort must be exactly the grid's free cells: otherwise states and P-log cells
  // would silently disagree.
  std::vector<std::string> cells = reasoner_.sortValues("cell");
  std::vector<int> free = grid.freeCells();
  if (cells.size() != free.size())
    throw ConfigError("navigation knowledge: sort cell has " + std::to_string(cells.size()) +
                      " values but the grid has " + std::to_string(free.size()) +
                      " free cells (geometry generated for another grid?)");
  for (size_t i = 0; i < cells.size(); ++i) {
    if (cells[i] != std::to_string(free[i]))
      throw ConfigError("navigation knowledge: sort cell value '" + cells[i] +
                        "' is not free cell " + std::to_string(free[i]) + " of the grid");
  }
  std::vector<std::string> moves = reasoner_.sortValues("move");
  for (const std::string& m : moves)
    if (moveIndex(m) < 0) throw ConfigError("navigation knowledge: unknown move '" + m + "'");
  times_ = reasoner_.sortValues("time");

  // Prototypes of the learned statements, parsed once against the program's declarations;
  // extraction copies them with other ground values instead of parsing text every time.
  for (const char* sort : {"loc", "move", "time"}) {
    const plog::SortDecl* sd = prog.findSort(sort);
    if (!sd) throw ConfigError(std::string("navigation knowledge: the program does not declare sort '") +
                               sort + "'");
    for (const plog::Term& t : sd->values) terms_.emplace(plog::toString(t), t);
  }
  if (!cells.empty() && !moves.empty() && !times_.empty()) {
    plog::Program decls;
    decls.dialect = prog.dialect;
    decls.sorts = prog.sorts;
    decls.attributes = prog.attributes;
    decls.domains = prog.domains;
    const std::string c = cells.front(), m = moves.front(), t = times_.front();
    plog::parseInto(decls,
                    "pr(next_cell=" + c + " | curr_cell=" + c + ", act_move=" + m +
                        ", curr_time=" + t + ") = 1/2.\nlearned(" + c + ", " + m + ", " + t + ").\n",
                    "<learned>");
    bool ok = decls.pr_atoms.size() == 1 && decls.rules.size() == 1 &&
              decls.pr_atoms[0].body.size() == 3 && decls.rules[0].head &&
              decls.rules[0].head->attr.args.size() == 3 && decls.rules[0].body.empty();
    for (size_t i = 0; ok && i < 3; ++i) ok = decls.pr_atoms[0].body[i].kind == plog::Literal::Kind::Atom;
    if (!ok)
      throw ConfigError("navigation knowledge: learned statements do not parse into the expected "
                        "shape (check the declarations of next_cell and learned)");
    pr_proto_ = decls.pr_atoms[0];
    fact_proto_ = decls.rules[0];
  }
}

const plog::Term& NavigationKnowledge::valueTerm(const std::string& value) {
  auto it = terms_.find(value);
  if (it != terms_.end()) return it->second;
  // Not a declared value (the reasoner will ignore the statement, as it would the text).
  const bool integer = !value.empty() && value.find_first_not_of("0123456789") == std::string::npos;
  plog::Term t = integer ? plog::Term::integer(std::stoll(value)) : plog::Term::symbol(value);
  return terms_.emplace(value, t).first->second;
}

void NavigationKnowledge::appendPrAtoms(const std::tuple<int, int, std::string>& key,
                                        const LearnedDistribution& d,
                                        std::vector<plog::PrAtom>& out) {
  const auto& [cell, move, time] = key;
  const std::string cell_text = std::to_string(cell);
  for (const auto& [value, k] : d.outcomes) {
    plog::PrAtom p = pr_proto_;
    p.atom.value = valueTerm(value);
    for (plog::Literal& l : p.body) {
      const std::string& n = l.atom.attr.name;
      if (n == "curr_cell") l.atom.value = valueTerm(cell_text);
      else if (n == "act_move") l.atom.value = valueTerm(kMoveNames[move]);
      else if (n == "curr_time") l.atom.value = valueTerm(time);
    }
    p.probability = static_cast<double>(k) / static_cast<double>(d.denominator);
    p.probability_text = std::to_string(k) + "/" + std::to_string(d.denominator);
    p.loc = {"<learned>", static_cast<int>(++learned_line_), 1};
    out.push_back(std::move(p));
  }
}

plog::Rule NavigationKnowledge::learnedFact(const std::tuple<int, int, std::string>& key) {
  const auto& [cell, move, time] = key;
  plog::Rule r = fact_proto_;
  r.head->attr.args[0] = valueTerm(std::to_string(cell));
  r.head->attr.args[1] = valueTerm(kMoveNames[move]);
  r.head->attr.args[2] = valueTerm(time);
  r.loc = {"<learned>", static_cast<int>(++learned_line_), 1};
  return r;
}

void NavigationKnowledge::updateLearned(const LearnedMap& updates,
                                        std::vector<plog::PrAtom> old_prs,
                                        std::vector<plog::Rule> old_facts) {
  std::vector<plog::PrAtom> new_prs;
  std::vector<plog::Rule> facts;
  for (const auto& [key, d] : updates) {
    auto it = learned_.find(key);
    if (it != learned_.end()) {
      if (it->second == d) continue;  // nothing new
      appendPrAtoms(key, it->second, old_prs);
      it->second = d;
    } else {
      learned_.emplace(key, d);
      facts.push_back(learnedFact(key));
    }
    appendPrAtoms(key, d, new_prs);
  }
  // Re-learned pairs: their old outcomes go (keeping one would make the sum exceed 1).
  if (!old_prs.empty() || !old_facts.empty()) reasoner_.removeStatements(old_facts, old_prs);
  if (!new_prs.empty() || !facts.empty())
    reasoner_.addStatements(std::move(facts), std::move(new_prs), kLearnedTag);
}

std::string NavigationKnowledge::evidenceFor(const std::vector<std::string>& times) const {
  for (const std::string& t : times) {
    if (std::find(times_.begin(), times_.end(), t) == times_.end())
      throw UnknownSymbolError("time '" + t + "' is not a value of sort time");
  }
  if (times.empty() || times.size() == times_.size()) return "";
  if (times.size() == 1) return "obs(curr_time=" + times.front() + ")";
  // Several possible times: observe that it is none of the others.
  std::string ev;
  for (const std::string& t : times_) {
    if (std::find(times.begin(), times.end(), t) != times.end()) continue;
    ev += (ev.empty() ? "" : ", ") + std::string("obs(curr_time=") + t + ", false)";
  }
  return ev;
}

NavModel NavigationKnowledge::buildModel(const std::vector<std::string>& times, double discount) {
  const std::string evidence = evidenceFor(times);
  const std::vector<std::string>& ctx = times.empty() ? times_ : times;

  plog::Table table = reasoner_.tableQuery("next_cell", {"curr_cell", "act_move"}, evidence);

  const std::size_t S = space_.numStates(), A = space_.numActions();
  mdp::SparseModelBuilder builder(S, A, discount);
  std::vector<std::uint8_t> filled(S * A, 0);
  for (const plog::TableRow& row : table.rows) {
    const int cell = std::stoi(row.conditioning_values.at(0));
    const int move = moveIndex(row.conditioning_values.at(1));
    const mdp::StateId s = space_.stateOf(cell);
    if (!row.consistent || row.distribution.empty())
      throw IncoherentError("navigation knowledge: no distribution of next_cell for curr_cell=" +
                            row.conditioning_values[0] + ", act_move=" +
                            row.conditioning_values[1] + (evidence.empty() ? "" : " given " + evidence));
    double total = 0;
    for (const plog::ValueProb& vp : row.distribution) total += vp.probability;
    for (const plog::ValueProb& vp : row.distribution) {
      const mdp::StateId s1 = vp.value == "trapped" ? space_.trappedState()
                                                    : space_.stateOf(std::stoi(vp.value));
      builder.addTransition(s, static_cast<mdp::ActionId>(move), s1, vp.probability / total);
    }
    filled[s * A + static_cast<size_t>(move)] = 1;
  }
  builder.setTerminal(space_.trappedState());
  for (mdp::StateId s = 0; s + 1 < S; ++s)
    for (size_t a = 0; a < A; ++a)
      if (!filled[s * A + a])
        throw IncoherentError("navigation knowledge: table query gave no row for cell " +
                              std::to_string(space_.cellOf(s)) + ", move " + kMoveNames[a]);

  NavModel model{builder.build(), std::vector<std::uint8_t>(S * A, 0)};
  for (mdp::StateId s = 0; s + 1 < S; ++s) {
    for (int a = 0; a < 4; ++a) {
      bool all = true;
      for (const std::string& t : ctx)
        all = all && learned_.count(std::make_tuple(space_.cellOf(s), a, t)) > 0;
      model.learned[s * A + static_cast<size_t>(a)] = all ? 1 : 0;
    }
  }
  return model;
}

std::size_t NavigationKnowledge::replaceLearned(const std::vector<mdp::KnownPair>& pairs,
                                                const std::string& time) {
  LearnedMap updates;
  const std::size_t written = learnedDistributions(pairs, time, updates);
  // Pairs of this time that are no longer learned go, with their learned(C, M, T) fact; pairs
  // learned again with the same distribution stay untouched (no grounding or row to redo).
  std::vector<plog::PrAtom> old_prs;
  std::vector<plog::Rule> old_facts;
  for (auto it = learned_.begin(); it != learned_.end();) {
    if (std::get<2>(it->first) == time && !updates.count(it->first)) {
      appendPrAtoms(it->first, it->second, old_prs);
      old_facts.push_back(learnedFact(it->first));
      it = learned_.erase(it);
    } else {
      ++it;
    }
  }
  updateLearned(updates, std::move(old_prs), std::move(old_facts));
  return written;
}

std::size_t NavigationKnowledge::learnedPairCount(const std::string& time) const {
  if (time.empty()) return learned_.size();
  std::size_t n = 0;
  for (const auto& kv : learned_) n += std::get<2>(kv.first) == time ? 1 : 0;
  return n;
}

std::size_t NavigationKnowledge::addLearned(const std::vector<mdp::KnownPair>& pairs,
                                            const std::string& time) {
  LearnedMap updates;
  const std::size_t written = learnedDistributions(pairs, time, updates);
  updateLearned(updates);
  return written;
}

std::size_t NavigationKnowledge::learnedDistributions(const std::vector<mdp::KnownPair>& pairs,
                                                      const std::string& time,
                                                      LearnedMap& updates) const {
  if (std::find(times_.begin(), times_.end(), time) == times_.end())
    throw UnknownSymbolError("time '" + time + "' is not a value of sort time");
  std::size_t written = 0;
  for (const mdp::KnownPair& kp : pairs) {
    if (kp.from_prior || kp.distribution.empty()) continue;
    const int cell = space_.cellOf(kp.state);
    if (cell < 0 || kp.action >= 4) continue;  // trapped / optimistic states have no dynamics
    std::vector<double> p;
    for (const mdp::Outcome& o : kp.distribution) p.push_back(o.probability);
    long denom = 1;
    std::vector<long> k = toFractions(p, kp.samples, &denom);
    LearnedDistribution d;
    d.denominator = denom;
    for (size_t i = 0; i < kp.distribution.size(); ++i) {
      if (k[i] == 0) continue;
      const mdp::StateId s1 = kp.distribution[i].state;
      const int c1 = space_.cellOf(s1);
      if (s1 != space_.trappedState() && c1 < 0)
        throw ConfigError("knowledge extraction: outcome state " + std::to_string(s1) +
                          " of cell " + std::to_string(cell) + " is outside the state space");
      d.outcomes.emplace_back(c1 < 0 ? "trapped" : std::to_string(c1), k[i]);
    }
    updates[std::make_tuple(cell, static_cast<int>(kp.action), time)] = std::move(d);
    ++written;
  }
  return written;
}

std::vector<NavigationKnowledge::LearnedEntry> NavigationKnowledge::learnedEntries() const {
  std::vector<LearnedEntry> out;
  out.reserve(learned_.size());
  for (const auto& [key, d] : learned_)
    out.push_back({std::get<0>(key), std::get<1>(key), std::get<2>(key), d.outcomes, d.denominator});
  return out;
}

namespace {
const char* const kAreaMarker = "% --- areas, time ";
std::string areaTag(const std::string& time) { return std::string(kLearnedTag) + "/areas/" + time; }
}  // namespace

void NavigationKnowledge::setLearnedAreas(const std::string& time, const std::string& statements) {
  if (std::find(times_.begin(), times_.end(), time) == times_.end())
    throw UnknownSymbolError("area knowledge for time '" + time + "', which sort time does not have");
  // Validate first (a refused update changes nothing): parse against a copy of the program.
  plog::Program scratch = reasoner_.program();
  plog::parseInto(scratch, statements, "<area knowledge, time " + time + ">");
  reasoner_.removeStatementsWithTag(areaTag(time));
  reasoner_.addStatements(statements, areaTag(time), "<area knowledge, time " + time + ">");
  areas_[time] = statements;
}

void NavigationKnowledge::clearLearned() {
  learned_.clear();
  reasoner_.removeStatementsWithTag(kLearnedTag);
  for (const auto& [time, text] : areas_) reasoner_.removeStatementsWithTag(areaTag(time));
  areas_.clear();
}

std::string NavigationKnowledge::learnedText() const {
  std::ostringstream o;
  o << "% Navigation knowledge learned by R-Max (written by knowledge extraction).\n"
    << "% pr(next_cell=X | curr_cell=C, act_move=M, curr_time=T) = k/n: outcome X seen k times\n"
    << "% in n tries of move M in cell C at time T; learned(C, M, T) switches off the human\n"
    << "% defaults of config/navigation.plog for that cell, move and time.\n";
  for (const auto& [key, d] : learned_) {
    const auto& [cell, move, time] = key;
    for (const auto& [value, k] : d.outcomes) {
      o << "pr(next_cell=" << value << " | curr_cell=" << cell << ", act_move=" << kMoveNames[move]
        << ", curr_time=" << time << ") = " << k << "/" << d.denominator << ".\n";
    }
    o << "learned(" << cell << ", " << kMoveNames[move] << ", " << time << ").\n";
  }
  for (const auto& [time, text] : areas_) o << kAreaMarker << time << " ---\n" << text;
  return o.str();
}

void NavigationKnowledge::saveLearned(const std::string& path) const {
  writeFileAtomic(path, learnedText());
}

void NavigationKnowledge::loadLearned(const std::string& path) {
  loadLearnedText(readFile(path), path);
}

void NavigationKnowledge::loadLearnedText(std::string text, const std::string& path) {
  // Area blocks come after the pairs, each after its marker line.
  std::vector<std::pair<std::string, std::string>> areaBlocks;
  for (std::size_t at = text.find(kAreaMarker); at != std::string::npos;) {
    const std::size_t lineEnd = text.find('\n', at);
    const std::string head = text.substr(at, lineEnd == std::string::npos ? std::string::npos : lineEnd - at);
    const std::size_t nameBegin = std::string(kAreaMarker).size();
    const std::size_t nameEnd = head.find(' ', nameBegin);
    const std::string time = head.substr(nameBegin, nameEnd == std::string::npos ? std::string::npos : nameEnd - nameBegin);
    const std::size_t next = lineEnd == std::string::npos ? std::string::npos : text.find(kAreaMarker, lineEnd);
    const std::size_t bodyBegin = lineEnd == std::string::npos ? text.size() : lineEnd + 1;
    areaBlocks.emplace_back(time, text.substr(bodyBegin, next == std::string::npos ? std::string::npos : next - bodyBegin));
    at = next;
  }
  if (const std::size_t first = text.find(kAreaMarker); first != std::string::npos) {
    // Keep the line count of the pairs part (errors name their lines); drop the area blocks.
    text.erase(first);
  }
  for (const auto& [time, block] : areaBlocks) {
    if (std::find(times_.begin(), times_.end(), time) == times_.end())
      throw ParseError({path, 1, 1}, "area knowledge for time '" + time + "', which sort time does not have");
    plog::Program scratch = reasoner_.program();
    plog::parseInto(scratch, block, path);
    if (scratch.random_rules.size() != reasoner_.program().random_rules.size() ||
        scratch.sorts.size() != reasoner_.program().sorts.size() ||
        scratch.attributes.size() != reasoner_.program().attributes.size())
      throw ParseError({path, 1, 1}, "area knowledge may only contain pr-atoms and "
                                     "learned_area / learned_noise facts");
  }
  // Parse in the context of the current program so names resolve, then check that every
  // statement has the shape extraction writes; anything else is an error naming its location.
  plog::Program scratch = reasoner_.program();
  const size_t pr0 = scratch.pr_atoms.size(), rule0 = scratch.rules.size();
  plog::parseInto(scratch, text, path);
  if (scratch.random_rules.size() != reasoner_.program().random_rules.size() ||
      scratch.sorts.size() != reasoner_.program().sorts.size() ||
      scratch.attributes.size() != reasoner_.program().attributes.size())
    throw ParseError({path, 1, 1}, "a learned-knowledge file may only contain pr-atoms for "
                                   "next_cell and learned(C, M, T) facts");
  LearnedMap loaded;
  std::set<std::tuple<int, int, std::string>> flagged;
  for (size_t i = rule0; i < scratch.rules.size(); ++i) {
    const plog::Rule& r = scratch.rules[i];
    if (!r.head || r.head->attr.name != "learned" || !r.body.empty() || r.head->attr.args.size() != 3)
      throw ParseError(r.loc, "expected a fact learned(Cell, Move, Time)");
    const auto& a = r.head->attr.args;
    flagged.insert(std::make_tuple(std::stoi(termText(a[0])), moveIndex(termText(a[1])),
                                   termText(a[2])));
  }
  std::map<std::tuple<int, int, std::string>, LearnedDistribution> fresh;
  for (size_t i = pr0; i < scratch.pr_atoms.size(); ++i) {
    const plog::PrAtom& p = scratch.pr_atoms[i];
    int cell = -1, move = -1;
    std::string time;
    for (const plog::Literal& l : p.body) {
      if (l.kind != plog::Literal::Kind::Atom || l.naf || l.negated) continue;
      const std::string n = l.atom.attr.name, v = termText(l.atom.value);
      if (n == "curr_cell") cell = std::stoi(v);
      else if (n == "act_move") move = moveIndex(v);
      else if (n == "curr_time") time = v;
    }
    if (p.atom.attr.name != "next_cell" || cell < 0 || move < 0 || time.empty() ||
        p.body.size() != 3)
      throw ParseError(p.loc, "expected pr(next_cell=X | curr_cell=C, act_move=M, curr_time=T) = k/n");
    // Probabilities are k/n fractions; keep them exact.
    long k = 0, n = 0;
    const std::string& txt = p.probability_text;
    const auto slash = txt.find('/');
    if (slash != std::string::npos) {
      k = std::stol(txt.substr(0, slash));
      n = std::stol(txt.substr(slash + 1));
    } else {
      n = 1000000;
      k = std::lround(p.probability * static_cast<double>(n));
    }
    LearnedDistribution& d = fresh[std::make_tuple(cell, move, time)];
    if (!d.outcomes.empty() && d.denominator != n)
      throw ParseError(p.loc, "pr-atoms of one cell, move and time must share a denominator");
    d.denominator = n;
    d.outcomes.emplace_back(termText(p.atom.value), k);
  }
  for (auto& [key, d] : fresh) {
    if (!flagged.count(key))
      throw ParseError({path, 1, 1}, "pr-atoms for curr_cell=" + std::to_string(std::get<0>(key)) +
                                         " without the matching learned(...) fact");
    space_.stateOf(std::get<0>(key));  // must be a free cell of this grid
    loaded[key] = std::move(d);
  }
  updateLearned(loaded);
  for (const auto& [time, block] : areaBlocks) setLearnedAreas(time, block);
}

}  // namespace kb
}  // namespace krr
