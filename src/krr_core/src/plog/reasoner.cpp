/**
 * @file reasoner.cpp
 * @brief The Reasoner's program: construction and loading, the declarations queries are parsed
 * against, a query's checks against the program, the back end settings and the sorts and
 * attributes (queries: reasoner_dispatch.cpp; statements: reasoner_statements.cpp).
 */
#include "krr_core/plog/reasoner.h"

#include <algorithm>
#include <map>
#include <string>
#include <unordered_set>
#include <vector>

#include "krr_core/common/files.h"
#include "krr_core/plog/asp_backend.h"
#include "krr_core/plog/engine.h"
#include "krr_core/plog/grounder.h"
#include "krr_core/plog/parser.h"
#include "reasoner_internal.h"

namespace krr {
namespace plog {

Reasoner::Reasoner() {
  limits_.cancel = &asp_won_;
  program_ = parseProgram("", "<empty>");
  structuralChange();
}
Reasoner::~Reasoner() = default;

void Reasoner::loadFile(const std::string& path, Dialect dialect) {
  loadString(readFile(path), path, dialect);
}

void Reasoner::loadString(const std::string& text, const std::string& name, Dialect dialect) {
  program_ = parseProgram(text, name, dialect, parse_options_);
  rule_ids_.clear();
  pr_ids_.clear();
  keys_valid_ = false;  // (also when the new program has no statement: the old keys go)
  structuralChange();
}

const Program& Reasoner::declarations() {
  if (decls_version_ != structure_version_) {
    decls_ = Program();
    decls_.dialect = program_.dialect;
    decls_.sorts = program_.sorts;
    decls_.attributes = program_.attributes;
    decls_.domains = program_.domains;
    decls_version_ = structure_version_;
  }
  return decls_;
}

namespace {

void symbolsOf(const Term& t, std::unordered_set<std::string>& out) {
  if (t.kind == Term::Kind::Symbol) out.insert(t.name);
  for (const auto& a : t.args) symbolsOf(a, out);
}

void symbolsOf(const std::vector<Literal>& body, std::unordered_set<std::string>& out) {
  for (const auto& l : body) {
    if (l.kind == Literal::Kind::Atom) {
      for (const auto& a : l.atom.attr.args) symbolsOf(a, out);
      symbolsOf(l.atom.value, out);
    } else {
      symbolsOf(l.lhs, out);
      symbolsOf(l.rhs, out);
    }
  }
}

}  // namespace

const std::unordered_set<std::string>& Reasoner::knownSymbols() {
  const std::pair<std::uint64_t, std::uint64_t> version{structure_version_, change_seq_};
  if (known_symbols_valid_ && known_version_ == version) return known_symbols_;
  known_symbols_.clear();
  for (const auto& s : program_.sorts)
    for (const auto& v : s.values) symbolsOf(v, known_symbols_);
  for (const auto& r : program_.rules) {
    if (r.head) {
      for (const auto& a : r.head->attr.args) symbolsOf(a, known_symbols_);
      symbolsOf(r.head->value, known_symbols_);
    }
    symbolsOf(r.body, known_symbols_);
  }
  for (const auto& r : program_.random_rules) {
    symbolsOf(r.body, known_symbols_);
    symbolsOf(r.range_body, known_symbols_);
  }
  for (const auto& p : program_.pr_atoms) symbolsOf(p.body, known_symbols_);
  known_version_ = version;
  known_symbols_valid_ = true;
  return known_symbols_;
}

void Reasoner::checkQuery(const Query& q) {
  // Contradictory interventions: do(a=x) and do(a=y) cannot both be made, so the query has no
  // meaning (the engine would silently keep the last one).
  std::map<std::string, const Intervention*> done;
  const std::vector<Intervention>& prog_do = program_.interventions;
  for (const std::vector<Intervention>* ds : {&prog_do, &q.interventions})
    for (const auto& d : *ds) {
      const std::string inst = toString(d.atom.attr);
      auto it = done.emplace(inst, &d).first;
      if (it->second->atom.value != d.atom.value)
        throw IncoherentError(d.loc.str() + ": contradictory interventions do(" +
                              toString(it->second->atom) + ") (at " + it->second->loc.str() +
                              ") and do(" + toString(d.atom) + ") on " + inst);
    }
  // Constants in untyped argument positions (implicitly declared predicates such as
  // request(I, R, P)) are not checked by the parser: a typo or an unknown person would answer
  // probability 0. A symbol that no sort and no statement mentions can never be derived.
  auto check = [&](const Atom& a, const SourceLocation& loc) {
    const AttributeDecl* d = program_.findAttribute(a.attr.name);
    if (!d) return;
    for (size_t i = 0; i < a.attr.args.size() && i < d->arg_sorts.size(); ++i) {
      if (!d->arg_sorts[i].empty()) continue;  // typed: checked against its sort when parsed
      std::unordered_set<std::string> syms;
      symbolsOf(a.attr.args[i], syms);
      for (const auto& x : syms)
        if (!knownSymbols().count(x))
          throw UnknownSymbolError(loc.str() + ": unknown value '" + x + "' for argument " +
                                   std::to_string(i + 1) + " of '" + a.attr.name +
                                   "' (no sort or statement of the program mentions it)");
    }
  };
  for (const auto& l : q.formula) check(l.atom, l.loc);
  for (const auto& o : q.observations) check(o.literal.atom, o.loc);
  for (const auto& d : q.interventions) check(d.atom, d.loc);
}

const char* backendName(Backend backend) {
  switch (backend) {
    case Backend::Native: return "native";
    case Backend::Asp: return "asp";
    case Backend::Auto: return "auto";
  }
  return "?";
}

Backend parseBackend(const std::string& name) {
  if (name == "native") return Backend::Native;
  if (name == "asp") return Backend::Asp;
  if (name == "auto") return Backend::Auto;
  throw ConfigError("unknown P-log back end '" + name + "' (expected auto, native or asp)");
}

void Reasoner::setAspOptions(const AspOptions& options) {
  asp_options_ = std::make_unique<AspOptions>(options);
  asp_.reset();
}

AspBackend& Reasoner::asp() {
  AspOptions o = asp_options_ ? *asp_options_ : AspOptions();
  if (limits_.max_inference_seconds > 0)
    o.timeout_s = std::min(o.timeout_s, limits_.max_inference_seconds);
  if (!asp_ || asp_->options().timeout_s != o.timeout_s) asp_ = std::make_unique<AspBackend>(o);
  return *asp_;
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
