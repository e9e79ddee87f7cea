#include "krr_core/pomdp/pomdpx_io.h"

#include <tinyxml2.h>

#include <algorithm>
#include <cctype>
#include <cerrno>
#include <cmath>
#include <cstdlib>
#include <functional>
#include <sstream>
#include <unordered_map>
#include <unordered_set>

#include "krr_core/common/errors.h"
#include "krr_core/common/files.h"
#include "krr_core/common/format.h"
#include "krr_core/common/limits.h"
#include "krr_core/common/resources.h"

namespace krr {
namespace pomdp {

namespace {

using tinyxml2::XMLElement;
using tinyxml2::XMLNode;

enum class Kind { kState, kObs, kAction, kReward };
/// Which copy of a state variable an identifier names (vnamePrev / vnameCurr).
enum class Slice { kPrev, kCurr, kNone };

struct Var {
  Kind kind = Kind::kState;
  std::string prev, curr;  ///< state: vnamePrev, vnameCurr; others: prev = vname
  bool fullyObs = false;
  std::vector<std::string> values;
  std::unordered_map<std::string, std::size_t> index;
  const XMLElement* elem = nullptr;
};

/// An identifier of a CondProb / Func: a variable and its slice.
struct Ref {
  std::size_t var = 0;
  Slice slice = Slice::kNone;
  bool operator==(const Ref& o) const { return var == o.var && slice == o.slice; }
};

/// One CondProb or Func as a dense table over (parents..., vars...), the vars varying fastest:
/// row r (a parent assignment) is v[r * rowLen, (r + 1) * rowLen).
struct Table {
  const XMLElement* elem = nullptr;
  std::string what;  ///< e.g. "StateTransitionFunction CondProb of 'rock_1'"
  std::vector<Ref> refs;
  std::vector<std::size_t> dims;
  std::size_t nParents = 0, rowLen = 1, rows = 1;
  std::vector<std::size_t> parentStride;  ///< row index = sum value(parent i) * parentStride[i]
  std::vector<std::size_t> slots;         ///< context slot of each ref
  std::vector<double> v;
  std::vector<const XMLElement*> rowEntry;  ///< last Entry that wrote each row (CondProb)
  /// Non-zero entries per row after validation (CondProb): (var-block index, p).
  std::vector<std::size_t> start;
  std::vector<std::pair<std::size_t, double>> nz;
  bool probability = true;  ///< CondProb (rows are distributions) or Func
};

/// Bytes per flat T or O entry: the reader's row and the Model's CSR.
constexpr std::size_t kBytesPerEntry = 2 * sizeof(Model::Entry);
/// Bytes tinyxml2 needs per node at most (element, attributes, text), for the budget check
/// before parsing.
constexpr std::size_t kBytesPerXmlNode = 192;

bool parseDouble(const std::string& s, double* v) {
  if (s.empty()) return false;
  const char* p = s.c_str();
  char* e = nullptr;
  errno = 0;
  const double d = std::strtod(p, &e);
  if (e == p || *e != '\0' || errno == ERANGE || !std::isfinite(d)) return false;
  *v = d;
  return true;
}

bool parseIndex(const std::string& s, std::size_t* v) {
  if (s.empty() || s.size() > 18) return false;
  for (char c : s)
    if (!std::isdigit(static_cast<unsigned char>(c))) return false;
  *v = static_cast<std::size_t>(std::strtoull(s.c_str(), nullptr, 10));
  return true;
}

std::vector<std::string> splitWs(const char* text) {
  std::vector<std::string> out;
  if (!text) return out;
  std::istringstream ss(text);
  std::string t;
  while (ss >> t) out.push_back(t);
  return out;
}

std::string lower(std::string s) {
  for (char& c : s) c = static_cast<char>(std::tolower(static_cast<unsigned char>(c)));
  return s;
}

class Reader {
 public:
  Reader(const std::string& text, const std::string& file, const CassandraLimits& limits,
         CassandraStats* stats)
      : text_(text),
        file_(file),
        budget_(limits.memory_budget ? limits.memory_budget : memoryBudget()),
        timeout_(limits.timeout),
        extraPerPair_(limits.extra_bytes_per_state_pair),
        tolerance_(limits.sum_tolerance),
        stats_(stats ? stats : &ownStats_) {
    if (!(tolerance_ >= 0.0 && tolerance_ < 0.5))
      throw ConfigError("readPomdpx: sum_tolerance " + formatNumber(tolerance_, 6) +
                        " outside [0, 0.5)");
    *stats_ = CassandraStats();
    lineStart_.push_back(0);
    std::size_t tags = 0;
    for (std::size_t i = 0; i < text_.size(); ++i) {
      if (text_[i] == '\n') lineStart_.push_back(i + 1);
      if (text_[i] == '<') ++tags;
    }
    // The document tree: at most one node (element or text) per '<' and one text node each.
    const std::size_t need = saturatingAdd(saturatingMul(text_.size(), 2),
                                           saturatingMul(tags, 2 * kBytesPerXmlNode));
    if (need > budget_)
      throw ParseError(SourceLocation{file_, 1, 1},
                       "file has " + std::to_string(tags) + " XML tags, parsing it needs about " +
                           formatBytes(need) + ", above the memory budget of " +
                           formatBytes(budget_) + " (KRR_MEMORY_BUDGET_MIB)");
  }

  Model read();

