#include "krr_core/pomdp/cassandra_io.h"

#include <algorithm>
#include <cctype>
#include <cerrno>
#include <cmath>
#include <cstdlib>
#include <functional>
#include <sstream>
#include <unordered_map>

#include "krr_core/common/errors.h"
#include "krr_core/common/files.h"
#include "krr_core/common/format.h"
#include "krr_core/common/limits.h"
#include "krr_core/common/resources.h"

namespace krr {
namespace pomdp {

namespace {

struct Token {
  std::string text;
  int line;
  int col;
};

/// @brief Number of tokens tokenize() will produce, so that the token list is checked against
/// the memory budget before it is built (one token per two bytes is possible).
std::size_t countTokens(const std::string& text) {
  std::size_t n = 0;
  bool inToken = false, inComment = false;
  for (char c : text) {
    if (inComment) {
      inComment = c != '\n';
      continue;
    }
    if (c == '#') {
      inComment = true;
      inToken = false;
    } else if (std::isspace(static_cast<unsigned char>(c))) {
      inToken = false;
    } else if (c == ':') {
      ++n;
      inToken = false;
    } else if (!inToken) {
      ++n;
      inToken = true;
    }
  }
  return n;
}

std::vector<Token> tokenize(const std::string& text) {
  std::vector<Token> out;
  out.reserve(countTokens(text));
  int line = 1, col = 1;
  std::size_t i = 0;
  auto advance = [&](char c) {
    if (c == '\n') {
      ++line;
      col = 1;
    } else {
      ++col;
    }
  };
  while (i < text.size()) {
    char c = text[i];
    if (c == '#') {
      while (i < text.size() && text[i] != '\n') advance(text[i++]);
      continue;
    }
    if (std::isspace(static_cast<unsigned char>(c))) {
      advance(c);
      ++i;
      continue;
    }
    if (c == ':') {
      out.push_back({":", line, col});
      advance(c);
      ++i;
      continue;
    }
    Token t{"", line, col};
    while (i < text.size() && !std::isspace(static_cast<unsigned char>(text[i])) &&
           text[i] != ':' && text[i] != '#') {
      t.text += text[i];
      advance(text[i++]);
    }
    out.push_back(t);
  }
  return out;
}

bool isNumber(const std::string& s, double* v) {
  if (s.empty()) return false;
  const char* p = s.c_str();
  char* e = nullptr;
  errno = 0;
  double d = std::strtod(p, &e);
  if (e == p || *e != '\0' || errno == ERANGE || !std::isfinite(d)) return false;
  if (v) *v = d;
  return true;
}

bool isInteger(const std::string& s, long* v) {
  if (s.empty()) return false;
  for (char c : s)
    if (!std::isdigit(static_cast<unsigned char>(c))) return false;
  errno = 0;
  long x = std::strtol(s.c_str(), nullptr, 10);
  if (errno == ERANGE) return false;
  if (v) *v = x;
  return true;
}

const char* kKeywords[] = {"discount", "values", "states", "actions", "observations", "start",
                           "T", "O", "R"};

/// One symbol set (states, actions or observations): a count or names.
struct Symbols {
  bool defined = false;
  std::size_t n = 0;
  std::vector<std::string> names;  // empty: numbered only
  /// name -> index: lookups and duplicate checks stay O(1) for long name lists.
  std::unordered_map<std::string, std::size_t> index;
};

/// Bytes per stored T or O entry: its place in the reader's row list and in the Model's CSR.
constexpr std::size_t kBytesPerEntry = 2 * sizeof(Model::Entry);

/// -1 stands for the '*' wildcard.
using Idx = long;

class Parser {
 public:
  Parser(const std::string& text, const std::string& file, const CassandraLimits& limits,
         CassandraStats* stats)
      : file_(file),
        budget_(limits.memory_budget ? limits.memory_budget : memoryBudget()),
        timeout_(limits.timeout),
        extraPerPair_(limits.extra_bytes_per_state_pair),
        sumTolerance_(limits.sum_tolerance),
        stats_(stats ? stats : &ownStats_) {
    if (!(sumTolerance_ >= 0.0 && sumTolerance_ < 0.5))
      throw ConfigError("readCassandra: sum_tolerance " + formatNumber(sumTolerance_, 6) +
                        " outside [0, 0.5)");
    *stats_ = CassandraStats();
    // Each token costs sizeof(Token) plus its text beyond the small-string buffer.
    const std::size_t tokens = countTokens(text);
    const std::size_t need = saturatingAdd(saturatingMul(tokens, sizeof(Token)), text.size());
    if (need > budget_)
      throw ParseError(SourceLocation{file_, 1, 1},
                       "file has " + std::to_string(tokens) + " tokens, parsing it needs about " +
                           formatBytes(need) + ", above the memory budget of " +
                           formatBytes(budget_) + " (KRR_MEMORY_BUDGET_MIB)");
    // A NUL byte would end a token's C string early ("0.95\0junk" read as 0.95): refused at
    // its own position, whatever follows it.
    if (const std::size_t nul = text.find('\0'); nul != std::string::npos) {
      int line = 1, col = 1;
      for (std::size_t i = 0; i < nul; ++i) {
        if (text[i] == '\n') {
          ++line;
          col = 1;
        } else {
          ++col;
        }
      }
      throw ParseError(SourceLocation{file_, line, col},
                       "NUL byte (\\0) in the file: a .pomdp file is text");
    }
    toks_ = tokenize(text);
    int l = 1, c = 1;
    for (char ch : text) {
      if (ch == '\n') {
        ++l;
        c = 1;
      } else {
        ++c;
      }
    }
    eof_ = {"<end of file>", l, c};
  }

