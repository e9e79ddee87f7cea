#include "krr_core/plog/reasoner.h"

#include <algorithm>
#include <unordered_map>

#include "krr_core/common/files.h"
#include "krr_core/common/resources.h"
#include "krr_core/plog/engine.h"
#include "krr_core/plog/grounder.h"
#include "krr_core/plog/parser.h"

namespace krr {
namespace plog {

namespace {

int attrIndex(const Program& p, const std::string& name) {
  for (size_t i = 0; i < p.attributes.size(); ++i)
    if (p.attributes[i].name == name) return static_cast<int>(i);
  return -1;
}

int domainIndex(const GroundProgram& g, int inst, const std::string& value) {
  const GInstance& gi = g.instances[static_cast<size_t>(inst)];
  for (size_t i = 0; i < gi.domain.size(); ++i)
    if (g.symbols->text(gi.domain[i]) == value) return static_cast<int>(i);
  return -1;
}

// Adds one ground literal to a condition (dynamic literal or constant truth).
void addLiteral(const GroundProgram& g, const Program& p, const Literal& l, GCondition& c) {
  if (l.kind != Literal::Kind::Atom) throw Error(l.loc.str() + ": comparison in a query condition");
  const std::string inst_name = toString(l.atom.attr);
  const std::string value = toString(l.atom.value);
  int a = attrIndex(p, l.atom.attr.name);
  if (a < 0) throw UnknownSymbolError(l.loc.str() + ": unknown attribute '" + l.atom.attr.name + "'");
  bool truth;
  if (g.attr_dynamic[static_cast<size_t>(a)]) {
    int inst = g.findInstance(inst_name);
    if (inst >= 0) {
      int vi = domainIndex(g, inst, value);
      c.lits.push_back(GLit{inst, vi, l.naf, l.negated});
      return;
    }
    truth = false;  // the instance never gets a value
  } else {
    std::string prefix = inst_name + "=";
    if (!l.negated) {
      truth = g.staticHolds(a, prefix + value);
    } else {
      truth = false;
      for (const auto& s : g.static_atoms[static_cast<size_t>(a)])
        if (s.compare(0, prefix.size(), prefix) == 0 && s != prefix + value) truth = true;
    }
  }
  if (l.naf) truth = !truth;
  if (!truth) c.constant = false;
}

void applyDo(const GroundProgram& g, const Program& p, const Intervention& d, ExactEngine& e) {
  int a = attrIndex(p, d.atom.attr.name);
  if (a < 0 || !g.attr_dynamic[static_cast<size_t>(a)])
    throw Error(d.loc.str() + ": do(" + toString(d.atom) +
                ") on an attribute that is neither random nor derived from random attributes "
                "is not supported by the native reasoner");
  int inst = g.findInstance(toString(d.atom.attr));
  if (inst < 0)
    throw UnknownSymbolError(d.loc.str() + ": do(" + toString(d.atom) + "): attribute instance " +
                             toString(d.atom.attr) + " is never selected or derived");
  int vi = domainIndex(g, inst, toString(d.atom.value));
  if (vi < 0)
    throw UnknownSymbolError(d.loc.str() + ": value '" + toString(d.atom.value) +
                             "' is not in the range of " + toString(d.atom.attr));
  e.setFixed(inst, vi);
}

void collectAttrs(const Query& q, std::set<std::string>& out) {
  for (const auto& l : q.formula) out.insert(l.atom.attr.name);
  for (const auto& o : q.observations) out.insert(o.literal.atom.attr.name);
  for (const auto& d : q.interventions) out.insert(d.atom.attr.name);
}

std::string setKey(const std::set<std::string>& s) {
  std::string k;
  for (const auto& x : s) k += x + ",";
  return k;
}

std::string prKey(const PrAtom& p) {
  std::vector<std::string> b;
  for (const auto& l : p.body) b.push_back(toString(l));
  std::sort(b.begin(), b.end());
  std::string k = p.label + "|" + toString(p.atom) + "|";
  for (const auto& x : b) k += x + ";";
  return k;
}

}  // namespace

Reasoner::Reasoner() { program_ = parseProgram("", "<empty>"); }
Reasoner::~Reasoner() = default;

void Reasoner::invalidate() { ground_cache_.clear(); }

void Reasoner::loadFile(const std::string& path, Dialect dialect) {
  loadString(readFile(path), path, dialect);
}

void Reasoner::loadString(const std::string& text, const std::string& name, Dialect dialect) {
  program_ = parseProgram(text, name, dialect);
  invalidate();
}

size_t Reasoner::addStatements(const std::string& text, const std::string& tag,
                               const std::string& name) {
  Program tmp = program_;
  const size_t nr = tmp.rules.size(), np = tmp.pr_atoms.size();
  parseInto(tmp, text, name, Dialect::Auto);
  size_t changed = 0;
  // pr-atoms: replace the probability of an existing pr-atom with the same label/atom/body
  std::unordered_map<std::string, size_t> existing;
  for (size_t i = 0; i < np; ++i) existing.emplace(prKey(tmp.pr_atoms[i]), i);
  std::vector<PrAtom> fresh;
  int generation = 0;
  for (size_t i = 0; i < np; ++i) generation = std::max(generation, tmp.pr_atoms[i].priority);
  ++generation;
  for (size_t i = np; i < tmp.pr_atoms.size(); ++i) {
    PrAtom& p = tmp.pr_atoms[i];
    p.tag = tag;
    p.priority = generation;
    std::string k = prKey(p);
    auto it = existing.find(k);
    if (it != existing.end()) {
      PrAtom& old = tmp.pr_atoms[it->second];
      old.probability = p.probability;
      old.probability_text = p.probability_text;
      old.tag = tag;
      old.loc = p.loc;
      old.priority = generation;
    } else {
      existing.emplace(k, np + fresh.size());
      fresh.push_back(p);
    }
    ++changed;
  }
  tmp.pr_atoms.resize(np);
  for (auto& p : fresh) tmp.pr_atoms.push_back(std::move(p));
  // rules: no duplicates
  std::set<std::string> seen;
  for (size_t i = 0; i < nr; ++i) seen.insert(toString(tmp.rules[i]));
  std::vector<Rule> new_rules;
  for (size_t i = nr; i < tmp.rules.size(); ++i) {
    std::string k = toString(tmp.rules[i]);
    if (!seen.insert(k).second) continue;
    tmp.rules[i].tag = tag;
    new_rules.push_back(tmp.rules[i]);
    ++changed;
  }
  tmp.rules.resize(nr);
  for (auto& r : new_rules) tmp.rules.push_back(std::move(r));
  program_ = std::move(tmp);
  invalidate();
  return changed;
}

size_t Reasoner::removeStatementsWithTag(const std::string& tag) {
  size_t before = program_.rules.size() + program_.pr_atoms.size();
  program_.rules.erase(std::remove_if(program_.rules.begin(), program_.rules.end(),
                                      [&](const Rule& r) { return r.tag == tag; }),
                       program_.rules.end());
  program_.pr_atoms.erase(std::remove_if(program_.pr_atoms.begin(), program_.pr_atoms.end(),
                                         [&](const PrAtom& r) { return r.tag == tag; }),
                          program_.pr_atoms.end());
  invalidate();
  return before - program_.rules.size() - program_.pr_atoms.size();
}

std::shared_ptr<const GroundProgram> Reasoner::groundFor(const std::set<std::string>& attrs) {
  std::set<std::string> all = attrs;
  for (const auto& o : program_.observations) all.insert(o.literal.atom.attr.name);
  for (const auto& d : program_.interventions) all.insert(d.atom.attr.name);
  for (const auto& a : all)
    if (attrIndex(program_, a) < 0) throw UnknownSymbolError("unknown attribute '" + a + "'");
  std::set<std::string> cone = relevanceCone(program_, all);
  std::string key = setKey(cone);
  auto it = ground_cache_.find(key);
  if (it != ground_cache_.end()) return it->second;
  Stopwatch sw;
  auto g = std::make_shared<GroundProgram>(groundProgram(program_, cone));
  stats_.ground_seconds = sw.seconds();
  stats_.ground_instances = g->instances.size();
  stats_.ground_statements = g->ground_statements;
  ground_cache_[key] = g;
  return g;
}

double Reasoner::probability(const std::string& query) {
  return probability(parseQuery(program_, query));
}

double Reasoner::probability(const Query& q) {
  std::set<std::string> attrs;
  collectAttrs(q, attrs);
  auto g = groundFor(attrs);
  ExactEngine e(*g);
  for (const auto& d : program_.interventions) applyDo(*g, program_, d, e);
  for (const auto& d : q.interventions) applyDo(*g, program_, d, e);
  std::vector<GCondition> evidence, formula(1);
  for (const std::vector<Observation>* os :
       {static_cast<const std::vector<Observation>*>(&program_.observations), &q.observations})
    for (const auto& o : *os) {
      GCondition c;
      c.truth = o.truth;
      addLiteral(*g, program_, o.literal, c);
      evidence.push_back(c);
    }
  for (const auto& l : q.formula) addLiteral(*g, program_, l, formula[0]);
  auto m = e.measure(formula, evidence);
  if (!(m.second > 0))
    throw IncoherentError(q.loc.str() + ": the evidence of query " + q.text +
                          " has probability zero (no possible world satisfies it)");
  return m.first / m.second;
}

std::vector<ValueProb> Reasoner::distribution(const std::string& attribute_term,
                                              const std::string& evidence) {
  AttributeTerm at = parseAttributeTerm(program_, attribute_term);
  Query ev;
  if (!evidence.empty()) ev = parseQuery(program_, "| " + evidence, "<evidence>");
  std::set<std::string> attrs{at.name};
  collectAttrs(ev, attrs);
  auto g = groundFor(attrs);
  int a = attrIndex(program_, at.name);
  std::vector<ValueProb> out;
  if (!g->attr_dynamic[static_cast<size_t>(a)]) {
    // static attribute: its value (if any) has probability 1
    std::string prefix = toString(at) + "=";
    for (const auto& s : g->static_atoms[static_cast<size_t>(a)])
      if (s.compare(0, prefix.size(), prefix) == 0) out.push_back({s.substr(prefix.size()), 1.0});
    return out;
  }
  int inst = g->findInstance(toString(at));
  if (inst < 0) return out;
  ExactEngine e(*g);
  for (const auto& d : program_.interventions) applyDo(*g, program_, d, e);
  for (const auto& d : ev.interventions) applyDo(*g, program_, d, e);
  std::vector<GCondition> evs;
  for (const std::vector<Observation>* os :
       {static_cast<const std::vector<Observation>*>(&program_.observations), static_cast<const std::vector<Observation>*>(&ev.observations)})
    for (const auto& o : *os) {
      GCondition c;
      c.truth = o.truth;
      addLiteral(*g, program_, o.literal, c);
      evs.push_back(c);
    }
  std::vector<double> m = e.marginal(inst, evs);
  double z = 0;
  for (double x : m) z += x;
  if (!(z > 0))
    throw IncoherentError("distribution of " + attribute_term + ": the evidence '" + evidence +
                          "' has probability zero");
  const GInstance& gi = g->instances[static_cast<size_t>(inst)];
  for (size_t v = 0; v < gi.domain.size(); ++v)
    if (m[v] > 0) out.push_back({g->symbols->text(gi.domain[v]), m[v] / z});
  return out;
}

Table Reasoner::tableQuery(const std::string& target, const std::vector<std::string>& conditioning,
                           const std::string& evidence, bool conditioning_as_do) {
  Table t;
  AttributeTerm tat = parseAttributeTerm(program_, target);
  t.target = toString(tat);
  std::vector<AttributeTerm> cats;
  std::set<std::string> attrs{tat.name};
  for (const auto& c : conditioning) {
    cats.push_back(parseAttributeTerm(program_, c));
    t.conditioning.push_back(toString(cats.back()));
    attrs.insert(cats.back().name);
  }
  Query ev;
  if (!evidence.empty()) ev = parseQuery(program_, "| " + evidence, "<evidence>");
  collectAttrs(ev, attrs);
  auto g = groundFor(attrs);
  int ti = g->findInstance(t.target);
  if (ti < 0)
    throw UnknownSymbolError("table query: target " + t.target +
                             " is not a random or derived attribute instance of the program");
  std::vector<int> ci;
  for (const auto& c : t.conditioning) {
    int i = g->findInstance(c);
    if (i < 0)
      throw UnknownSymbolError("table query: conditioning attribute " + c +
                               " is not a random or derived attribute instance of the program");
    ci.push_back(i);
  }
  ExactEngine e(*g);
  for (const auto& d : program_.interventions) applyDo(*g, program_, d, e);
  for (const auto& d : ev.interventions) applyDo(*g, program_, d, e);
  std::vector<GCondition> evs;
  for (const std::vector<Observation>* os :
       {static_cast<const std::vector<Observation>*>(&program_.observations), static_cast<const std::vector<Observation>*>(&ev.observations)})
    for (const auto& o : *os) {
      GCondition c;
      c.truth = o.truth;
      addLiteral(*g, program_, o.literal, c);
      evs.push_back(c);
    }
  if (conditioning_as_do) e.indexBy(ci);
  const GInstance& tg = g->instances[static_cast<size_t>(ti)];
  std::vector<int> cur(ci.size(), 0);
  size_t total = 1;
  for (int c : ci) total *= g->instances[static_cast<size_t>(c)].domain.size();
  t.rows.reserve(total);
  for (size_t row = 0; row < total; ++row) {
    TableRow r;
    std::vector<GCondition> evr = evs;
    for (size_t k = 0; k < ci.size(); ++k) {
      const GInstance& cg = g->instances[static_cast<size_t>(ci[k])];
      r.conditioning_values.push_back(g->symbols->text(cg.domain[static_cast<size_t>(cur[k])]));
      if (conditioning_as_do) {
        e.setFixed(ci[k], cur[k]);
      } else {
        GCondition c;
        c.lits.push_back(GLit{ci[k], cur[k], false, false});
        evr.push_back(c);
      }
    }
    std::vector<std::pair<int, double>> m = e.marginalSparse(ti, evr);
    double z = 0;
    for (const auto& x : m) z += x.second;
    if (z > 0) {
      for (const auto& x : m) {
        if (!(x.second > 0)) continue;
        if (x.first == static_cast<int>(tg.domain.size()))
          r.undefined_probability = x.second / z;
        else
          r.distribution.push_back(
              {g->symbols->text(tg.domain[static_cast<size_t>(x.first)]), x.second / z});
      }
    } else {
      r.consistent = false;
    }
    t.rows.push_back(std::move(r));
    for (size_t k = 0; k < cur.size(); ++k) {
      if (++cur[k] < static_cast<int>(g->instances[static_cast<size_t>(ci[k])].domain.size())) break;
      cur[k] = 0;
    }
  }
  return t;
}

std::vector<QueryAnswer> Reasoner::answerProgramQueries() {
  std::vector<QueryAnswer> out;
  for (const auto& q : program_.queries) out.push_back({q.text, probability(q)});
  return out;
}

std::vector<std::string> Reasoner::sortValues(const std::string& sort) const {
  const SortDecl* s = program_.findSort(sort);
  if (!s) throw UnknownSymbolError("unknown sort '" + sort + "'");
  std::vector<std::string> out;
  for (const auto& v : s->values) out.push_back(toString(v));
  return out;
}

std::vector<std::string> Reasoner::attributeRange(const std::string& attribute) const {
  const AttributeDecl* a = program_.findAttribute(attribute);
  if (!a) throw UnknownSymbolError("unknown attribute '" + attribute + "'");
  return sortValues(a->range_sort);
}

std::vector<std::string> Reasoner::sortNames() const {
  std::vector<std::string> out;
  for (const auto& s : program_.sorts) out.push_back(s.name);
  return out;
}

std::vector<std::string> Reasoner::attributeNames() const {
  std::vector<std::string> out;
  for (const auto& a : program_.attributes) out.push_back(a.name);
  return out;
}

std::string Reasoner::exportProgram() const { return toString(program_); }

}  // namespace plog
}  // namespace krr