 private:
  // ---- locations -------------------------------------------------------------------------
  SourceLocation at(std::size_t offset) const {
    const auto it = std::upper_bound(lineStart_.begin(), lineStart_.end(), offset);
    const std::size_t line = static_cast<std::size_t>(it - lineStart_.begin());
    return {file_, static_cast<int>(line), static_cast<int>(offset - lineStart_[line - 1] + 1)};
  }
  /// @brief Offset of the element's '<' in the text: the first "<Name" on its line.
  std::size_t offsetOf(const XMLNode* n) const {
    const int line = n ? n->GetLineNum() : 0;
    if (line < 1 || static_cast<std::size_t>(line) > lineStart_.size()) return 0;
    const std::size_t b = lineStart_[static_cast<std::size_t>(line - 1)];
    const std::size_t e = static_cast<std::size_t>(line) < lineStart_.size()
                              ? lineStart_[static_cast<std::size_t>(line)]
                              : text_.size();
    const XMLElement* el = n->ToElement();
    if (el) {
      const std::size_t p = text_.find(std::string("<") + el->Name(), b);
      if (p != std::string::npos && p < e) return p;
    }
    return b;
  }
  SourceLocation loc(const XMLNode* n) const {
    if (!n) return {file_, 1, 1};
    return at(offsetOf(n));
  }
  /// @brief Location of the k-th white-space separated token of the element's text, or of
  /// the element when the raw text does not match (entities, comments).
  SourceLocation tokenLoc(const XMLElement* e, std::size_t k) const {
    std::size_t p = offsetOf(e);
    const std::size_t gt = text_.find('>', p);
    if (gt == std::string::npos || gt == 0 || text_[gt - 1] == '/') return loc(e);
    const std::size_t end = text_.find('<', gt);
    const std::size_t stop = end == std::string::npos ? text_.size() : end;
    std::vector<std::size_t> starts;
    for (std::size_t i = gt + 1; i < stop; ++i)
      if (!std::isspace(static_cast<unsigned char>(text_[i])) &&
          (i == gt + 1 || std::isspace(static_cast<unsigned char>(text_[i - 1]))))
        starts.push_back(i);
    if (starts.size() != splitWs(e->GetText()).size() || k >= starts.size()) return loc(e);
    return at(starts[k]);
  }
  [[noreturn]] void fail(const XMLNode* n, const std::string& msg) const {
    throw ParseError(loc(n), msg);
  }
  [[noreturn]] void failToken(const XMLElement* e, std::size_t k, const std::string& msg) const {
    throw ParseError(tokenLoc(e, k), msg);
  }
  void checkTime(const XMLNode* n) const {
    if (timeout_ > 0.0 && clock_.seconds() > timeout_)
      fail(n, "reading stopped here: time budget of " + formatNumber(timeout_, 6) +
                  " s exceeded");
  }
  /// @brief Bytes of the flat Model with S states, A actions, O observations: per (state,
  /// action) the CSR offsets of T and O, one entry in each, R and flags; the dense forms Model
  /// keeps whatever the density; the names. estimateModelBytes without the .pomdp reader's
  /// per-row lists: this reader writes the CSR rows directly.
  static std::size_t flatModelBytes(std::size_t S, std::size_t A, std::size_t O) {
    constexpr std::size_t kPerStateAction =
        2 * sizeof(std::size_t) + sizeof(double) + 2 * kBytesPerEntry + 16;
    const std::size_t as = saturatingMul(A, S);
    std::size_t b = saturatingMul(as, kPerStateAction);
    if (S <= Model::kDenseStates)
      b = saturatingAdd(b, saturatingMul(saturatingMul(as, S), 2 * sizeof(double)));
    const std::size_t zBytes = saturatingMul(saturatingMul(as, O), sizeof(double));
    if (zBytes <= Model::kDenseBytes) b = saturatingAdd(b, zBytes);
    return saturatingAdd(b, saturatingMul(saturatingAdd(saturatingAdd(S, A), O), 64));
  }
  /// @brief Bytes of the flat model with `entries` T and O entries plus the tables so far.
  std::size_t needBytes(std::size_t entries) const {
    const std::size_t rows = saturatingMul(saturatingMul(A_, S_), 2);
    const std::size_t beyond = entries > rows ? entries - rows : 0;
    std::size_t b = saturatingAdd(flatModelBytes(S_, A_, O_),
                                  saturatingMul(beyond, kBytesPerEntry));
    b = saturatingAdd(b, saturatingMul(saturatingMul(S_, S_), extraPerPair_));
    return saturatingAdd(b, tableBytes_);
  }
  void checkBudget(const XMLNode* n, const std::string& what, std::size_t entries) const {
    const std::size_t need = needBytes(entries);
    if (need > budget_)
      fail(n, what + ": the model needs about " + formatBytes(need) + " (" +
                  std::to_string(S_) + " states, " + std::to_string(A_) + " action(s), " +
                  std::to_string(O_) + " observation(s)" +
                  (entries ? ", " + std::to_string(entries) + " T and O entries" : "") +
                  (tableBytes_ ? ", " + formatBytes(tableBytes_) + " of tables" : "") +
                  "), above the memory budget of " + formatBytes(budget_) +
                  " (KRR_MEMORY_BUDGET_MIB)");
  }

  // ---- structure -------------------------------------------------------------------------
  const XMLElement* onlyChild(const XMLElement* parent, const char* name, bool required) const {
    const XMLElement* c = parent->FirstChildElement(name);
    if (!c) {
      if (required) fail(parent, std::string("<") + parent->Name() + "> has no <" + name + ">");
      return nullptr;
    }
    if (c->NextSiblingElement(name))
      fail(c->NextSiblingElement(name),
           std::string("<") + name + "> given twice in <" + parent->Name() + ">");
    return c;
  }
  void readVariables(const XMLElement* e);
  std::vector<std::string> readValues(const XMLElement* var, char prefix);
  Ref lookup(const XMLElement* e, std::size_t k, const std::string& name) const {
    const auto it = ids_.find(name);
    if (it == ids_.end()) failToken(e, k, "unknown variable '" + name + "'");
    return it->second;
  }
  std::string refName(const Ref& r) const {
    return r.slice == Slice::kCurr ? vars_[r.var].curr : vars_[r.var].prev;
  }
  /// @brief A CondProb (section: "InitialStateBelief", ...) or Func, read into a table.
  Table readTable(const XMLElement* e, const std::string& section);
  void readEntry(Table& t, const XMLElement* entry);
  void finishCondProb(Table& t);
  std::string rowText(const Table& t, std::size_t row) const {
    std::string out;
    std::size_t rest = row;
    for (std::size_t i = t.nParents; i-- > 0;) {
      const std::size_t d = t.dims[i];
      const std::string part = refName(t.refs[i]) + "=" + vars_[t.refs[i].var].values[rest % d];
      out = out.empty() ? part : part + ", " + out;
      rest /= d;
    }
    return out.empty() ? "no parents" : out;
  }
  std::size_t rowIndex(const Table& t, const std::vector<std::size_t>& ctx) const {
    std::size_t r = 0;
    for (std::size_t i = 0; i < t.nParents; ++i) r += ctx[t.slots[i]] * t.parentStride[i];
    return r;
  }
  std::size_t slotOf(const Ref& r) const {
    return 2 * r.var + (r.slice == Slice::kCurr ? 1 : 0);
  }
  std::vector<std::string> flatNames(const std::vector<std::size_t>& order, std::size_t n,
                                     const char* prefix, const char* none) const;

  // ---- read(), one step per section ------------------------------------------------------
  /// The elements of <pomdpx> (each at most once; Description skipped).
  struct Sections {
    const XMLElement* root = nullptr;
    const XMLElement *discount = nullptr, *variable = nullptr, *belief = nullptr,
                     *trans = nullptr, *obs = nullptr, *reward = nullptr;
  };
  Sections findSections(const XMLElement* root) const;
  double readDiscount(const XMLElement* discEl) const;
  /// The flat orders, sizes and strides of the declared variables (fully observable state
  /// variables first, SARSOP's order; the last varies fastest), refused above the budget.
  void layOut(const XMLElement* varEl);
  std::vector<Table> readSection(const XMLElement* sec, const char* name, const char* child);
  /// Which table defines each variable of `kind` (exactly one).
  std::vector<long> owners(const std::vector<Table>& tabs, const XMLElement* sec,
                           const XMLElement* root, Kind kind, const char* what) const;
  /// The order in which the state variables are drawn: their dependencies within one slice
  /// must be acyclic.
  std::vector<std::size_t> drawOrder(const std::vector<Table>& tabs,
                                     const std::vector<long>& owner, Slice slice,
                                     const XMLElement* sec) const;
  std::size_t valueOf(std::size_t flat, std::size_t var,
                      const std::vector<std::size_t>& stride) const {
    return (flat / stride[var]) % vars_[var].values.size();
  }
  void setState(std::size_t s, bool curr) {
    for (std::size_t v : stateOrder_) ctx_[2 * v + (curr ? 1 : 0)] = valueOf(s, v, stateStride_);
  }
  void setAction(std::size_t a) {
    std::size_t rest = a;
    for (std::size_t k = actionOrder_.size(); k-- > 0;) {
      const std::size_t d = vars_[actionOrder_[k]].values.size();
      ctx_[2 * actionOrder_[k]] = rest % d;
      rest /= d;
    }
  }
  /// The factors of one flat distribution: variable order[d] is drawn from
  /// tabs[owner[order[d]]], its value counted at stride[v] in the flat index; with setCurr
  /// each drawn value goes into the context (later factors may depend on it).
  struct Factors {
    const std::vector<Table>& tabs;
    const std::vector<long>& owner;
    const std::vector<std::size_t>& order;
    const std::vector<std::size_t>& stride;
    bool setCurr;
  };
  /// Appends to `row` the flat entries of the factors from `depth` on, in the context.
  void drawRow(const Factors& f, std::size_t depth, double p, std::size_t flat,
               std::vector<Model::Entry>& row);
  /// The most entries one row can have: rows are refused before they are generated.
  static std::size_t widest(const std::vector<Table>& tabs);
  /// Flat T(s, a, s') rows per action; `entries` counts the T and O entries made.
  std::vector<SparseRows> flatTransitions(const std::vector<Table>& trans,
                                          const std::vector<long>& tOwner,
                                          const std::vector<std::size_t>& tOrder,
                                          const XMLElement* transEl, std::size_t* entries);
  /// Flat O(s', a, o) rows per action, o = (x', observation variables).
  std::vector<SparseRows> flatObservations(const std::vector<Table>& obs,
                                           const std::vector<long>& zOwner,
                                           const XMLElement* obsEl, std::size_t* entries);
  /// R(s, a): the sum of the Funcs, in expectation over s' and o where they appear.
  Eigen::MatrixXd flatRewards(const std::vector<Table>& rew, const std::vector<SparseRows>& tCsr,
                              const std::vector<SparseRows>& zCsr);
  /// Each Func is within the limit, their sum need not be: refused at <RewardFunction>.
  void checkRewardSum(const Eigen::MatrixXd& r, const XMLElement* rewEl) const;
  /// b0: the product of the InitialStateBelief factors.
  Eigen::VectorXd initialBelief(const std::vector<Table>& belief);
  /// The Model from the flat rows (the tables are released first).
  Model buildModel(std::vector<SparseRows> tCsr, std::vector<SparseRows> zCsr,
                   Eigen::MatrixXd r, double discount, const Eigen::VectorXd* b0,
                   std::size_t entries, std::vector<Table>& trans, std::vector<Table>& obs,
                   const XMLElement* root);