  Model parse();

 private:
  [[noreturn]] void fail(const Token& t, const std::string& msg) const {
    throw ParseError(SourceLocation{file_, t.line, t.col}, msg);
  }
  /// @brief Stop with an error at t once the time budget is spent.
  void checkTime(const Token& t) const {
    if (timeout_ > 0.0 && clock_.seconds() > timeout_)
      fail(t, "reading stopped here: time budget of " + formatNumber(timeout_, 6) +
                  " s exceeded");
  }
  /// @brief Bytes the model needs with entries_ stored entries (at least one per row before
  /// the rows are filled): the declarations' part plus the entries seen so far.
  std::size_t needBytes(std::size_t entries) const {
    auto count = [](const Symbols& sym) { return std::max<std::size_t>(sym.n, 1); };
    const std::size_t S = count(states_), A = count(actions_), O = count(obs_);
    const std::size_t rows = saturatingMul(saturatingMul(A, S), 2);
    const std::size_t beyond = entries > rows ? entries - rows : 0;  // estimate counts 1 per row
    return saturatingAdd(saturatingAdd(estimateModelBytes(S, A, O),
                                       saturatingMul(beyond, kBytesPerEntry)),
                         saturatingMul(saturatingMul(S, S), extraPerPair_));
  }
  /// @brief Refuse a declaration (at t) whose model would not fit in the memory budget.
  /// Undeclared counts are taken as 1, the least they can be. The number of non-zero T and O
  /// entries is not declared: this is the least the model can take (one entry per row), and
  /// reserveEntries() checks the entries as they arrive.
  void checkModelSize(const Token& t, const std::string& decl) const {
    auto count = [](const Symbols& sym) { return std::max<std::size_t>(sym.n, 1); };
    const std::size_t S = count(states_), A = count(actions_), O = count(obs_);
    const std::size_t need = needBytes(0);
    if (need > budget_)
      fail(t, decl + " needs about " + formatBytes(need) + " for the model (" +
                  std::to_string(S) + " states, " + std::to_string(A) + " action(s), " +
                  std::to_string(O) + " observation(s), at least one entry per T and O row), "
                  "above the memory budget of " + formatBytes(budget_) +
                  " (KRR_MEMORY_BUDGET_MIB)");
  }
  /// @brief Refuse (at t) a statement that would store `more` further T or O entries beyond
  /// the memory budget, before they are stored.
  void reserveEntries(const Token& t, std::size_t more) const {
    const std::size_t need = needBytes(saturatingAdd(entries_, more));
    if (need > budget_)
      fail(t, "this statement brings the model to " + std::to_string(entries_ + more) +
                  " non-zero T and O entries, about " + formatBytes(need) +
                  ", above the memory budget of " + formatBytes(budget_) +
                  " (KRR_MEMORY_BUDGET_MIB)");
  }
  const Token& peek(std::size_t k = 0) const {
    return pos_ + k < toks_.size() ? toks_[pos_ + k] : eof_;
  }
  bool atEnd() const { return pos_ >= toks_.size(); }
  const Token& next(const char* what) {
    if (atEnd()) fail(eof_, std::string("unexpected end of file, expected ") + what);
    return toks_[pos_++];
  }
  void expectColon() {
    const Token& t = next("':'");
    if (t.text != ":") fail(t, "expected ':', got '" + t.text + "'");
  }
  bool isKeywordStart(std::size_t k) const {
    if (pos_ + k >= toks_.size()) return true;
    const std::string& s = toks_[pos_ + k].text;
    for (const char* kw : kKeywords)
      if (s == kw) {
        const std::string& n = peek(k + 1).text;
        return n == ":" || (s == "start" && (n == "include" || n == "exclude"));
      }
    return false;
  }
  double number(const char* what) {
    const Token& t = next(what);
    double v = 0.0;
    if (!isNumber(t.text, &v)) fail(t, std::string("expected ") + what + ", got '" + t.text + "'");
    return v;
  }
  /// @brief A reward entry: |R| <= Model::kMaxAbsReward, so that every bound stays finite.
  double reward() {
    const Token& t = peek();
    const double v = number("reward value");
    if (std::abs(v) > Model::kMaxAbsReward)
      fail(t, "reward " + t.text + " is outside [-" + formatNumber(Model::kMaxAbsReward, 6) +
                  ", " + formatNumber(Model::kMaxAbsReward, 6) + "], the limit that keeps "
                  "|R| / (1 - discount) and |R| * horizon finite");
    return v;
  }
  double probability(const char* what) {
    const Token& t = peek();
    double v = number(what);
    if (v < 0.0 || v > 1.0 + sumTolerance_)
      fail(t, std::string(what) + " " + t.text + " is not in [0, 1]");
    return v;
  }
  void symbolList(Symbols& sym, const char* kind) {
    const Token& kw = toks_[pos_ - 2];
    if (sym.defined) fail(kw, std::string(kind) + " defined twice");
    sym.defined = true;
    long n = 0;
    // A number is a count, never a name ("states: -2" is not a state named -2): anything but
    // a positive integer is refused at its own token.
    if (!atEnd() && isNumber(peek().text, nullptr) && !isInteger(peek().text, nullptr))
      fail(peek(), std::string("number of ") + kind + " must be a positive integer, got '" +
                       peek().text + "'");
    if (!atEnd() && isInteger(peek().text, &n) && isKeywordStart(1)) {
      if (n <= 0) fail(peek(), std::string("number of ") + kind + " must be positive");
      sym.n = static_cast<std::size_t>(n);
      checkModelSize(peek(), std::string(kind) + ": " + peek().text);
      ++pos_;
      return;
    }
    while (!isKeywordStart(0)) {
      if (peek(1).text == ":" || peek().text == ":")
        fail(peek(), "expected one of discount, values, states, actions, "
             "observations, start, T, O, R; got '" + peek().text + "'");
      const Token& t = next("a name");
      if (t.text == "*") fail(t, "'*' is not a valid name");
      if (isNumber(t.text, nullptr))
        fail(t, std::string("'") + t.text + "' is a number, not a name: " + kind +
                    " are a positive count or a list of names");
      if (!sym.index.emplace(t.text, sym.names.size()).second)
        fail(t, std::string("duplicate ") + kind + " name '" + t.text + "'");
      sym.names.push_back(t.text);
      sym.n = sym.names.size();
      if ((sym.n & 1023) == 0) {  // a long list is refused as soon as it is too large
        checkModelSize(t, std::string(kind) + ": (" + std::to_string(sym.n) + " names so far)");
        checkTime(t);
      }
    }
    if (sym.names.empty()) fail(peek(), std::string("expected a count or names of ") + kind);
    sym.n = sym.names.size();
    checkModelSize(kw, std::string(kind) + ": (" + std::to_string(sym.n) + " names)");
  }
  Idx symbol(const Symbols& sym, const char* kind, bool allowWildcard) {
    const Token& t = next(kind);
    if (!sym.defined) fail(t, std::string(kind) + " used before they are declared");
    if (t.text == "*") {
      if (!allowWildcard) fail(t, "wildcard '*' not allowed here");
      return -1;
    }
    const auto it = sym.index.find(t.text);
    if (it != sym.index.end()) return static_cast<Idx>(it->second);
    long v = 0;
    if (isInteger(t.text, &v)) {
      if (static_cast<std::size_t>(v) >= sym.n)
        fail(t, std::string(kind) + " index " + t.text + " out of range (" +
                    std::to_string(sym.n) + " " + kind + "s)");
      return v;
    }
    fail(t, std::string("unknown ") + kind + " '" + t.text + "'");
  }
  std::vector<std::size_t> range(Idx i, std::size_t n) const {
    std::vector<std::size_t> out;
    if (i >= 0) {
      out.push_back(static_cast<std::size_t>(i));
    } else {
      for (std::size_t k = 0; k < n; ++k) out.push_back(k);
    }
    return out;
  }
  void requireAll(const Token& t) {
    if (!states_.defined || !actions_.defined || !obs_.defined)
      fail(t, "T:, O: and R: need states, actions and observations declared first");
    if (tRows_.empty()) {
      tRows_.assign(actions_.n * states_.n, {});
      zRows_.assign(actions_.n * states_.n, {});
      tLoc_.assign(actions_.n * states_.n, Token{"", 0, 0});
      zLoc_.assign(actions_.n * states_.n, Token{"", 0, 0});
      checkTime(t);
    }
  }
  /// @brief One statement, from its keyword (the statement's first token).
  void parseStatement();
  void parseStart();
  void parseT();
  void parseO();
  void parseR();
  /// @brief Normalises every T and O row, or fails at the statement that last wrote a row
  /// whose probabilities do not sum to 1 (here, so that the error points at that entry).
  void validateRows();
  /// @brief R(s, a): the R statements, in expectation over s' and o where they depend on them.
  Eigen::MatrixXd expectedRewards();
  /// @brief The Model, its T and O rows moved into CSR form (the row lists are released).
  Model buildModel(Eigen::MatrixXd r);
  void setT(Idx a, Idx s, Idx s1, double p, const Token& where);
  void setZ(Idx a, Idx s1, Idx o, double p, const Token& where);
  /// @brief The readers' shared rule (checkDistributionSum): false if sum is off by more than
  /// the tolerance; else *divisor is what the entries are divided by (1: kept as written).
  template <typename Where>
  bool acceptSum(double sum, Where where, double* divisor) {
    return checkDistributionSum(sum, sumTolerance_, *stats_, where, divisor);
  }