  const std::string& text_;
  std::string file_;
  std::size_t budget_;
  double timeout_;
  std::size_t extraPerPair_;
  double tolerance_;
  CassandraStats ownStats_;
  CassandraStats* stats_;
  Stopwatch clock_;
  std::vector<std::size_t> lineStart_;
  std::vector<Var> vars_;
  std::unordered_map<std::string, Ref> ids_;
  std::size_t S_ = 1, A_ = 1, O_ = 1, tableBytes_ = 0;
  // The flat layout (layOut): variable orders, X = values of the fully observable state
  // variables, Ov = of the observation variables; strides of each variable in a flat state
  // and observation; the context, two slots (prev, curr) per variable.
  std::vector<std::size_t> stateOrder_, actionOrder_, obsVarOrder_, xOrder_, obsOrder_;
  std::size_t X_ = 1, Ov_ = 1;
  std::vector<std::size_t> stateStride_, obsStride_, ctx_;
};

std::vector<std::string> Reader::readValues(const XMLElement* var, char prefix) {
  const XMLElement* en = var->FirstChildElement("ValueEnum");
  const XMLElement* nv = var->FirstChildElement("NumValues");
  if (en && nv) fail(nv, "give either <ValueEnum> or <NumValues>, not both");
  std::vector<std::string> values;
  if (en) {
    values = splitWs(en->GetText());
    if (values.empty()) fail(en, "<ValueEnum> lists no values");
    std::unordered_set<std::string> seen;
    for (std::size_t k = 0; k < values.size(); ++k) {
      if (values[k] == "*" || values[k] == "-")
        failToken(en, k, "'" + values[k] + "' is a wildcard, not a value name");
      if (!seen.insert(values[k]).second)
        failToken(en, k, "duplicate value '" + values[k] + "'");
    }
    return values;
  }
  if (!nv) fail(var, std::string("<") + var->Name() + "> has neither <ValueEnum> nor <NumValues>");
  const auto tok = splitWs(nv->GetText());
  std::size_t n = 0;
  if (tok.size() != 1 || !parseIndex(tok[0], &n) || n == 0)
    fail(nv, "<NumValues> must be a positive integer, got '" +
                 std::string(nv->GetText() ? nv->GetText() : "") + "'");
  // Refused before the names are made: "<NumValues>1000000000000</NumValues>" is a few bytes.
  const std::size_t need = saturatingMul(n, 64);
  if (need > budget_)
    fail(nv, "<NumValues>" + tok[0] + "</NumValues> needs about " + formatBytes(need) +
                 " for its value names alone, above the memory budget of " +
                 formatBytes(budget_) + " (KRR_MEMORY_BUDGET_MIB)");
  values.reserve(n);
  for (std::size_t i = 0; i < n; ++i) values.push_back(prefix + std::to_string(i));
  return values;
}

void Reader::readVariables(const XMLElement* e) {
  for (const XMLElement* c = e->FirstChildElement(); c; c = c->NextSiblingElement()) {
    const std::string name = c->Name();
    Var v;
    v.elem = c;
    auto attr = [&](const char* a) {
      const char* s = c->Attribute(a);
      if (!s || splitWs(s).size() != 1)
        fail(c, "<" + name + "> needs attribute " + a + " (one identifier)");
      return splitWs(s)[0];
    };
    if (name == "StateVar") {
      v.kind = Kind::kState;
      v.prev = attr("vnamePrev");
      v.curr = attr("vnameCurr");
      if (const char* f = c->Attribute("fullyObs")) {
        const std::string fo = lower(f);
        if (fo == "true" || fo == "1") {
          v.fullyObs = true;
        } else if (fo != "false" && fo != "0") {
          fail(c, "fullyObs must be true or false, got '" + std::string(f) + "'");
        }
      }
      v.values = readValues(c, 's');
    } else if (name == "ObsVar" || name == "ActionVar") {
      v.kind = name == "ObsVar" ? Kind::kObs : Kind::kAction;
      v.prev = attr("vname");
      v.values = readValues(c, name == "ObsVar" ? 'o' : 'a');
    } else if (name == "RewardVar") {
      v.kind = Kind::kReward;
      v.prev = attr("vname");
    } else if (name == "TerminalStateRewardVar") {
      fail(c, "<TerminalStateRewardVar> is not supported (not part of PomdpX 1.0)");
    } else {
      fail(c, "unknown element <" + name + "> in <Variable> (expected StateVar, ObsVar, "
              "ActionVar or RewardVar)");
    }
    for (std::size_t i = 0; i < v.values.size(); ++i) v.index.emplace(v.values[i], i);
    const std::size_t vi = vars_.size();
    auto define = [&](const std::string& id, Slice slice) {
      if (id == "null" || id == "*" || id == "-")
        fail(c, "'" + id + "' is reserved and cannot name a variable");
      if (!ids_.emplace(id, Ref{vi, slice}).second)
        fail(c, "variable name '" + id + "' declared twice");
    };
    if (v.kind == Kind::kState) {
      define(v.prev, Slice::kPrev);
      define(v.curr, Slice::kCurr);
    } else {
      define(v.prev, Slice::kNone);
    }
    vars_.push_back(std::move(v));
    checkTime(c);
  }
}

Table Reader::readTable(const XMLElement* e, const std::string& section) {
  Table t;
  t.elem = e;
  t.probability = std::string(e->Name()) == "CondProb";
  const XMLElement* varEl = onlyChild(e, "Var", true);
  const XMLElement* parEl = onlyChild(e, "Parent", true);
  const XMLElement* paramEl = onlyChild(e, "Parameter", true);
  const auto varTok = splitWs(varEl->GetText());
  if (varTok.empty()) fail(varEl, "<Var> names no variable");
  if (!t.probability && varTok.size() != 1) fail(varEl, "a <Func> defines one reward variable");
  std::vector<Ref> varRefs;
  for (std::size_t k = 0; k < varTok.size(); ++k) {
    const Ref r = lookup(varEl, k, varTok[k]);
    const Var& v = vars_[r.var];
    bool ok = false;
    const char* want = "";
    if (section == "InitialStateBelief") {
      ok = v.kind == Kind::kState && r.slice == Slice::kPrev;
      want = "a state variable's vnamePrev";
    } else if (section == "StateTransitionFunction") {
      ok = v.kind == Kind::kState && r.slice == Slice::kCurr;
      want = "a state variable's vnameCurr";
    } else if (section == "ObsFunction") {
      ok = v.kind == Kind::kObs;
      want = "an observation variable";
    } else {
      ok = v.kind == Kind::kReward;
      want = "a reward variable";
    }
    if (!ok) failToken(varEl, k, "<Var> of " + section + " must be " + want + ", got '" +
                                     varTok[k] + "'");
    if (std::find(varRefs.begin(), varRefs.end(), r) != varRefs.end())
      failToken(varEl, k, "'" + varTok[k] + "' given twice in <Var>");
    varRefs.push_back(r);
  }
  t.what = section + " " + e->Name() + " of '" + varTok[0] + (varTok.size() > 1 ? "' ..." : "'");
  const auto parTok = splitWs(parEl->GetText());
  if (parTok.empty()) fail(parEl, "<Parent> is empty (write 'null' for no parents)");
  if (!(parTok.size() == 1 && parTok[0] == "null")) {
    for (std::size_t k = 0; k < parTok.size(); ++k) {
      if (parTok[k] == "null") failToken(parEl, k, "'null' must be the only parent");
      const Ref r = lookup(parEl, k, parTok[k]);
      const Var& v = vars_[r.var];
      bool ok = false;
      const char* allowed = "";
      if (section == "InitialStateBelief") {
        ok = v.kind == Kind::kState && r.slice == Slice::kPrev;
        allowed = "state variables' vnamePrev";
      } else if (section == "StateTransitionFunction") {
        ok = v.kind == Kind::kAction || v.kind == Kind::kState;
        allowed = "action variables and state variables";
      } else if (section == "ObsFunction") {
        ok = v.kind == Kind::kAction || (v.kind == Kind::kState && r.slice == Slice::kCurr);
        allowed = "action variables and state variables' vnameCurr (observations depend on "
                  "the action and the next state)";
      } else {
        ok = v.kind != Kind::kReward;
        allowed = "action, state and observation variables";
      }
      if (!ok) failToken(parEl, k, "'" + parTok[k] + "' cannot be a parent in " + section +
                                       " (allowed: " + allowed + ")");
      if (std::find(varRefs.begin(), varRefs.end(), r) != varRefs.end() ||
          std::find(t.refs.begin(), t.refs.end(), r) != t.refs.end())
        failToken(parEl, k, "'" + parTok[k] + "' appears twice in <Var> and <Parent>");
      t.refs.push_back(r);
    }
  }
  t.nParents = t.refs.size();
  for (const Ref& r : varRefs) t.refs.push_back(r);
  std::size_t cells = 1;
  for (const Ref& r : t.refs) {
    const std::size_t d = vars_[r.var].kind == Kind::kReward ? 1 : vars_[r.var].values.size();
    t.dims.push_back(d);
    t.slots.push_back(slotOf(r));
    cells = saturatingMul(cells, d);
  }
  if (!t.probability) {  // the reward variable is not a table dimension
    t.refs.pop_back();
    t.dims.pop_back();
    t.slots.pop_back();
  }
  t.rowLen = 1;
  for (std::size_t i = t.nParents; i < t.dims.size(); ++i) t.rowLen *= t.dims[i];
  t.rows = 1;
  t.parentStride.assign(t.nParents, 1);
  for (std::size_t i = t.nParents; i-- > 0;) {
    t.parentStride[i] = t.rows;
    t.rows = saturatingMul(t.rows, t.dims[i]);
  }
  // The dense table (and, for a CondProb, its row locations) is checked before it exists.
  const std::size_t bytes = saturatingAdd(saturatingMul(cells, 2 * sizeof(double)),
                                          saturatingMul(t.rows, sizeof(void*)));
  tableBytes_ = saturatingAdd(tableBytes_, bytes);
  checkBudget(e, t.what + " is a table of " + std::to_string(cells) + " entries", 0);
  t.v.assign(cells, 0.0);
  if (t.probability) t.rowEntry.assign(t.rows, nullptr);

  const char* type = paramEl->Attribute("type");
  if (type && std::string(type) != "TBL") {
    if (std::string(type) == "DD")
      fail(paramEl, "decision-diagram parameters (type=\"DD\") are not supported (SARSOP does "
                    "not read them either); write the table as type=\"TBL\" entries");
    fail(paramEl, "unknown <Parameter> type '" + std::string(type) + "' (expected TBL)");
  }
  for (const XMLElement* c = paramEl->FirstChildElement(); c; c = c->NextSiblingElement()) {
    if (std::string(c->Name()) != "Entry")
      fail(c, "unexpected <" + std::string(c->Name()) + "> in a TBL <Parameter> (expected <Entry>)");
    readEntry(t, c);
  }
  return t;
}

void Reader::readEntry(Table& t, const XMLElement* entry) {
  checkTime(entry);
  const XMLElement* inst = onlyChild(entry, "Instance", true);
  const XMLElement* pt = onlyChild(entry, "ProbTable", false);
  const XMLElement* vt = onlyChild(entry, "ValueTable", false);
  if (pt && vt) fail(vt, "an <Entry> has either <ProbTable> or <ValueTable>, not both");
  if (t.probability && vt) fail(vt, "a <CondProb> entry needs <ProbTable>, not <ValueTable>");
  const XMLElement* tab = pt ? pt : vt;  // a Func may use either (the format's own examples do)
  if (!tab) fail(entry, std::string("<Entry> has no <") +
                            (t.probability ? "ProbTable" : "ValueTable") + ">");
  const auto tok = splitWs(inst->GetText());
  if (tok.size() != t.dims.size())
    fail(inst, "<Instance> has " + std::to_string(tok.size()) + " item(s), " + t.what + " needs " +
                   std::to_string(t.dims.size()) + " (its parents" +
                   (t.probability ? " then its variable" : "") + ")");
  // Per position: a fixed value, or -1 for '*', -2 for '-'.
  std::vector<long> fixed(tok.size());
  std::vector<std::size_t> dashes;
  std::size_t count = 1;
  for (std::size_t k = 0; k < tok.size(); ++k) {
    const Var& v = vars_[t.refs[k].var];
    if (tok[k] == "*") {
      fixed[k] = -1;
    } else if (tok[k] == "-") {
      fixed[k] = -2;
      dashes.push_back(k);
      count = saturatingMul(count, t.dims[k]);
    } else {
      const auto it = v.index.find(tok[k]);
      std::size_t idx = 0;
      if (it != v.index.end()) {
        idx = it->second;
      } else if (!parseIndex(tok[k], &idx) || idx >= v.values.size()) {
        failToken(inst, k, "'" + tok[k] + "' is not a value of '" + refName(t.refs[k]) + "'");
      }
      fixed[k] = static_cast<long>(idx);
    }
  }
  const auto numTok = splitWs(tab->GetText());
  std::vector<double> numbers;
  const std::string kw = numTok.size() == 1 ? lower(numTok[0]) : std::string();
  if (kw == "identity" || kw == "uniform") {
    if (!t.probability) fail(tab, "'" + kw + "' is for probabilities, not rewards");
    if (kw == "identity") {
      if (dashes.size() != 2 || dashes[1] != tok.size() - 1 ||
          t.dims[dashes[0]] != t.dims[dashes[1]])
        fail(tab, "'identity' needs exactly two '-' in <Instance>, the last on the variable, "
                  "over the same number of values");
      const std::size_t n = t.dims[dashes[0]];
      numbers.assign(count, 0.0);
      for (std::size_t i = 0; i < n; ++i) numbers[i * n + i] = 1.0;
    } else {
      if (count > t.v.size()) fail(tab, "'uniform' covers more entries than the table has");
      numbers.assign(count, 1.0 / static_cast<double>(count));
    }
  } else {
    if (numTok.size() != count)
      fail(tab, "<" + std::string(tab->Name()) + "> has " + std::to_string(numTok.size()) +
                    " number(s), <Instance> needs " + std::to_string(count) +
                    (dashes.empty() ? " (no '-')" : " (the product of the '-' variables' sizes)"));
    numbers.resize(count);
    for (std::size_t k = 0; k < count; ++k) {
      if (!parseDouble(numTok[k], &numbers[k]))
        failToken(tab, k, "expected a number, got '" + numTok[k] + "'");
      if (!t.probability && std::abs(numbers[k]) > Model::kMaxAbsReward)
        failToken(tab, k, "reward " + numTok[k] + " is outside [-" +
                              formatNumber(Model::kMaxAbsReward, 6) + ", " +
                              formatNumber(Model::kMaxAbsReward, 6) + "], the limit that keeps "
                              "|R| / (1 - discount) and |R| * horizon finite");
      if (t.probability && (numbers[k] < 0.0 || numbers[k] > 1.0 + tolerance_))
        failToken(tab, k, "probability " + numTok[k] + " is not in [0, 1]");
    }
  }
  // Every assignment of the '*' and '-' positions; the '-' positions index the numbers.
  std::vector<std::size_t> cur(tok.size(), 0);
  std::vector<std::size_t> free;
  for (std::size_t k = 0; k < tok.size(); ++k) {
    if (fixed[k] >= 0) {
      cur[k] = static_cast<std::size_t>(fixed[k]);
    } else {
      free.push_back(k);
    }
  }
  std::vector<std::size_t> stride(t.dims.size(), 1);
  for (std::size_t k = t.dims.size(); k-- > 1;) stride[k - 1] = stride[k] * t.dims[k];
  std::size_t steps = 0;
  while (true) {
    std::size_t cell = 0, num = 0;
    for (std::size_t k = 0; k < tok.size(); ++k) cell += cur[k] * stride[k];
    for (std::size_t d : dashes) num = num * t.dims[d] + cur[d];
    t.v[cell] = numbers[num];
    if (t.probability) t.rowEntry[cell / t.rowLen] = entry;
    if ((++steps & 0xffff) == 0) checkTime(entry);
    std::size_t i = free.size();
    while (i > 0) {
      const std::size_t k = free[i - 1];
      if (++cur[k] < t.dims[k]) break;
      cur[k] = 0;
      --i;
    }
    if (i == 0) break;
  }
}

void Reader::finishCondProb(Table& t) {
  t.start.assign(1, 0);
  t.start.reserve(t.rows + 1);
  for (std::size_t r = 0; r < t.rows; ++r) {
    if ((r & 0xfff) == 0) checkTime(t.elem);
    double* row = t.v.data() + r * t.rowLen;
    double sum = 0.0;
    for (std::size_t k = 0; k < t.rowLen; ++k) sum += row[k];
    if (sum == 0.0 && !t.rowEntry[r])
      fail(t.elem, t.what + ": no <Entry> gives the distribution for " + rowText(t, r));
    double divisor = 1.0;
    if (sum != 1.0 &&
        !checkDistributionSum(sum, tolerance_, *stats_,
                              [&] { return t.what + " given " + rowText(t, r); }, &divisor))
      fail(t.rowEntry[r] ? t.rowEntry[r] : t.elem,
           t.what + ": probabilities given " + rowText(t, r) + " sum to " +
               formatNumber(sum, 10) + " (expected 1 within " + formatNumber(tolerance_, 3) + ")");
    for (std::size_t k = 0; k < t.rowLen; ++k) {
      if (divisor != 1.0) row[k] /= divisor;
      if (row[k] != 0.0) t.nz.emplace_back(k, row[k]);
    }
    t.start.push_back(t.nz.size());
  }
}

std::vector<std::string> Reader::flatNames(const std::vector<std::size_t>& order, std::size_t n,
                                           const char* prefix, const char* none) const {
  std::vector<std::string> out;
  out.reserve(n);
  if (order.empty()) {
    out.emplace_back(none);
    return out;
  }
  std::unordered_set<std::string> seen;
  bool unique = true;
  for (std::size_t i = 0; i < n; ++i) {
    std::string name;
    std::size_t rest = i;
    for (std::size_t k = order.size(); k-- > 0;) {
      const Var& v = vars_[order[k]];
      const std::string& part = v.values[rest % v.values.size()];
      name = name.empty() ? part : part + "_" + name;
      rest /= v.values.size();
    }
    if (order.size() > 1 && unique && !seen.insert(name).second) unique = false;
    out.push_back(std::move(name));
  }
  if (!unique)  // joined value names can collide ("a_b" + "c" vs "a" + "b_c"): number them
    for (std::size_t i = 0; i < n; ++i) out[i] = prefix + std::to_string(i);
  return out;
}

Model Reader::read() {
  // tinyxml2 reads C strings: a NUL byte would silently end the document there.
  if (const std::size_t nul = text_.find('\0'); nul != std::string::npos)
    throw ParseError(at(nul), "NUL byte (\\0) in the file: a .pomdpx file is text");
  tinyxml2::XMLDocument doc;
  if (doc.Parse(text_.data(), text_.size()) != tinyxml2::XML_SUCCESS) {
    const int line = std::max(1, doc.ErrorLineNum());
    throw ParseError(SourceLocation{file_, line, 1},
                     std::string("not well-formed XML: ") + doc.ErrorName() +
                         (doc.ErrorStr() ? std::string(" (") + doc.ErrorStr() + ")" : ""));
  }
  const Sections sec = findSections(doc.RootElement());
  const double discount = readDiscount(sec.discount);
  readVariables(sec.variable);
  layOut(sec.variable);

  // ---- tables ------------------------------------------------------------------------------
  std::vector<Table> belief = readSection(sec.belief, "InitialStateBelief", "CondProb");
  std::vector<Table> trans = readSection(sec.trans, "StateTransitionFunction", "CondProb");
  std::vector<Table> obs = readSection(sec.obs, "ObsFunction", "CondProb");
  std::vector<Table> rew = readSection(sec.reward, "RewardFunction", "Func");
  const auto tOwner = owners(trans, sec.trans, sec.root, Kind::kState, "StateTransitionFunction");
  const auto zOwner = owners(obs, sec.obs, sec.root, Kind::kObs, "ObsFunction");
  std::vector<long> bOwner;
  if (sec.belief) bOwner = owners(belief, sec.belief, sec.root, Kind::kState, "InitialStateBelief");
  for (std::size_t i = 0; i < rew.size(); ++i)
    for (std::size_t j = 0; j < i; ++j)
      if (rew[i].what == rew[j].what) fail(rew[i].elem, rew[i].what + " given twice");
  const auto tOrder = drawOrder(trans, tOwner, Slice::kCurr, sec.trans);
  if (sec.belief) drawOrder(belief, bOwner, Slice::kPrev, sec.belief);

  // ---- flat T, O, R and b0 -----------------------------------------------------------------
  ctx_.assign(2 * vars_.size(), 0);
  std::size_t entries = 0;
  std::vector<SparseRows> tCsr = flatTransitions(trans, tOwner, tOrder, sec.trans, &entries);
  std::vector<SparseRows> zCsr =
      flatObservations(obs, zOwner, sec.obs ? sec.obs : sec.root, &entries);
  Eigen::MatrixXd r = flatRewards(rew, tCsr, zCsr);
  checkRewardSum(r, sec.reward);
  Eigen::VectorXd b0;
  if (sec.belief) b0 = initialBelief(belief);
  return buildModel(std::move(tCsr), std::move(zCsr), std::move(r), discount,
                    sec.belief ? &b0 : nullptr, entries, trans, obs, sec.root);
}

Reader::Sections Reader::findSections(const XMLElement* root) const {
  if (!root) throw ParseError(SourceLocation{file_, 1, 1}, "no XML element in the file");
  if (std::string(root->Name()) != "pomdpx")
    fail(root, "the root element is <" + std::string(root->Name()) + ">, expected <pomdpx>");
  Sections sec;
  sec.root = root;
  for (const XMLElement* c = root->FirstChildElement(); c; c = c->NextSiblingElement()) {
    const std::string n = c->Name();
    const XMLElement** slot = n == "Discount"                  ? &sec.discount
                              : n == "Variable"                ? &sec.variable
                              : n == "InitialStateBelief"      ? &sec.belief
                              : n == "StateTransitionFunction" ? &sec.trans
                              : n == "ObsFunction"             ? &sec.obs
                              : n == "RewardFunction"          ? &sec.reward
                                                               : nullptr;
    if (n == "Description") continue;
    if (n == "TerminalStateRewardFunction")
      fail(c, "<TerminalStateRewardFunction> is not supported (not part of PomdpX 1.0)");
    if (!slot)
      fail(c, "unknown element <" + n + "> in <pomdpx> (expected Description, Discount, "
              "Variable, InitialStateBelief, StateTransitionFunction, ObsFunction, "
              "RewardFunction)");
    if (*slot) fail(c, "<" + n + "> given twice");
    *slot = c;
  }
  if (!sec.discount) fail(root, "<pomdpx> has no <Discount>");
  if (!sec.variable) fail(root, "<pomdpx> has no <Variable>");
  if (!sec.trans) fail(root, "<pomdpx> has no <StateTransitionFunction>");
  return sec;
}

double Reader::readDiscount(const XMLElement* discEl) const {
  double discount = 0.0;
  const auto tok = splitWs(discEl->GetText());
  if (tok.size() != 1 || !parseDouble(tok[0], &discount) || !(discount > 0.0 && discount <= 1.0))
    fail(discEl, "<Discount> must be one number in (0, 1], got '" +
                     std::string(discEl->GetText() ? discEl->GetText() : "") + "'");
  return discount;
}

void Reader::layOut(const XMLElement* varEl) {
  // Flat orders: fully observable state variables first (SARSOP's order), last fastest.
  for (std::size_t i = 0; i < vars_.size(); ++i)
    if (vars_[i].kind == Kind::kState && vars_[i].fullyObs) xOrder_.push_back(i);
  stateOrder_ = xOrder_;
  for (std::size_t i = 0; i < vars_.size(); ++i) {
    if (vars_[i].kind == Kind::kState && !vars_[i].fullyObs) stateOrder_.push_back(i);
    if (vars_[i].kind == Kind::kAction) actionOrder_.push_back(i);
    if (vars_[i].kind == Kind::kObs) obsVarOrder_.push_back(i);
  }
  if (stateOrder_.empty()) fail(varEl, "<Variable> declares no <StateVar>");
  if (actionOrder_.empty()) fail(varEl, "<Variable> declares no <ActionVar>");
  obsOrder_ = xOrder_;  // flat observation: (x', observation variables)
  obsOrder_.insert(obsOrder_.end(), obsVarOrder_.begin(), obsVarOrder_.end());
  X_ = Ov_ = 1;
  S_ = A_ = 1;
  for (std::size_t i : stateOrder_) S_ = saturatingMul(S_, vars_[i].values.size());
  for (std::size_t i : actionOrder_) A_ = saturatingMul(A_, vars_[i].values.size());
  for (std::size_t i : xOrder_) X_ = saturatingMul(X_, vars_[i].values.size());
  for (std::size_t i : obsVarOrder_) Ov_ = saturatingMul(Ov_, vars_[i].values.size());
  O_ = saturatingMul(X_, Ov_);
  // The flat sizes are known from the declarations: refuse before anything is allocated.
  checkBudget(varEl, "the declared variables", 0);
  stateStride_.assign(vars_.size(), 0);
  obsStride_.assign(vars_.size(), 0);
  std::size_t m = 1;
  for (std::size_t k = stateOrder_.size(); k-- > 0;) {
    stateStride_[stateOrder_[k]] = m;
    m *= vars_[stateOrder_[k]].values.size();
  }
  m = 1;
  for (std::size_t k = obsVarOrder_.size(); k-- > 0;) {
    obsStride_[obsVarOrder_[k]] = m;
    m *= vars_[obsVarOrder_[k]].values.size();
  }
}

std::vector<Table> Reader::readSection(const XMLElement* sec, const char* name,
                                       const char* child) {
  std::vector<Table> out;
  if (!sec) return out;
  for (const XMLElement* c = sec->FirstChildElement(); c; c = c->NextSiblingElement()) {
    if (std::string(c->Name()) != child)
      fail(c, "unexpected <" + std::string(c->Name()) + "> in <" + name + "> (expected <" +
                  child + ">)");
    out.push_back(readTable(c, name));
    if (out.back().probability) finishCondProb(out.back());
  }
  if (out.empty()) fail(sec, std::string("<") + name + "> has no <" + child + ">");
  return out;
}

std::vector<long> Reader::owners(const std::vector<Table>& tabs, const XMLElement* sec,
                                 const XMLElement* root, Kind kind, const char* what) const {
  std::vector<long> owner(vars_.size(), -1);
  for (std::size_t i = 0; i < tabs.size(); ++i)
    for (std::size_t k = tabs[i].nParents; k < tabs[i].refs.size(); ++k) {
      const std::size_t v = tabs[i].refs[k].var;
      if (owner[v] >= 0)
        fail(tabs[i].elem, "'" + refName(tabs[i].refs[k]) + "' is defined by two <CondProb> in <" +
                               what + ">");
      owner[v] = static_cast<long>(i);
    }
  for (std::size_t v = 0; v < vars_.size(); ++v)
    if (vars_[v].kind == kind && owner[v] < 0)
      fail(sec ? sec : root, std::string("<") + what + "> has no <CondProb> for '" +
                                 (kind == Kind::kState && std::string(what) != "InitialStateBelief"
                                      ? vars_[v].curr
                                      : vars_[v].prev) +
                                 "'");
  return owner;
}

std::vector<std::size_t> Reader::drawOrder(const std::vector<Table>& tabs,
                                           const std::vector<long>& owner, Slice slice,
                                           const XMLElement* sec) const {
  std::vector<std::size_t> order;
  std::vector<int> state(vars_.size(), 0);  // 0 new, 1 on the stack, 2 done
  std::function<void(std::size_t)> visit = [&](std::size_t v) {
    if (state[v] == 2) return;
    if (state[v] == 1)
      fail(sec, "the variables of <" + std::string(sec->Name()) +
                    "> depend on each other in a cycle (through '" + vars_[v].prev + "')");
    state[v] = 1;
    const Table& t = tabs[static_cast<std::size_t>(owner[v])];
    for (std::size_t k = 0; k < t.nParents; ++k)
      if (t.refs[k].slice == slice && vars_[t.refs[k].var].kind == Kind::kState)
        visit(t.refs[k].var);
    state[v] = 2;
    order.push_back(v);
  };
  for (std::size_t v : stateOrder_) visit(v);
  return order;
}

void Reader::drawRow(const Factors& f, std::size_t depth, double p, std::size_t flat,
                     std::vector<Model::Entry>& row) {
  if (depth == f.order.size()) {
    row.emplace_back(flat, p);
    return;
  }
  const std::size_t v = f.order[depth];
  const Table& t = f.tabs[static_cast<std::size_t>(f.owner[v])];
  const std::size_t r = rowIndex(t, ctx_);
  for (std::size_t k = t.start[r]; k < t.start[r + 1]; ++k) {
    if (f.setCurr) ctx_[2 * v + 1] = t.nz[k].first;
    drawRow(f, depth + 1, p * t.nz[k].second, flat + t.nz[k].first * f.stride[v], row);
  }
}

std::size_t Reader::widest(const std::vector<Table>& tabs) {
  std::size_t w = 1;
  for (const Table& t : tabs) {
    std::size_t most = 0;
    for (std::size_t r = 0; r < t.rows; ++r) most = std::max(most, t.start[r + 1] - t.start[r]);
    w = saturatingMul(w, most);
  }
  return w;
}

std::vector<SparseRows> Reader::flatTransitions(const std::vector<Table>& trans,
                                                const std::vector<long>& tOwner,
                                                const std::vector<std::size_t>& tOrder,
                                                const XMLElement* transEl,
                                                std::size_t* entries) {
  const std::size_t S = S_, A = A_;
  std::vector<SparseRows> tCsr(A);
  std::vector<Model::Entry> row;
  const Factors next{trans, tOwner, tOrder, stateStride_, true};
  const std::size_t widestT = widest(trans);
  for (std::size_t a = 0; a < A; ++a) {
    setAction(a);
    tCsr[a].cols = S;
    tCsr[a].start.reserve(S + 1);
    for (std::size_t s = 0; s < S; ++s) {
      checkBudget(transEl, "StateTransitionFunction", saturatingAdd(*entries, widestT));
      if ((s & 1023) == 0) checkTime(transEl);
      setState(s, false);
      row.clear();
      drawRow(next, 0, 1.0, 0, row);
      std::sort(row.begin(), row.end());
      *entries += row.size();
      tCsr[a].pushRow(row);
    }
  }
  checkBudget(transEl, "StateTransitionFunction", *entries);
  return tCsr;
}

std::vector<SparseRows> Reader::flatObservations(const std::vector<Table>& obs,
                                                 const std::vector<long>& zOwner,
                                                 const XMLElement* obsEl, std::size_t* entries) {
  const std::size_t S = S_, A = A_, O = O_, Y = S / X_;
  std::vector<SparseRows> zCsr(A);
  std::vector<Model::Entry> row;
  const Factors draw{obs, zOwner, obsVarOrder_, obsStride_, false};
  const std::size_t widestZ = widest(obs);
  for (std::size_t a = 0; a < A; ++a) {
    setAction(a);
    zCsr[a].cols = O;
    zCsr[a].start.reserve(S + 1);
    for (std::size_t s1 = 0; s1 < S; ++s1) {
      checkBudget(obsEl, "ObsFunction", saturatingAdd(*entries, widestZ));
      if ((s1 & 1023) == 0) checkTime(obsEl);
      setState(s1, true);
      row.clear();
      drawRow(draw, 0, 1.0, (s1 / Y) * Ov_, row);  // fully observable variables come first in s1
      *entries += row.size();
      zCsr[a].pushRow(row);
    }
  }
  return zCsr;
}

Eigen::MatrixXd Reader::flatRewards(const std::vector<Table>& rew,
                                    const std::vector<SparseRows>& tCsr,
                                    const std::vector<SparseRows>& zCsr) {
  const std::size_t S = S_, A = A_;
  Eigen::MatrixXd r =
      Eigen::MatrixXd::Zero(static_cast<Eigen::Index>(S), static_cast<Eigen::Index>(A));
  for (const Table& f : rew) {
    bool next = false, observed = false;
    for (std::size_t k = 0; k < f.nParents; ++k) {
      next = next || f.refs[k].slice == Slice::kCurr;
      observed = observed || vars_[f.refs[k].var].kind == Kind::kObs;
    }
    for (std::size_t a = 0; a < A; ++a) {
      setAction(a);
      for (std::size_t s = 0; s < S; ++s) {
        if ((s & 1023) == 0) checkTime(f.elem);
        setState(s, false);
        double value = 0.0;
        if (!next && !observed) {
          value = f.v[rowIndex(f, ctx_)];
        } else {
          for (const auto& t : tCsr[a].row(s)) {
            setState(t.first, true);
            if (!observed) {
              value += t.second * f.v[rowIndex(f, ctx_)];
              continue;
            }
            double w = 0.0;
            for (const auto& z : zCsr[a].row(t.first)) {
              for (std::size_t v : obsVarOrder_)
                ctx_[2 * v] = valueOf(z.first % Ov_, v, obsStride_);
              w += z.second * f.v[rowIndex(f, ctx_)];
            }
            value += t.second * w;
          }
        }
        r(static_cast<Eigen::Index>(s), static_cast<Eigen::Index>(a)) += value;
      }
    }
  }
  return r;
}

void Reader::checkRewardSum(const Eigen::MatrixXd& r, const XMLElement* rewEl) const {
  if (r.size() == 0) return;
  Eigen::Index ws = 0, wa = 0;
  if (r.cwiseAbs().maxCoeff(&ws, &wa) > Model::kMaxAbsReward)
    fail(rewEl, "the reward functions add up to " + formatNumber(r(ws, wa), 6) + " in state " +
                    std::to_string(ws) + " under action " + std::to_string(wa) +
                    ", outside [-" + formatNumber(Model::kMaxAbsReward, 6) + ", " +
                    formatNumber(Model::kMaxAbsReward, 6) + "], the limit that keeps "
                    "|R| / (1 - discount) and |R| * horizon finite");
}

Eigen::VectorXd Reader::initialBelief(const std::vector<Table>& belief) {
  Eigen::VectorXd b0(static_cast<Eigen::Index>(S_));
  for (std::size_t s = 0; s < S_; ++s) {
    setState(s, false);
    double p = 1.0;
    for (const Table& t : belief) {
      std::size_t cell = rowIndex(t, ctx_) * t.rowLen, m = t.rowLen;
      for (std::size_t k = t.nParents; k < t.refs.size(); ++k) {
        m /= t.dims[k];
        cell += ctx_[t.slots[k]] * m;
      }
      p *= t.v[cell];
    }
    b0(static_cast<Eigen::Index>(s)) = p;
  }
  return b0;
}

Model Reader::buildModel(std::vector<SparseRows> tCsr, std::vector<SparseRows> zCsr,
                         Eigen::MatrixXd r, double discount, const Eigen::VectorXd* b0,
                         std::size_t entries, std::vector<Table>& trans,
                         std::vector<Table>& obs, const XMLElement* root) {
  const std::size_t S = S_, A = A_, O = O_;
  std::size_t nnzT = 0;
  for (const auto& t : tCsr) nnzT += t.entries.size();
  const double cells = static_cast<double>(A) * S * S;
  const bool denseT = (S <= Model::kDenseStates || nnzT >= Model::kDenseDensity * cells) &&
                      2.0 * cells * sizeof(double) <= static_cast<double>(Model::kDenseBytes);
  ModelStorage storage = ModelStorage::kAuto;
  if (denseT && S > Model::kDenseStates &&
      saturatingAdd(needBytes(entries), static_cast<std::size_t>(2.0 * cells * sizeof(double))) >
          budget_)
    storage = ModelStorage::kSparse;
  std::vector<std::string> sNames = flatNames(stateOrder_, S, "s", "s0");
  std::vector<std::string> aNames = flatNames(actionOrder_, A, "a", "a0");
  std::vector<std::string> oNames = flatNames(obsOrder_, O, "o", "none");
  // Tables are no longer needed: release them before the Model copies T and O.
  std::vector<Table>().swap(trans);
  std::vector<Table>().swap(obs);
  try {
    const double left = timeout_ > 0.0 ? std::max(1e-9, timeout_ - clock_.seconds()) : 0.0;
    Model m(std::move(tCsr), std::move(zCsr), std::move(r), discount, left, storage);
    m.setNames(std::move(sNames), std::move(aNames), std::move(oNames));
    if (b0) m.setInitialBelief(*b0);
    return m;
  } catch (const ConfigError& e) {
    if (timeout_ > 0.0 && clock_.seconds() > timeout_)
      fail(root, "reading stopped while building the model: time budget of " +
                     formatNumber(timeout_, 6) + " s exceeded");
    fail(root, std::string("invalid model: ") + e.what());
  }
}

// ---- writer ----------------------------------------------------------------------------------

std::string fmt(double v) {
  std::ostringstream ss;
  ss.precision(17);
  ss << v;
  return ss.str();
}

std::string xmlEscape(const std::string& s) {
  std::string out;
  for (char c : s) {
    switch (c) {
      case '&': out += "&amp;"; break;
      case '<': out += "&lt;"; break;
      case '>': out += "&gt;"; break;
      case '"': out += "&quot;"; break;
      default: out += c;
    }
  }
  return out;
}

void checkNames(const std::vector<std::string>& names, const char* kind) {
  for (const auto& n : names) {
    bool ok = !n.empty() && n != "*" && n != "-";
    for (char c : n) ok = ok && !std::isspace(static_cast<unsigned char>(c));
    if (!ok)
      throw ConfigError(std::string("writePomdpx: ") + kind + " name '" + n +
                        "' cannot be a PomdpX value (empty, white space, '*' or '-')");
  }
}

std::string joined(const std::vector<std::string>& names) {
  std::string out;
  for (const auto& n : names) out += (out.empty() ? "" : " ") + xmlEscape(n);
  return out;
}

/// One sparse row as entries: the whole row with '-' when that is shorter.
void writeRow(std::ostringstream& ss, const std::string& prefix, const EntryRange& row,
              const std::vector<std::string>& colNames, const char* table) {
  const std::size_t n = colNames.size();
  if (row.size() * 4 > n) {
    ss << "      <Entry><Instance>" << prefix << " -</Instance><" << table << ">";
    std::size_t k = 0;
    for (std::size_t c = 0; c < n; ++c) {
      const double p = k < row.size() && row[k].first == c ? row[k++].second : 0.0;
      ss << (c ? " " : "") << fmt(p);
    }
    ss << "</" << table << "></Entry>\n";
    return;
  }
  for (const auto& e : row)
    ss << "      <Entry><Instance>" << prefix << ' ' << xmlEscape(colNames[e.first])
       << "</Instance><" << table << ">" << fmt(e.second) << "</" << table << "></Entry>\n";
}

bool sameRow(const EntryRange& x, const EntryRange& y) {
  if (x.size() != y.size()) return false;
  for (std::size_t k = 0; k < x.size(); ++k)
    if (x[k].first != y[k].first || x[k].second != y[k].second) return false;
  return true;
}

}  // namespace

Model readPomdpx(const std::string& text, const std::string& file, const CassandraLimits& limits,
                 CassandraStats* stats) {
  return Reader(text, file, limits, stats).read();
}

Model loadPomdpx(const std::string& path, const CassandraLimits& limits, CassandraStats* stats) {
  return readPomdpx(readFile(path), path, limits, stats);
}

std::string writePomdpx(const Model& m) {
  const auto& sn = m.stateNames();
  const auto& an = m.actionNames();
  const auto& on = m.observationNames();
  checkNames(sn, "state");
  checkNames(an, "action");
  checkNames(on, "observation");
  std::ostringstream ss;
  ss << "<?xml version=\"1.0\" encoding=\"UTF-8\"?>\n"
     << "<!-- POMDP written by krr_core (krr::pomdp::writePomdpx) -->\n"
     << "<pomdpx version=\"1.0\" id=\"krr_model\">\n"
     << "  <Discount>" << fmt(m.getDiscount()) << "</Discount>\n"
     << "  <Variable>\n"
     << "    <StateVar vnamePrev=\"state_0\" vnameCurr=\"state_1\" fullyObs=\"false\">"
     << "<ValueEnum>" << joined(sn) << "</ValueEnum></StateVar>\n"
     << "    <ObsVar vname=\"obs\"><ValueEnum>" << joined(on) << "</ValueEnum></ObsVar>\n"
     << "    <ActionVar vname=\"action\"><ValueEnum>" << joined(an) << "</ValueEnum></ActionVar>\n"
     << "    <RewardVar vname=\"reward\"/>\n"
     << "  </Variable>\n";
  ss << "  <InitialStateBelief>\n    <CondProb><Var>state_0</Var><Parent>null</Parent>\n"
     << "    <Parameter type=\"TBL\">\n      <Entry><Instance>-</Instance><ProbTable>";
  for (Eigen::Index i = 0; i < m.initialBelief().size(); ++i)
    ss << (i ? " " : "") << fmt(m.initialBelief()(i));
  ss << "</ProbTable></Entry>\n    </Parameter></CondProb>\n  </InitialStateBelief>\n";
  ss << "  <StateTransitionFunction>\n    <CondProb><Var>state_1</Var>"
     << "<Parent>action state_0</Parent>\n    <Parameter type=\"TBL\">\n";
  for (std::size_t a = 0; a < m.getA(); ++a) {
    if (m.isIdentityTransition(a)) {
      ss << "      <Entry><Instance>" << xmlEscape(an[a])
         << " - -</Instance><ProbTable>identity</ProbTable></Entry>\n";
      continue;
    }
    for (std::size_t s = 0; s < m.getS(); ++s)
      writeRow(ss, xmlEscape(an[a]) + ' ' + xmlEscape(sn[s]), m.successors(s, a), sn, "ProbTable");
  }
  ss << "    </Parameter></CondProb>\n  </StateTransitionFunction>\n";
  ss << "  <ObsFunction>\n    <CondProb><Var>obs</Var><Parent>action state_1</Parent>\n"
     << "    <Parameter type=\"TBL\">\n";
  for (std::size_t s1 = 0; s1 < m.getS(); ++s1) {
    bool same = true;  // the same row after every action: one '*' entry
    for (std::size_t a = 1; a < m.getA() && same; ++a)
      same = sameRow(m.observationRow(s1, 0), m.observationRow(s1, a));
    if (same) {
      writeRow(ss, "* " + xmlEscape(sn[s1]), m.observationRow(s1, 0), on, "ProbTable");
      continue;
    }
    for (std::size_t a = 0; a < m.getA(); ++a)
      writeRow(ss, xmlEscape(an[a]) + ' ' + xmlEscape(sn[s1]), m.observationRow(s1, a), on,
               "ProbTable");
  }
  ss << "    </Parameter></CondProb>\n  </ObsFunction>\n";
  ss << "  <RewardFunction>\n    <Func><Var>reward</Var><Parent>action state_0</Parent>\n"
     << "    <Parameter type=\"TBL\">\n";
  for (std::size_t a = 0; a < m.getA(); ++a)
    for (std::size_t s = 0; s < m.getS(); ++s) {
      const double v = m.getExpectedReward(s, a);
      if (v != 0.0)
        ss << "      <Entry><Instance>" << xmlEscape(an[a]) << ' ' << xmlEscape(sn[s])
           << "</Instance><ValueTable>" << fmt(v) << "</ValueTable></Entry>\n";
    }
  ss << "    </Parameter></Func>\n  </RewardFunction>\n</pomdpx>\n";
  return ss.str();
}

void savePomdpx(const std::string& path, const Model& model) {
  writeFileAtomic(path, writePomdpx(model));
}

Model loadPomdpFile(const std::string& path, const CassandraLimits& limits,
                    CassandraStats* stats) {
  auto endsWith = [&](const std::string& suffix) {
    return path.size() >= suffix.size() &&
           lower(path.substr(path.size() - suffix.size())) == suffix;
  };
  if (endsWith(".pomdpx")) return loadPomdpx(path, limits, stats);
  if (endsWith(".pomdp")) return loadCassandra(path, limits, stats);
  const std::string text = readFile(path);
  const std::size_t p = text.find_first_not_of(" \t\r\n");
  if (p != std::string::npos && text[p] == '<') return readPomdpx(text, path, limits, stats);
  return readCassandra(text, path, limits, stats);
}

}  // namespace pomdp
}  // namespace krr