  std::string file_;
  std::size_t budget_;
  double timeout_;
  std::size_t extraPerPair_;
  double sumTolerance_;
  CassandraStats ownStats_;
  CassandraStats* stats_;
  Stopwatch clock_;
  std::vector<Token> toks_;
  Token eof_;
  std::size_t pos_ = 0;
  bool haveDiscount_ = false, cost_ = false, haveStart_ = false;
  double discount_ = 1.0;
  Symbols states_, actions_, obs_;
  Eigen::VectorXd start_;
  /// T rows (index a * S + s) and O rows (a * S + s1): sorted (column, p), no zeros. Sparse,
  /// so that a 3201-state RockSample takes megabytes, not the 3.7 GiB of dense tables.
  std::vector<std::vector<Model::Entry>> tRows_, zRows_;
  std::size_t entries_ = 0;  ///< entries stored in tRows_ and zRows_
  std::vector<Token> tLoc_, zLoc_;
  /// @brief row[k] = p (later statements override earlier ones; p = 0 removes the entry).
  void setEntry(std::vector<Model::Entry>& row, std::size_t k, double p);
  /// @brief Every entry of row set to p (a '*' column).
  void setWholeRow(std::vector<Model::Entry>& row, std::size_t n, double p);
  struct REntry {
    Idx a, s, s1, o;
    double v;
  };
  std::vector<REntry> r_;
};

void Parser::setEntry(std::vector<Model::Entry>& row, std::size_t k, double p) {
  if (row.empty() || row.back().first < k) {  // the common case: columns in order
    if (p != 0.0) {
      row.emplace_back(k, p);
      ++entries_;
    }
    return;
  }
  auto it = std::lower_bound(row.begin(), row.end(), k,
                             [](const Model::Entry& e, std::size_t c) { return e.first < c; });
  if (it != row.end() && it->first == k) {
    if (p != 0.0) {
      it->second = p;
    } else {
      row.erase(it);
      --entries_;
    }
  } else if (p != 0.0) {
    row.insert(it, Model::Entry(k, p));
    ++entries_;
  }
}

void Parser::setWholeRow(std::vector<Model::Entry>& row, std::size_t n, double p) {
  entries_ -= row.size();
  row.clear();
  if (p == 0.0) {
    row.shrink_to_fit();
    return;
  }
  row.reserve(n);
  for (std::size_t k = 0; k < n; ++k) row.emplace_back(k, p);
  entries_ += n;
}

void Parser::setT(Idx a, Idx s, Idx s1, double p, const Token& where) {
  const auto ss = range(s, states_.n), as = range(a, actions_.n);
  const std::size_t S = states_.n;
  if (p != 0.0)  // refused before it is stored
    reserveEntries(where, saturatingMul(as.size() * ss.size(), s1 < 0 ? S : 1));
  for (std::size_t ai : as) {
    for (std::size_t si : ss) {
      auto& row = tRows_[ai * S + si];
      if (s1 < 0) {
        setWholeRow(row, S, p);
      } else {
        setEntry(row, static_cast<std::size_t>(s1), p);
      }
      tLoc_[ai * S + si] = where;
    }
    if (ss.size() > 1) checkTime(where);
  }
}

void Parser::setZ(Idx a, Idx s1, Idx o, double p, const Token& where) {
  const auto ss = range(s1, states_.n), as = range(a, actions_.n);
  const std::size_t S = states_.n;
  if (p != 0.0)
    reserveEntries(where, saturatingMul(as.size() * ss.size(), o < 0 ? obs_.n : 1));
  for (std::size_t ai : as) {
    for (std::size_t si : ss) {
      auto& row = zRows_[ai * S + si];
      if (o < 0) {
        setWholeRow(row, obs_.n, p);
      } else {
        setEntry(row, static_cast<std::size_t>(o), p);
      }
      zLoc_[ai * S + si] = where;
    }
    if (ss.size() > 1) checkTime(where);
  }
}

void Parser::parseStart() {
  const bool list = peek().text == "include" || peek().text == "exclude";
  const Token& kw = toks_[pos_ - (list ? 1 : 2)];
  if (!states_.defined) fail(kw, "start: needs states declared first");
  const auto S = static_cast<Eigen::Index>(states_.n);
  haveStart_ = true;
  if (list) {
    const bool include = next("include").text == "include";
    expectColon();
    std::vector<char> listed(states_.n, 0);
    bool any = false;
    while (!isKeywordStart(0)) {
      Idx s = symbol(states_, "state", false);
      listed[static_cast<std::size_t>(s)] = 1;
      any = true;
    }
    if (!any) fail(peek(), "expected state names after start " + std::string(include ? "include" : "exclude"));
    start_ = Eigen::VectorXd::Zero(S);
    for (std::size_t s = 0; s < states_.n; ++s)
      if (static_cast<bool>(listed[s]) == include) start_(s) = 1.0;
    if (start_.sum() == 0.0) fail(kw, "start exclude: excludes every state");
    start_ /= start_.sum();
    return;
  }
  const Token& t = peek();
  if (t.text == "uniform") {
    ++pos_;
    start_ = Eigen::VectorXd::Constant(S, 1.0 / states_.n);
    return;
  }
  // A single state (name, or index when S > 1) followed by a keyword: that state surely.
  if (isKeywordStart(1) && (!isNumber(t.text, nullptr) || (states_.n > 1 && isInteger(t.text, nullptr)))) {
    Idx s = symbol(states_, "state", false);
    start_ = Eigen::VectorXd::Zero(S);
    start_(s) = 1.0;
    return;
  }
  start_.resize(S);
  for (Eigen::Index i = 0; i < S; ++i) start_(i) = probability("start probability");
  double divisor = 1.0;
  if (!acceptSum(start_.sum(), [] { return std::string("start vector"); }, &divisor))
    fail(t, "start probabilities sum to " + std::to_string(start_.sum()) + " (expected 1)");
  start_ /= divisor;
}

void Parser::parseT() {
  const Token& kw = toks_[pos_ - 2];
  requireAll(kw);
  Idx a = symbol(actions_, "action", true);
  if (peek().text != ":") {  // matrix form
    const Token& t = peek();
    if (t.text == "identity" || t.text == "uniform") {
      ++pos_;
      if (t.text == "identity") {
        for (std::size_t s = 0; s < states_.n; ++s) {
          const auto si = static_cast<Idx>(s);
          setT(a, si, -1, 0.0, kw);
          setT(a, si, si, 1.0, kw);
        }
      } else {
        setT(a, -1, -1, 1.0 / states_.n, kw);
      }
      return;
    }
    for (std::size_t s = 0; s < states_.n; ++s)
      for (std::size_t k = 0; k < states_.n; ++k)
        setT(a, static_cast<Idx>(s), static_cast<Idx>(k), probability("transition probability"), kw);
    return;
  }
  expectColon();
  Idx s = symbol(states_, "state", true);
  if (peek().text != ":") {  // row form
    if (peek().text == "uniform") {
      ++pos_;
      setT(a, s, -1, 1.0 / states_.n, kw);
      return;
    }
    for (std::size_t k = 0; k < states_.n; ++k)
      setT(a, s, static_cast<Idx>(k), probability("transition probability"), kw);
    return;
  }
  expectColon();
  Idx s1 = symbol(states_, "state", true);
  setT(a, s, s1, probability("transition probability"), kw);
}

void Parser::parseO() {
  const Token& kw = toks_[pos_ - 2];
  requireAll(kw);
  Idx a = symbol(actions_, "action", true);
  if (peek().text != ":") {  // matrix form
    if (peek().text == "uniform") {
      ++pos_;
      setZ(a, -1, -1, 1.0 / obs_.n, kw);
      return;
    }
    for (std::size_t s = 0; s < states_.n; ++s)
      for (std::size_t o = 0; o < obs_.n; ++o)
        setZ(a, static_cast<Idx>(s), static_cast<Idx>(o), probability("observation probability"), kw);
    return;
  }
  expectColon();
  Idx s1 = symbol(states_, "state", true);
  if (peek().text != ":") {  // row form
    if (peek().text == "uniform") {
      ++pos_;
      setZ(a, s1, -1, 1.0 / obs_.n, kw);
      return;
    }
    for (std::size_t o = 0; o < obs_.n; ++o)
      setZ(a, s1, static_cast<Idx>(o), probability("observation probability"), kw);
    return;
  }
  expectColon();
  Idx o = symbol(obs_, "observation", true);
  setZ(a, s1, o, probability("observation probability"), kw);
}

void Parser::parseR() {
  const Token& kw = toks_[pos_ - 2];
  requireAll(kw);
  Idx a = symbol(actions_, "action", true);
  expectColon();
  Idx s = symbol(states_, "state", true);
  if (peek().text != ":") {  // matrix S' x O
    for (std::size_t s1 = 0; s1 < states_.n; ++s1)
      for (std::size_t o = 0; o < obs_.n; ++o)
        r_.push_back({a, s, static_cast<Idx>(s1), static_cast<Idx>(o), reward()});
    return;
  }
  expectColon();
  Idx s1 = symbol(states_, "state", true);
  if (peek().text != ":") {  // row over O
    for (std::size_t o = 0; o < obs_.n; ++o)
      r_.push_back({a, s, s1, static_cast<Idx>(o), reward()});
    return;
  }
  expectColon();
  Idx o = symbol(obs_, "observation", true);
  r_.push_back({a, s, s1, o, reward()});
}

Model Parser::parse() {
  while (!atEnd()) parseStatement();
  if (!haveDiscount_) fail(eof_, "missing 'discount:'");
  if (!states_.defined) fail(eof_, "missing 'states:'");
  if (!actions_.defined) fail(eof_, "missing 'actions:'");
  if (!obs_.defined) fail(eof_, "missing 'observations:'");
  requireAll(eof_);
  validateRows();
  Eigen::MatrixXd r = expectedRewards();
  if (cost_) r = -r;
  return buildModel(std::move(r));
}

void Parser::parseStatement() {
  checkTime(peek());
  const Token& kw = next("a keyword");
  if (kw.text == "start" && (peek().text == "include" || peek().text == "exclude")) {
    parseStart();
    return;
  }
  bool known = false;
  for (const char* k : kKeywords) known = known || kw.text == k;
  if (!known)
    fail(kw, "expected one of discount, values, states, actions, observations, start, T, O, R; got '" +
                 kw.text + "'");
  expectColon();
  if (kw.text == "discount") {
    const Token& t = peek();
    discount_ = number("discount");
    if (!(discount_ > 0.0 && discount_ <= 1.0)) fail(t, "discount " + t.text + " outside (0, 1]");
    haveDiscount_ = true;
  } else if (kw.text == "values") {
    const Token& t = next("reward or cost");
    if (t.text != "reward" && t.text != "cost")
      fail(t, "values must be 'reward' or 'cost', got '" + t.text + "'");
    cost_ = t.text == "cost";
  } else if (kw.text == "states") {
    symbolList(states_, "states");
  } else if (kw.text == "actions") {
    symbolList(actions_, "actions");
  } else if (kw.text == "observations") {
    symbolList(obs_, "observations");
  } else if (kw.text == "start") {
    parseStart();
  } else if (kw.text == "T") {
    parseT();
  } else if (kw.text == "O") {
    parseO();
  } else {
    parseR();
  }
}

void Parser::validateRows() {
  auto rowSum = [](const std::vector<Model::Entry>& row) {
    double sum = 0.0;
    for (const auto& e : row) sum += e.second;
    return sum;
  };
  auto scale = [](std::vector<Model::Entry>& row, double divisor) {
    if (divisor != 1.0)
      for (auto& e : row) e.second /= divisor;
  };
  for (std::size_t a = 0; a < actions_.n; ++a) {
    for (std::size_t s = 0; s < states_.n; ++s) {
      if ((s & 255) == 0) checkTime(eof_);
      auto name = [&](const Symbols& sym, std::size_t i) {
        return sym.names.empty() ? std::to_string(i) : sym.names[i];
      };
      auto& trow = tRows_[a * states_.n + s];
      const double ts = rowSum(trow);
      double tDiv = 1.0;
      if (ts != 1.0 && !acceptSum(ts, [&] {
            return "T row of action '" + name(actions_, a) + "' from state '" +
                   name(states_, s) + "'";
          }, &tDiv))
        fail(tLoc_[a * states_.n + s].line ? tLoc_[a * states_.n + s] : eof_,
             "transition probabilities of action '" + name(actions_, a) + "' from state '" +
                 name(states_, s) + "' sum to " + formatNumber(ts, 10) +
                 " (expected 1 within " + formatNumber(sumTolerance_, 3) + ")");
      scale(trow, tDiv);
      auto& zrow = zRows_[a * states_.n + s];
      const double zs = rowSum(zrow);
      double zDiv = 1.0;
      if (zs != 1.0 && !acceptSum(zs, [&] {
            return "O row of action '" + name(actions_, a) + "' in state '" + name(states_, s) +
                   "'";
          }, &zDiv))
        fail(zLoc_[a * states_.n + s].line ? zLoc_[a * states_.n + s] : eof_,
             "observation probabilities of action '" + name(actions_, a) + "' in state '" +
                 name(states_, s) + "' sum to " + formatNumber(zs, 10) +
                 " (expected 1 within " + formatNumber(sumTolerance_, 3) + ")");
      scale(zrow, zDiv);
    }
  }
}

Eigen::MatrixXd Parser::expectedRewards() {
  const std::size_t S = states_.n, A = actions_.n, O = obs_.n;
  Eigen::MatrixXd r = Eigen::MatrixXd::Zero(static_cast<Eigen::Index>(S), static_cast<Eigen::Index>(A));
  bool simple = true;
  for (const auto& e : r_) simple = simple && e.s1 < 0 && e.o < 0;
  if (simple) {
    for (const auto& e : r_)
      for (std::size_t a : range(e.a, A))
        for (std::size_t s : range(e.s, S)) r(s, a) = e.v;
    return r;
  }
  const double cells = static_cast<double>(A) * S * S * O;
  if (cells > 5e7 || cells * sizeof(double) + static_cast<double>(estimateModelBytes(S, A, O)) >
                         static_cast<double>(budget_))
    fail(eof_, "model too large for next-state/observation dependent rewards (" +
                   formatBytes(static_cast<std::size_t>(cells * sizeof(double))) +
                   " of reward table, memory budget " + formatBytes(budget_) + ")");
  std::vector<double> full(static_cast<std::size_t>(cells), 0.0);
  auto at = [&](std::size_t a, std::size_t s, std::size_t s1, std::size_t o) -> double& {
    return full[((a * S + s) * S + s1) * O + o];
  };
  for (const auto& e : r_)
    for (std::size_t a : range(e.a, A))
      for (std::size_t s : range(e.s, S))
        for (std::size_t s1 : range(e.s1, S))
          for (std::size_t o : range(e.o, O)) at(a, s, s1, o) = e.v;
  for (std::size_t a = 0; a < A; ++a)
    for (std::size_t s = 0; s < S; ++s) {
      if ((s & 63) == 0) checkTime(eof_);
      double v = 0.0;
      for (const auto& t : tRows_[a * S + s]) {
        double w = 0.0;
        for (const auto& z : zRows_[a * S + t.first]) w += z.second * at(a, s, t.first, z.first);
        v += t.second * w;
      }
      r(s, a) = v;
    }
  return r;
}

Model Parser::buildModel(Eigen::MatrixXd r) {
  const std::size_t S = states_.n, A = actions_.n, O = obs_.n;
  auto names = [](const Symbols& sym, const char* prefix) {
    if (!sym.names.empty()) return sym.names;
    std::vector<std::string> out;
    for (std::size_t i = 0; i < sym.n; ++i) out.push_back(prefix + std::to_string(i));
    return out;
  };
  // kAuto keeps a dense copy of T (and O) when that is cheap and faster; that copy is counted
  // here, where the number of entries is known, and skipped if it would break the budget.
  std::size_t nnzT = 0;
  for (const auto& row : tRows_) nnzT += row.size();
  const double cells = static_cast<double>(A) * S * S;
  const bool denseT = (S <= Model::kDenseStates || nnzT >= Model::kDenseDensity * cells) &&
                      2.0 * cells * sizeof(double) <= static_cast<double>(Model::kDenseBytes);
  ModelStorage storage = ModelStorage::kAuto;
  if (denseT && S > Model::kDenseStates &&
      saturatingAdd(needBytes(entries_),
                    static_cast<std::size_t>(2.0 * cells * sizeof(double))) > budget_)
    storage = ModelStorage::kSparse;
  // CSR per action, built row by row while the row lists are released (one copy at a time).
  std::vector<SparseRows> tCsr(A), zCsr(A);
  for (std::size_t a = 0; a < A; ++a) {
    checkTime(eof_);
    tCsr[a].cols = S;
    zCsr[a].cols = O;
    std::size_t nt = 0, nz = 0;
    for (std::size_t s = 0; s < S; ++s) {
      nt += tRows_[a * S + s].size();
      nz += zRows_[a * S + s].size();
    }
    tCsr[a].entries.reserve(nt);
    tCsr[a].start.reserve(S + 1);
    zCsr[a].entries.reserve(nz);
    zCsr[a].start.reserve(S + 1);
    for (std::size_t s = 0; s < S; ++s) {
      tCsr[a].pushRow(tRows_[a * S + s]);
      std::vector<Model::Entry>().swap(tRows_[a * S + s]);
      zCsr[a].pushRow(zRows_[a * S + s]);
      std::vector<Model::Entry>().swap(zRows_[a * S + s]);
    }
  }
  try {
    // What is left of the time budget bounds the construction too.
    const double left = timeout_ > 0.0 ? std::max(1e-9, timeout_ - clock_.seconds()) : 0.0;
    Model m(std::move(tCsr), std::move(zCsr), std::move(r), discount_, left, storage);
    m.setNames(names(states_, "s"), names(actions_, "a"), names(obs_, "o"));
    if (haveStart_) m.setInitialBelief(start_);
    return m;
  } catch (const ConfigError& e) {
    if (timeout_ > 0.0 && clock_.seconds() > timeout_)
      fail(eof_, "reading stopped while building the model: time budget of " +
                     formatNumber(timeout_, 6) + " s exceeded");
    fail(eof_, std::string("invalid model: ") + e.what());
  }
}

bool validName(const std::string& n) {
  if (n.empty() || !std::isalpha(static_cast<unsigned char>(n[0]))) return false;
  for (char c : n)
    if (!std::isalnum(static_cast<unsigned char>(c)) && c != '_' && c != '-') return false;
  for (const char* kw : kKeywords)
    if (n == kw) return false;
  return true;
}

std::string fmt(double v) {
  std::ostringstream ss;
  ss.precision(17);
  ss << v;
  return ss.str();
}

}  // namespace

bool checkDistributionSum(double sum, double tolerance, CassandraStats& stats,
                          const std::function<std::string()>& where, double* divisor) {
  const double dev = std::abs(sum - 1.0);
  if (!(dev <= tolerance)) return false;
  if (dev > stats.max_sum_deviation) {
    stats.max_sum_deviation = dev;
    stats.max_deviation_where = where();
  }
  const bool exact = dev <= kExactSumNoise;
  if (!exact) ++stats.renormalised_rows;
  if (divisor) *divisor = exact ? 1.0 : sum;
  return true;
}

std::size_t estimateModelBytes(std::size_t states, std::size_t actions, std::size_t observations) {
  const std::size_t as = saturatingMul(actions, states);
  // Per (state, action): the reader's T and O row lists and locations, the CSR offsets, the
  // reward, flags, and one entry in each of the T and O rows (each sums to 1).
  constexpr std::size_t kPerStateAction = 2 * sizeof(std::vector<Model::Entry>) +
                                          2 * sizeof(Token) + 2 * sizeof(std::size_t) +
                                          sizeof(double) + 2 * kBytesPerEntry + 16;
  std::size_t b = saturatingMul(as, kPerStateAction);
  // Dense forms Model keeps whatever the density: T and its transpose up to kDenseStates
  // states, O whenever it is small.
  if (states <= Model::kDenseStates)
    b = saturatingAdd(b, saturatingMul(saturatingMul(as, states), 2 * sizeof(double)));
  const std::size_t zBytes = saturatingMul(saturatingMul(as, observations), sizeof(double));
  if (zBytes <= Model::kDenseBytes) b = saturatingAdd(b, zBytes);
  const std::size_t symbols = saturatingAdd(saturatingAdd(states, actions), observations);
  return saturatingAdd(b, saturatingMul(symbols, 64));
}

Model readCassandra(const std::string& text, const std::string& file,
                    const CassandraLimits& limits, CassandraStats* stats) {
  return Parser(text, file, limits, stats).parse();
}

Model loadCassandra(const std::string& path, const CassandraLimits& limits,
                    CassandraStats* stats) {
  return readCassandra(readFile(path), path, limits, stats);
}

std::string writeCassandra(const Model& m) {
  auto check = [](const std::vector<std::string>& v, const char* kind) {
    for (const auto& n : v)
      if (!validName(n))
        throw ConfigError(std::string("writeCassandra: ") + kind + " name '" + n +
                          "' is not a .pomdp identifier ([A-Za-z][A-Za-z0-9_-]*)");
  };
  check(m.stateNames(), "state");
  check(m.actionNames(), "action");
  check(m.observationNames(), "observation");
  const auto& sn = m.stateNames();
  const auto& an = m.actionNames();
  const auto& on = m.observationNames();
  std::ostringstream ss;
  ss << "# POMDP written by krr_core (krr::pomdp::writeCassandra)\n";
  ss << "discount: " << fmt(m.getDiscount()) << "\nvalues: reward\nstates:";
  for (const auto& n : sn) ss << ' ' << n;
  ss << "\nactions:";
  for (const auto& n : an) ss << ' ' << n;
  ss << "\nobservations:";
  for (const auto& n : on) ss << ' ' << n;
  ss << "\nstart:";
  for (Eigen::Index i = 0; i < m.initialBelief().size(); ++i) ss << ' ' << fmt(m.initialBelief()(i));
  ss << "\n\n";
  for (std::size_t a = 0; a < m.getA(); ++a) {
    if (m.isIdentityTransition(a)) {
      ss << "T: " << an[a] << "\nidentity\n";
      continue;
    }
    for (std::size_t s = 0; s < m.getS(); ++s)
      for (const auto& e : m.successors(s, a))
        ss << "T: " << an[a] << " : " << sn[s] << " : " << sn[e.first] << ' ' << fmt(e.second) << '\n';
  }
  ss << '\n';
  for (std::size_t a = 0; a < m.getA(); ++a)
    for (std::size_t s = 0; s < m.getS(); ++s)
      for (const auto& e : m.observationRow(s, a))
        ss << "O: " << an[a] << " : " << sn[s] << " : " << on[e.first] << ' ' << fmt(e.second) << '\n';
  ss << '\n';
  for (std::size_t a = 0; a < m.getA(); ++a)
    for (std::size_t s = 0; s < m.getS(); ++s) {
      const double v = m.getExpectedReward(s, a);
      if (v != 0.0) ss << "R: " << an[a] << " : " << sn[s] << " : * : * " << fmt(v) << '\n';
    }
  return ss.str();
}

void saveCassandra(const std::string& path, const Model& model) {
  writeFileAtomic(path, writeCassandra(model));
}

}  // namespace pomdp
}  // namespace krr
