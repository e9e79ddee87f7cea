#include "krr_core/plog/parser.h"

#include "krr_core/plog/arith.h"

#include <cctype>
#include <cmath>
#include <algorithm>
#include <cstdlib>
#include <functional>
#include <map>
#include <set>
#include <unordered_set>

namespace krr {
namespace plog {
namespace {

// ---------------------------------------------------------------------------------------------
// Lexer
// ---------------------------------------------------------------------------------------------

enum class Tok {
  End, Ident, Var, Int, Decimal, LParen, RParen, LBrace, RBrace, LBracket, RBracket, Comma,
  Semicolon, Dot, DotDot, Colon, If, Bar, Eq, EqEq, Ne, Lt, Gt, Le, Ge, Plus, Minus, Star,
  Slash, Question, Hash, Arrow
};

struct Token {
  Tok kind = Tok::End;
  std::string text;
  SourceLocation loc;
};

std::vector<Token> lex(const std::string& src, const std::string& file) {
  std::vector<Token> out;
  size_t i = 0;
  int line = 1, col = 1;
  auto adv = [&](size_t n) {
    for (size_t k = 0; k < n && i < src.size(); ++k, ++i) {
      if (src[i] == '\n') {
        ++line;
        col = 1;
      } else {
        ++col;
      }
    }
  };
  while (i < src.size()) {
    char c = src[i];
    if (c == '%') {
      while (i < src.size() && src[i] != '\n') adv(1);
      continue;
    }
    if (std::isspace(static_cast<unsigned char>(c))) {
      adv(1);
      continue;
    }
    Token t;
    t.loc = SourceLocation{file, line, col};
    auto two = [&](const char* s) { return src.compare(i, 2, s) == 0; };
    if (std::isalpha(static_cast<unsigned char>(c)) || c == '_') {
      size_t j = i;
      while (j < src.size() && (std::isalnum(static_cast<unsigned char>(src[j])) || src[j] == '_'))
        ++j;
      t.text = src.substr(i, j - i);
      t.kind = (std::isupper(static_cast<unsigned char>(c)) || c == '_') ? Tok::Var : Tok::Ident;
      adv(j - i);
    } else if (std::isdigit(static_cast<unsigned char>(c))) {
      size_t j = i;
      while (j < src.size() && std::isdigit(static_cast<unsigned char>(src[j]))) ++j;
      t.kind = Tok::Int;
      if (j + 1 < src.size() && src[j] == '.' && std::isdigit(static_cast<unsigned char>(src[j + 1]))) {
        ++j;
        while (j < src.size() && std::isdigit(static_cast<unsigned char>(src[j]))) ++j;
        t.kind = Tok::Decimal;
      }
      t.text = src.substr(i, j - i);
      adv(j - i);
    } else {
      size_t n = 1;
      if (two(":-")) { t.kind = Tok::If; n = 2; }
      else if (two("..")) { t.kind = Tok::DotDot; n = 2; }
      else if (two("==")) { t.kind = Tok::EqEq; n = 2; }
      else if (two("!=")) { t.kind = Tok::Ne; n = 2; }
      else if (two("<>")) { t.kind = Tok::Ne; n = 2; }
      else if (two("<=")) { t.kind = Tok::Le; n = 2; }
      else if (two(">=")) { t.kind = Tok::Ge; n = 2; }
      else if (two("->")) { t.kind = Tok::Arrow; n = 2; }
      else {
        switch (c) {
          case '(': t.kind = Tok::LParen; break;
          case ')': t.kind = Tok::RParen; break;
          case '{': t.kind = Tok::LBrace; break;
          case '}': t.kind = Tok::RBrace; break;
          case '[': t.kind = Tok::LBracket; break;
          case ']': t.kind = Tok::RBracket; break;
          case ',': t.kind = Tok::Comma; break;
          case ';': t.kind = Tok::Semicolon; break;
          case '.': t.kind = Tok::Dot; break;
          case ':': t.kind = Tok::Colon; break;
          case '|': t.kind = Tok::Bar; break;
          case '=': t.kind = Tok::Eq; break;
          case '<': t.kind = Tok::Lt; break;
          case '>': t.kind = Tok::Gt; break;
          case '+': t.kind = Tok::Plus; break;
          case '-': t.kind = Tok::Minus; break;
          case '*': t.kind = Tok::Star; break;
          case '/': t.kind = Tok::Slash; break;
          case '?': t.kind = Tok::Question; break;
          case '#': t.kind = Tok::Hash; break;
          default: {
            std::string shown = std::isprint(static_cast<unsigned char>(c))
                                    ? std::string("'") + c + "'"
                                    : "byte " + std::to_string(static_cast<unsigned char>(c));
            throw ParseError(t.loc, "unexpected character " + shown);
          }
        }
      }
      t.text = src.substr(i, n);
      adv(n);
    }
    out.push_back(t);
  }
  Token e;
  e.kind = Tok::End;
  e.loc = SourceLocation{file, line, col};
  out.push_back(e);
  return out;
}

// ---------------------------------------------------------------------------------------------
// Raw (unresolved) syntax
// ---------------------------------------------------------------------------------------------

struct RawLit {
  bool naf = false;
  Term lhs;
  bool has_op = false;
  CompareOp op = CompareOp::Eq;
  Term rhs;
  SourceLocation loc;
};

struct RawObs {
  RawLit lit;
  bool truth = true;
  SourceLocation loc;
};

struct RawQuery {
  std::vector<RawLit> formula;
  std::vector<RawObs> obs;
  std::vector<RawLit> dos;
  std::string text;
  SourceLocation loc;
};

struct RawStmt {
  enum class Kind { Rule, Random, Pr, Obs, Do, Query } kind = Kind::Rule;
  std::string label;
  std::optional<RawLit> head;      // Rule (absent: constraint); Random: lhs = attribute term
  std::vector<RawLit> body;
  bool has_range = false;          // Random
  std::string range_var;
  std::vector<RawLit> range_body;
  std::string range_pred;          // plog2 random(a, p)
  RawLit pr_atom;                  // Pr
  double prob = 0;
  std::string prob_text;
  RawObs obs;                      // Obs
  RawLit do_lit;                   // Do
  RawQuery query;                  // Query
  int priority = 0;                // Pr: knowledge generation
  SourceLocation loc;
};

// ---------------------------------------------------------------------------------------------
// Parser
// ---------------------------------------------------------------------------------------------

class Parser {
 public:
  Parser(const std::string& text, const std::string& file, Program& prog, Dialect dialect)
      : toks_(lex(text, file)), text_(text), prog_(prog), dialect_(dialect) {}

  std::vector<RawStmt> parseAll() {
    if (dialect_ == Dialect::Auto) {
      dialect_ = Dialect::Classic;
      for (size_t k = 0; k + 1 < toks_.size(); ++k) {
        if (toks_[k].kind == Tok::Ident &&
            (toks_[k].text == "sorts" || toks_[k].text == "attributes" ||
             toks_[k].text == "statements") &&
            (k == 0 || toks_[k - 1].kind == Tok::Dot) &&
            (toks_[k + 1].kind != Tok::LParen && toks_[k + 1].kind != Tok::Eq &&
             toks_[k + 1].kind != Tok::Colon && toks_[k + 1].kind != Tok::Dot &&
             toks_[k + 1].kind != Tok::If)) {
          dialect_ = Dialect::Plog2;
          break;
        }
      }
    }
    std::vector<RawStmt> out;
    parseStatements(out);
    for (const auto& d : pending_domains_)
      if (!prog_.findSort(d.sort))
        throw UnknownSymbolError(d.loc.str() + ": unknown sort '" + d.sort + "' in #domain");
    for (const auto& n : pending_sorts_) {
      if (!prog_.findSort(n.text))
        throw UnknownSymbolError(n.loc.str() + ": unknown sort '" + n.text + "'");
    }
    if (!pending_sorts_.empty())
      for (auto& a : prog_.attributes) a.range_sort = booleanRange(a.range_sort);
    return out;
  }

  void parseStatements(std::vector<RawStmt>& out) {
    while (peek().kind != Tok::End) {
      if (dialect_ == Dialect::Plog2 && peek().kind == Tok::Ident &&
          (peek().text == "sorts" || peek().text == "attributes" || peek().text == "statements")) {
        bool section = peek(1).kind != Tok::LParen && peek(1).kind != Tok::Eq &&
                       peek(1).kind != Tok::Colon && peek(1).kind != Tok::Dot &&
                       peek(1).kind != Tok::If;
        if (section) {
          next();
          continue;
        }
      }
      parseStatement(out);
    }
  }

  Dialect dialect() const { return dialect_; }
  /// @brief Classic `a : s.` attributes: the classic solver takes their arity from use.
  const std::set<std::string>& rangeOnly() const { return range_only_; }
  bool allow_empty_formula_ = false;
  int generation_ = 0;

  // Query parsing entry (for parseQuery): "?" optional.
  RawQuery parseStandaloneQuery() {
    if (peek().kind == Tok::Question) next();
    RawQuery q = parseQueryBody(peek().loc);
    if (peek().kind == Tok::Dot) next();
    expect(Tok::End, "end of query");
    return q;
  }

  Term parseStandaloneTerm() {
    Term t = parseExpr();
    expect(Tok::End, "end of attribute term");
    return t;
  }

 private:
  const Token& peek(size_t k = 0) const {
    size_t j = std::min(pos_ + k, toks_.size() - 1);
    return toks_[j];
  }
  const Token& next() {
    const Token& t = toks_[pos_];
    if (pos_ + 1 < toks_.size()) ++pos_;
    return t;
  }
  [[noreturn]] void fail(const Token& t, const std::string& expected) {
    std::string got = t.kind == Tok::End ? "end of input" : "'" + t.text + "'";
    throw ParseError(t.loc, "unexpected " + got + ", expected " + expected);
  }
  const Token& expect(Tok k, const std::string& what) {
    if (peek().kind != k) fail(peek(), what);
    return next();
  }
  bool accept(Tok k) {
    if (peek().kind == k) {
      next();
      return true;
    }
    return false;
  }
  bool isIdent(const char* s, size_t k = 0) const {
    return peek(k).kind == Tok::Ident && peek(k).text == s;
  }

  /// @brief Consistency-restoring rules `h :+ body.` need the minimal-abduction semantics of
  /// CR-Prolog, which neither back end implements: refuse them by name instead of misreading
  /// `:+` or dropping the rule.
  void refuseCrRule() {
    if (peek().kind == Tok::Colon && peek(1).kind == Tok::Plus)
      throw ParseError(peek().loc, "consistency-restoring rules (':+') are not supported");
  }

  /// @brief Observations and actions are facts (plog2.0 manual, section on statements); a
  /// conditional `do(a, y) :- b.` would need actions that depend on the world.
  void refuseBody(const char* what) {
    if (peek().kind == Tok::If)
      throw ParseError(peek().loc, std::string(what) + " must be a fact: a rule with " + what +
                                       " as its head is not supported");
  }

  // Statement terminator: '.' (a query at end of input may omit it).
  void endStatement() { expect(Tok::Dot, "'.' at end of statement"); }

  void parseStatement(std::vector<RawStmt>& out) {
    const Token& first = peek();
    // plog2 and classic sort declarations: '#s = ...' / 's = {...}'
    if (first.kind == Tok::Hash) {
      if (peek(1).kind == Tok::Ident && peek(1).text == "generation" &&
          peek(2).kind == Tok::Int) {
        // `#generation N.` (extension written by export): pr-atoms that follow belong to
        // knowledge generation N (see PrAtom::priority)
        next();
        next();
        const Token& n = expect(Tok::Int, "generation number");
        generation_ = std::atoi(n.text.c_str());
        endStatement();
        return;
      }
      if (peek(1).kind == Tok::Ident && peek(1).text == "domain" &&
          peek(2).kind == Tok::Ident) {
        parseDomain();
        return;
      }
      if (peek(1).kind == Tok::Ident && peek(1).text == "const" && peek(2).kind == Tok::Ident) {
        parseConst();
        return;
      }
      if (peek(1).kind == Tok::Ident && peek(2).kind == Tok::Eq) {
        next();
        parseSortDecl();
        return;
      }
      fail(peek(1), "sort name, 'const' or 'domain' after '#'");
    }
    if (first.kind == Tok::Ident && peek(1).kind == Tok::Eq &&
        (peek(2).kind == Tok::LBrace ||
         (peek(2).kind == Tok::Int && peek(3).kind == Tok::DotDot) ||
         (peek(2).kind == Tok::Hash))) {
      parseSortDecl();
      return;
    }
    if (first.kind == Tok::Ident && peek(1).kind == Tok::Colon) {
      pos_ += 1;
      refuseCrRule();  // `a :+ b.` is a CR-rule, not a declaration
      pos_ -= 1;
      parseAttributeDecl();
      return;
    }
    if (first.kind == Tok::Ident && peek(1).kind == Tok::Comma) {
      // `a1, a2, a3 : s.` declares several attributes with the same signature
      size_t k = 0;
      while (peek(k).kind == Tok::Ident && peek(k + 1).kind == Tok::Comma) k += 2;
      if (peek(k).kind == Tok::Ident && peek(k + 1).kind == Tok::Colon) {
        std::vector<Token> names;
        for (size_t j = 0; j <= k; j += 2) names.push_back(peek(j));
        size_t save = pos_;
        for (const auto& n : names) {
          pos_ = save + k;  // re-parse the signature for each name
          parseAttributeDecl();
          prog_.attributes.back().name = n.text;
          prog_.attributes.back().loc = n.loc;
        }
        return;
      }
    }
    RawStmt st;
    st.loc = first.loc;
    if (first.kind == Tok::LBracket) {
      next();
      const Token& l = peek();
      if (l.kind != Tok::Ident && l.kind != Tok::Var && l.kind != Tok::Int)
        fail(l, "label name after '['");
      st.label = next().text;
      if (l.kind == Tok::Ident && peek().kind == Tok::LParen) {
        // classic `[r(B)] random(place(B))`: the label names the rule; its arguments only
        // repeat the attribute's, so labels match by name
        next();
        parseExpr();
        while (accept(Tok::Comma)) parseExpr();
        expect(Tok::RParen, "')' closing the label's arguments");
      }
      expect(Tok::RBracket, "']' after label");
      if (!isIdent("random") && !isIdent("pr")) fail(peek(), "'random' or 'pr' after a label");
    }
    if (isIdent("random") && peek(1).kind == Tok::LParen) {
      parseRandom(st);
    } else if (isIdent("pr") && peek(1).kind == Tok::LParen) {
      parsePr(st);
    } else if (isIdent("obs") && peek(1).kind == Tok::LParen) {
      next();
      next();
      st.kind = RawStmt::Kind::Obs;
      st.obs = parseObsArgs(st.loc);
      refuseBody("obs(...)");
      endStatement();
    } else if (isIdent("do") && peek(1).kind == Tok::LParen) {
      next();
      next();
      st.kind = RawStmt::Kind::Do;
      st.do_lit = parseDoArgs();
      refuseBody("do(...)");
      endStatement();
    } else if (first.kind == Tok::Question) {
      next();
      st.kind = RawStmt::Kind::Query;
      st.query = parseQueryBody(first.loc);
      if (peek().kind != Tok::End) endStatement();
    } else if (first.kind == Tok::If) {
      next();
      st.kind = RawStmt::Kind::Rule;
      st.body = parseBody();
      endStatement();
    } else {
      st.kind = RawStmt::Kind::Rule;
      st.head = parseLiteral(false);
      refuseCrRule();
      if (accept(Tok::If)) st.body = parseBody();
      endStatement();
    }
    out.push_back(std::move(st));
  }

  /// @brief `#const n = 3.`: n stands for the integer wherever it is used as a term, so
  /// plog2.0 programs parameterised by constants read as written.
  void parseConst() {
    next();  // '#'
    next();  // const
    const Token& n = expect(Tok::Ident, "constant name after #const");
    expect(Tok::Eq, "'=' in #const");
    Term v = parseExpr();
    long long x = evalConst(v);
    if (consts_.count(n.text))
      throw ParseError(n.loc, "constant '" + n.text + "' defined twice");
    consts_[n.text] = x;
    endStatement();
  }

  void parseDomain() {
    SourceLocation loc = peek().loc;
    next();  // '#'
    next();  // domain
    do {
      DomainDecl d;
      d.loc = peek().loc;
      d.sort = expect(Tok::Ident, "sort name in #domain").text;
      expect(Tok::LParen, "'(' after sort name in #domain");
      do {
        d.variables.push_back(expect(Tok::Var, "variable in #domain").text);
      } while (accept(Tok::Semicolon) || accept(Tok::Comma));
      expect(Tok::RParen, "')' closing #domain");
      // the classic examples write #domain before the sorts: checked once all are declared
      pending_domains_.push_back(d);
      prog_.domains.push_back(d);
    } while (accept(Tok::Comma));
    (void)loc;
    endStatement();
  }

  /// @brief Largest number of values of one sort: keeps a hostile declaration from taking
  /// gigabytes before anything is grounded.
  static constexpr unsigned long long kMaxSortValues = 1000000;

  void addValue(SortDecl& s, const Term& v, std::set<std::string>& seen) {
    std::string key = toString(v);
    if (!seen.insert(key).second) return;
    if (s.values.size() >= kMaxSortValues)
      throw ParseError(v.loc, "sort " + s.name + " has more than " +
                                  std::to_string(kMaxSortValues) + " values");
    s.values.push_back(v);
  }

  /// @brief Add lo..hi; the size is computed in unsigned arithmetic so that ranges such as
  /// -5e18..5e18 cannot slip past the check through overflow, and the loop counts values
  /// instead of comparing x <= hi (which never fails for hi = INT64_MAX).
  void addRange(SortDecl& s, long long lo, long long hi, const SourceLocation& loc,
                std::set<std::string>& seen) {
    // plog2.0 and the classic solver both refuse lo > hi; an empty sort is almost always a typo
    if (lo > hi)
      throw ParseError(loc, "empty range " + std::to_string(lo) + ".." + std::to_string(hi) +
                                " in sort " + s.name + " (the lower bound exceeds the upper)");
    const unsigned long long n = rangeSize(lo, hi);
    if (n > kMaxSortValues)
      throw ParseError(loc, "range " + std::to_string(lo) + ".." + std::to_string(hi) +
                                " too large in sort " + s.name + " (more than " +
                                std::to_string(kMaxSortValues) + " values)");
    for (unsigned long long k = 0; k < n; ++k)
      addValue(s, Term::integer(static_cast<long long>(static_cast<unsigned long long>(lo) + k), loc),
               seen);
    s.range_lo = lo;
    s.range_hi = hi;
  }

  /// @brief Sort expression with plog2.0's set operators: `+` union and `-` difference (left
  /// associative), `*` intersection (binding tighter), parentheses. Values keep first-seen order.
  void parseSortUnion(SortDecl& s, std::set<std::string>& seen, int& ranges, int& others) {
    parseSortProduct(s, seen, ranges, others);
    while (peek().kind == Tok::Plus || peek().kind == Tok::Minus) {
      bool minus = next().kind == Tok::Minus;
      SortDecl rhs;
      rhs.name = s.name;
      std::set<std::string> rseen;
      parseSortProduct(rhs, rseen, ranges, others);
      if (minus) {
        std::vector<Term> kept;
        seen.clear();
        for (auto& v : s.values)
          if (!rseen.count(toString(v)) && seen.insert(toString(v)).second) kept.push_back(v);
        s.values = std::move(kept);
        others += 2;
      } else {
        for (const auto& v : rhs.values) addValue(s, v, seen);
      }
    }
  }

  void parseSortProduct(SortDecl& s, std::set<std::string>& seen, int& ranges, int& others) {
    parseSortOperand(s, seen, ranges, others);
    while (accept(Tok::Star)) {
      SortDecl rhs;
      rhs.name = s.name;
      std::set<std::string> rseen;
      parseSortOperand(rhs, rseen, ranges, others);
      std::vector<Term> kept;
      seen.clear();
      for (auto& v : s.values)
        if (rseen.count(toString(v)) && seen.insert(toString(v)).second) kept.push_back(v);
      s.values = std::move(kept);
      others += 2;
    }
  }

  void parseSortOperand(SortDecl& s, std::set<std::string>& seen, int& ranges, int& others) {
    if (peek().kind == Tok::LParen) {
      next();
      parseSortUnion(s, seen, ranges, others);
      expect(Tok::RParen, "')' closing sort expression");
      return;
    }
    // record sort f(#s1, ..., #sn): every f(t1, ..., tn) with ti in si
    bool hashed = peek().kind == Tok::Hash;
    if (!hashed && peek().kind == Tok::Ident && peek(1).kind == Tok::LParen) {
      parseRecordSort(s, seen);
      others += 2;
      return;
    }
    parseSortElements(s, seen, ranges, others);
  }

  void parseRecordSort(SortDecl& s, std::set<std::string>& seen) {
    const Token& f = next();
    next();  // '('
    std::vector<std::vector<Term>> args;
    do {
      SourceLocation aloc = peek().loc;
      SortDecl arg;
      arg.name = s.name;
      std::set<std::string> aseen;
      int r = 0, o = 0;
      parseSortUnion(arg, aseen, r, o);
      if (peek().kind == Tok::LParen)
        throw ParseError(peek().loc, "record sorts with variables and conditions "
                                     "(f(#s(X)) : ...) are not supported");
      if (arg.values.empty()) throw ParseError(aloc, "empty sort in record sort " + f.text);
      args.push_back(std::move(arg.values));
    } while (accept(Tok::Comma));
    expect(Tok::RParen, "')' closing record sort");
    unsigned long long total = 1;
    for (const auto& a : args) {
      total *= a.size();
      if (total > kMaxSortValues)
        throw ParseError(f.loc, "record sort " + f.text + "(...) has more than " +
                                    std::to_string(kMaxSortValues) + " values");
    }
    std::vector<size_t> idx(args.size(), 0);
    for (unsigned long long k = 0; k < total; ++k) {
      Term c;
      c.kind = Term::Kind::Compound;
      c.name = f.text;
      c.loc = f.loc;
      for (size_t i = 0; i < args.size(); ++i) c.args.push_back(args[i][idx[i]]);
      addValue(s, c, seen);
      for (size_t i = args.size(); i-- > 0;) {
        if (++idx[i] < args[i].size()) break;
        idx[i] = 0;
      }
    }
  }

  void parseSortElements(SortDecl& s, std::set<std::string>& seen, int& ranges, int& others) {
    // one operand of a union: {e1, e2, ...} | lo..hi | #sortname | sortname
    if (accept(Tok::LBrace)) {
      if (peek().kind != Tok::RBrace) {
        do {
          Term a = parseExpr();
          if (accept(Tok::DotDot)) {
            Term b = parseExpr();
            long long lo = evalConst(a), hi = evalConst(b);
            addRange(s, lo, hi, a.loc, seen);
            ++ranges;
          } else {
            if (!a.isGround() || a.kind == Term::Kind::Binary || a.kind == Term::Kind::Negate) {
              if (a.kind == Term::Kind::Binary || a.kind == Term::Kind::Negate)
                a = Term::integer(evalConst(a), a.loc);
              else
                throw ParseError(a.loc, "sort element must be a ground constant");
            }
            addValue(s, a, seen);
            ++others;
          }
        } while (accept(Tok::Comma));
      }
      expect(Tok::RBrace, "'}' or ',' in sort declaration");
      return;
    }
    if (peek().kind == Tok::Int || peek().kind == Tok::Minus) {
      Term a = parseExpr();
      expect(Tok::DotDot, "'..' in range");
      Term b = parseExpr();
      long long lo = evalConst(a), hi = evalConst(b);
      addRange(s, lo, hi, a.loc, seen);
      ++ranges;
      return;
    }
    accept(Tok::Hash);
    const Token& n = expect(Tok::Ident, "'{', a range or a sort name");
    const SortDecl* other = prog_.findSort(n.text);
    if (!other) throw UnknownSymbolError(n.loc.str() + ": unknown sort '" + n.text + "'");
    for (const auto& v : other->values) addValue(s, v, seen);
    others += 2;
  }

  long long evalConst(const Term& t) {
    switch (t.kind) {
      case Term::Kind::Integer: return t.value;
      case Term::Kind::Negate: {
        long long r;
        if (checkedNegate(evalConst(t.args[0]), &r) != ArithStatus::Ok)
          throw ParseError(t.loc, "integer overflow in '" + toString(t) + "'");
        return r;
      }
      case Term::Kind::Binary: {
        long long a = evalConst(t.args[0]), b = evalConst(t.args[1]), r = 0;
        switch (checkedBinary(t.name, a, b, &r)) {
          case ArithStatus::Ok: return r;
          case ArithStatus::Overflow:
            throw ParseError(t.loc, "integer overflow in '" + toString(t) + "'");
          case ArithStatus::DivisionByZero:
            throw ParseError(t.loc, "division by zero in '" + toString(t) + "'");
          default:
            throw ParseError(t.loc, "unknown operator '" + t.name + "'");
        }
      }
      default:
        throw ParseError(t.loc, "expected an integer constant, got '" + toString(t) + "'");
    }
  }

  void parseSortDecl() {
    SortDecl s;
    s.loc = peek().loc;
    s.name = next().text;
    expect(Tok::Eq, "'=' in sort declaration");
    if (prog_.findSort(s.name) && !(s.name == "boolean"))
      throw ParseError(s.loc, "sort '" + s.name + "' declared twice");
    std::set<std::string> seen;
    int ranges = 0, others = 0;
    parseSortUnion(s, seen, ranges, others);
    s.is_range = ranges == 1 && others == 0 && s.range_hi >= s.range_lo &&
                 s.values.size() == rangeSize(s.range_lo, s.range_hi);
    endStatement();
    if (s.name == "boolean") return;  // builtin; a redeclaration {true,false} is accepted
    prog_.sorts.push_back(s);
  }

  std::string parseSortRef() {
    accept(Tok::Hash);
    const Token& n = expect(Tok::Ident, "sort name");
    if (!prog_.findSort(n.text)) {
      // the classic examples declare `kc : kind.` before `kind = {1..4}.`
      if (dialect_ != Dialect::Classic)
        throw UnknownSymbolError(n.loc.str() + ": unknown sort '" + n.text + "'");
      pending_sorts_.push_back(n);
    }
    return n.text;
  }

  /// @brief A user sort {true, false} (plog2.0's `#bool`) is the boolean range: bare atoms
  /// p(t) then mean p(t) = true, exactly as for the builtin `boolean`.
  std::string booleanRange(const std::string& sort) const {
    const SortDecl* r = prog_.findSort(sort);
    if (!r) return sort;
    std::set<std::string> vals;
    for (const auto& v : r->values) vals.insert(toString(v));
    return vals == std::set<std::string>{"true", "false"} ? "boolean" : sort;
  }

  void parseAttributeDecl() {
    AttributeDecl a;
    a.loc = peek().loc;
    a.name = next().text;
    next();  // ':'
    std::vector<std::string> sorts;
    sorts.push_back(parseSortRef());
    while (accept(Tok::Comma)) sorts.push_back(parseSortRef());
    if (accept(Tok::Arrow)) {
      a.arg_sorts = sorts;
      a.range_sort = parseSortRef();
    } else {
      if (sorts.size() != 1) fail(peek(), "'->' after argument sorts");
      a.range_sort = sorts[0];
      if (dialect_ == Dialect::Classic) range_only_.insert(a.name);
    }
    endStatement();
    static const std::set<std::string> kKeywords = {"random", "pr", "obs", "do", "not"};
    if (kKeywords.count(a.name))
      throw ParseError(a.loc, "the name of attribute '" + a.name +
                                  "' coincides with a P-log keyword");
    a.range_sort = booleanRange(a.range_sort);
    // f(t) would be both an attribute term and a value (plog2.0 refuses this too)
    for (const auto& srt : prog_.sorts)
      for (const auto& v : srt.values)
        if (v.kind == Term::Kind::Compound && v.name == a.name)
          throw ParseError(a.loc, "attribute '" + a.name + "' conflicts with the record " +
                                      toString(v) + " of sort " + srt.name + " (declared at " +
                                      srt.loc.str() + ")");
    if (const AttributeDecl* old = prog_.findAttribute(a.name)) {
      if (!old->implicit)
        throw ParseError(a.loc, "attribute '" + a.name + "' declared twice");
    }
    for (auto it = prog_.attributes.begin(); it != prog_.attributes.end(); ++it)
      if (it->name == a.name) {
        prog_.attributes.erase(it);
        break;
      }
    prog_.attributes.push_back(a);
  }

  void parseRandom(RawStmt& st) {
    st.kind = RawStmt::Kind::Random;
    next();  // random
    next();  // (
    RawLit h;
    h.loc = peek().loc;
    h.lhs = parseExpr();
    st.head = h;
    if (accept(Tok::Colon)) {
      st.has_range = true;
      if (accept(Tok::LBrace)) {
        st.range_var = expect(Tok::Var, "range variable in '{X : p(X)}'").text;
        expect(Tok::Colon, "':' after range variable");
        st.range_body = parseBody();
        expect(Tok::RBrace, "'}' closing dynamic range");
      } else {
        st.range_pred = expect(Tok::Ident, "'{' or predicate name for dynamic range").text;
      }
    } else if (accept(Tok::Comma)) {
      st.has_range = true;
      st.range_pred = expect(Tok::Ident, "dynamic range predicate name").text;
    }
    expect(Tok::RParen, "')' closing random(...)");
    refuseCrRule();
    if (accept(Tok::If)) st.body = parseBody();
    endStatement();
  }

  void parsePr(RawStmt& st) {
    st.kind = RawStmt::Kind::Pr;
    st.priority = generation_;
    next();  // pr
    next();  // (
    st.pr_atom = parseLiteral(false);
    if (accept(Tok::Bar)) st.body = parseBody();
    expect(Tok::RParen, "')' or '|' in pr-atom");
    expect(Tok::Eq, "'=' before the probability");
    const Token& n = peek();
    std::string txt;
    double v;
    if (n.kind == Tok::Int || n.kind == Tok::Decimal) {
      next();
      txt = n.text;
      v = std::strtod(n.text.c_str(), nullptr);
      if (accept(Tok::Slash)) {
        const Token& d = peek();
        if (d.kind != Tok::Int && d.kind != Tok::Decimal) fail(d, "denominator");
        next();
        double dv = std::strtod(d.text.c_str(), nullptr);
        if (dv == 0) throw ParseError(d.loc, "zero denominator in probability");
        v /= dv;
        txt += "/" + d.text;
      }
    } else {
      fail(n, "probability (number, fraction or decimal)");
    }
    st.prob = v;
    st.prob_text = txt;
    endStatement();
  }

  RawObs parseObsArgs(const SourceLocation& loc) {
    RawObs o;
    o.loc = loc;
    if (isIdent("neg")) {
      next();
      o.truth = false;
    }
    o.lit = parseLiteral(false);
    if (accept(Tok::Comma)) {
      Term v = parseExpr();
      if (accept(Tok::Comma)) {
        // plog2.0 `obs(a, y, true)` / `obs(a, y, false)`: a = y is observed to hold / not hold
        Term flag = parseExpr();
        if (o.lit.has_op) throw ParseError(v.loc, "obs(a, y, flag) needs an attribute term a");
        if (flag.kind != Term::Kind::Symbol || (flag.name != "true" && flag.name != "false"))
          throw ParseError(flag.loc, "expected 'true' or 'false' as third argument of obs");
        if (flag.name == "false") o.truth = !o.truth;
        o.lit.has_op = true;
        o.lit.op = CompareOp::Eq;
        o.lit.rhs = v;
        expect(Tok::RParen, "')' closing obs(...)");
        return o;
      }
      // classic `obs(l, false)`: l does not hold; plog2 `obs(a, y)`: a = y (for a bare
      // predicate in the classic dialect, the second argument is the truth flag)
      bool classic_flag = dialect_ != Dialect::Plog2 && v.kind == Term::Kind::Symbol &&
                          (v.name == "true" || v.name == "false");
      if (o.lit.has_op || classic_flag) {
        if (v.kind == Term::Kind::Symbol && (v.name == "true" || v.name == "false")) {
          if (v.name == "false") o.truth = !o.truth;
        } else {
          throw ParseError(v.loc, "expected 'true' or 'false' as second argument of obs");
        }
      } else {
        o.lit.has_op = true;
        o.lit.op = CompareOp::Eq;
        o.lit.rhs = v;
      }
    }
    expect(Tok::RParen, "')' closing obs(...)");
    return o;
  }

  RawLit parseDoArgs() {
    RawLit l = parseLiteral(false);
    if (accept(Tok::Comma)) {
      if (l.has_op) fail(peek(), "')' closing do(...)");
      l.has_op = true;
      l.op = CompareOp::Eq;
      l.rhs = parseExpr();
      if (accept(Tok::Comma)) {
        // plog2.0 `do(a, y, true)`; an intervention cannot make a = y false
        Term flag = parseExpr();
        if (flag.kind != Term::Kind::Symbol || flag.name != "true")
          throw ParseError(flag.loc, "the third argument of do(a, y, ...) must be 'true' "
                                     "(an intervention fixes a = y; do(a, y, false) is not "
                                     "P-log)");
      }
    }
    expect(Tok::RParen, "')' closing do(...)");
    return l;
  }

  RawQuery parseQueryBody(const SourceLocation& loc) {
    RawQuery q;
    q.loc = loc;
    size_t start_tok = pos_;
    if (accept(Tok::LBrace)) {
      q.formula = parseBody();
      expect(Tok::RBrace, "'}' closing query formula");
    } else if (peek().kind != Tok::Bar || !allow_empty_formula_) {
      q.formula = parseBody();
    }
    if (accept(Tok::Bar)) {
      do {
        if (isIdent("obs") && peek(1).kind == Tok::LParen) {
          SourceLocation l = next().loc;
          next();
          q.obs.push_back(parseObsArgs(l));
        } else if (isIdent("do") && peek(1).kind == Tok::LParen) {
          next();
          next();
          q.dos.push_back(parseDoArgs());
        } else {
          fail(peek(), "'obs(...)' or 'do(...)' in query condition");
        }
      } while (accept(Tok::Comma));
    }
    // normalised text of the query
    std::string s = "?";
    for (size_t k = start_tok; k < pos_; ++k) {
      const std::string& t = toks_[k].text;
      if (toks_[k].kind == Tok::Bar) s += " | ";
      else if (toks_[k].kind == Tok::Comma) s += ", ";
      else if (toks_[k].kind == Tok::Ident && t == "not") s += "not ";
      else s += t;
    }
    q.text = s;
    return q;
  }

  std::vector<RawLit> parseBody() {
    std::vector<RawLit> b;
    b.push_back(parseLiteral(true));
    while (accept(Tok::Comma)) b.push_back(parseLiteral(true));
    return b;
  }

  RawLit parseLiteral(bool allow_naf) {
    RawLit l;
    l.loc = peek().loc;
    if (isIdent("not") && peek(1).kind != Tok::LParen && peek(1).kind != Tok::Eq) {
      if (!allow_naf) fail(peek(), "literal without 'not'");
      next();
      l.naf = true;
    }
    if (isIdent("neg") && peek(1).kind == Tok::Ident) {
      next();
      Term t = parseExpr();
      Term n;
      n.kind = Term::Kind::Negate;
      n.loc = t.loc;
      n.args.push_back(t);
      l.lhs = n;
      return l;
    }
    l.lhs = parseExpr();
    Tok k = peek().kind;
    if (k == Tok::Eq || k == Tok::EqEq || k == Tok::Ne || k == Tok::Lt || k == Tok::Gt ||
        k == Tok::Le || k == Tok::Ge) {
      next();
      l.has_op = true;
      l.op = k == Tok::Eq || k == Tok::EqEq ? CompareOp::Eq
             : k == Tok::Ne                  ? CompareOp::Ne
             : k == Tok::Lt                  ? CompareOp::Lt
             : k == Tok::Gt                  ? CompareOp::Gt
             : k == Tok::Le                  ? CompareOp::Le
                                             : CompareOp::Ge;
      l.rhs = parseExpr();
    }
    return l;
  }

  Term parseExpr() {
    if (++depth_ > 200) throw ParseError(peek().loc, "expression nested too deeply");
    Term t = parseProduct();
    while (peek().kind == Tok::Plus || peek().kind == Tok::Minus) {
      Term b;
      b.kind = Term::Kind::Binary;
      b.loc = peek().loc;
      b.name = next().text;
      b.args.push_back(t);
      b.args.push_back(parseProduct());
      t = b;
    }
    --depth_;
    return t;
  }

  Term parseProduct() {
    Term t = parseUnary();
    while (peek().kind == Tok::Star || peek().kind == Tok::Slash || isIdent("mod") ||
           isIdent("div")) {
      Term b;
      b.kind = Term::Kind::Binary;
      b.loc = peek().loc;
      std::string op = next().text;
      b.name = op == "div" ? "/" : op;
      b.args.push_back(t);
      b.args.push_back(parseUnary());
      t = b;
    }
    return t;
  }

  Term parseUnary() {
    if (peek().kind == Tok::Minus) {
      SourceLocation loc = next().loc;
      if (++depth_ > 200) throw ParseError(loc, "expression nested too deeply");
      Term inner = parseUnary();
      --depth_;
      if (inner.kind == Term::Kind::Integer) {
        if (checkedNegate(inner.value, &inner.value) != ArithStatus::Ok)
          throw ParseError(loc, "integer overflow in '-" + toString(inner) + "'");
        inner.loc = loc;
        return inner;
      }
      Term n;
      n.kind = Term::Kind::Negate;
      n.loc = loc;
      n.args.push_back(inner);
      return n;
    }
    return parsePrimary();
  }

  Term parsePrimary() {
    const Token& t = peek();
    switch (t.kind) {
      case Tok::Int: {
        next();
        errno = 0;
        long long v = std::strtoll(t.text.c_str(), nullptr, 10);
        if (errno == ERANGE) throw ParseError(t.loc, "integer too large '" + t.text + "'");
        return Term::integer(v, t.loc);
      }
      case Tok::Var:
        next();
        return Term::variable(t.text, t.loc);
      case Tok::Ident: {
        next();
        if (accept(Tok::LParen)) {
          Term c;
          c.kind = Term::Kind::Compound;
          c.name = t.text;
          c.loc = t.loc;
          c.args.push_back(parseExpr());
          while (accept(Tok::Comma)) c.args.push_back(parseExpr());
          expect(Tok::RParen, "')' or ',' in argument list");
          return c;
        }
        auto c = consts_.find(t.text);
        if (c != consts_.end()) return Term::integer(c->second, t.loc);
        return Term::symbol(t.text, t.loc);
      }
      case Tok::LParen: {
        next();
        Term e = parseExpr();
        expect(Tok::RParen, "')'");
        return e;
      }
      default:
        fail(t, "term");
    }
  }

  std::vector<Token> toks_;
  const std::string& text_;
  Program& prog_;
  Dialect dialect_;
  size_t pos_ = 0;
  int depth_ = 0;
  /// @brief Sorts named in classic declarations before their own declaration.
  std::vector<Token> pending_sorts_;
  std::set<std::string> range_only_;
  /// @brief #domain declarations whose sort is checked at the end of the text.
  std::vector<DomainDecl> pending_domains_;
  /// @brief `#const` definitions seen so far (name -> value).
  std::map<std::string, long long> consts_;
};

// ---------------------------------------------------------------------------------------------
// Resolution
// ---------------------------------------------------------------------------------------------

class Resolver {
 public:
  explicit Resolver(Program& p) : prog_(p) {}

  bool isAttributeTerm(const Term& t) const {
    if (t.kind != Term::Kind::Symbol && t.kind != Term::Kind::Compound) return false;
    return prog_.findAttribute(t.name) != nullptr;
  }

  AttributeTerm toAttr(const Term& t) {
    AttributeTerm a;
    a.name = t.name;
    a.args = t.args;
    a.loc = t.loc;
    const AttributeDecl* d = prog_.findAttribute(t.name);
    if (!d) throw UnknownSymbolError(t.loc.str() + ": unknown attribute '" + t.name + "'");
    if (d->arg_sorts.size() != a.args.size())
      throw UnknownSymbolError(t.loc.str() + ": attribute '" + t.name + "' expects " +
                               std::to_string(d->arg_sorts.size()) + " argument(s), got " +
                               std::to_string(a.args.size()));
    for (size_t i = 0; i < a.args.size(); ++i) {
      checkValue(a.args[i], d->arg_sorts[i], "argument " + std::to_string(i + 1) + " of '" +
                                                 t.name + "'");
    }
    return a;
  }

  void checkValue(const Term& v, const std::string& sort, const std::string& what) {
    if (sort.empty()) return;
    if (v.kind != Term::Kind::Symbol && v.kind != Term::Kind::Integer &&
        v.kind != Term::Kind::Compound)
      return;
    if (!v.isGround()) return;
    const SortDecl* s = prog_.findSort(sort);
    if (!s) throw UnknownSymbolError(v.loc.str() + ": unknown sort '" + sort + "'");
    auto& cache = sort_cache_[sort];
    if (cache.size() != s->values.size()) {
      cache.clear();
      for (const auto& x : s->values) cache.insert(toString(x));
    }
    if (cache.count(toString(v))) return;
    throw UnknownSymbolError(v.loc.str() + ": unknown value '" + toString(v) + "' for " + what +
                             " (not in sort " + sort + ")");
  }

  Atom makeAtom(const Term& attr_term, const Term& value) {
    Atom a;
    a.attr = toAttr(attr_term);
    a.value = value;
    a.loc = attr_term.loc;
    const AttributeDecl* d = prog_.findAttribute(attr_term.name);
    checkValue(value, d->range_sort, "the value of '" + attr_term.name + "'");
    return a;
  }

  Term freshVar() { return Term::variable("_V" + std::to_string(fresh_++)); }

  /// @brief plog2.0 lets rule bodies test observations: `not obs(s, true, true)` holds when the
  /// program does not observe s = true. They are read as the hidden boolean attribute
  /// `obs(a(t), y, flag)` (untyped arguments), made true by one fact per observation.
  bool usesObsLiterals() const {
    const AttributeDecl* d = prog_.findAttribute("obs");
    return d && d->implicit && d->arg_sorts.size() == 3;
  }

  static bool rawUsesObs(const std::vector<RawLit>& body) {
    for (const auto& l : body)
      if (!l.has_op && l.lhs.kind == Term::Kind::Compound && l.lhs.name == "obs") return true;
    return false;
  }

  void declareObsAttribute(const std::vector<RawStmt>& stmts) {
    if (prog_.findAttribute("obs")) return;
    for (const auto& s : stmts) {
      if (!rawUsesObs(s.body) && !rawUsesObs(s.range_body)) continue;
      AttributeDecl d;
      d.name = "obs";
      d.arg_sorts.assign(3, "");
      d.range_sort = "boolean";
      d.implicit = true;
      d.loc = s.loc;
      prog_.attributes.push_back(d);
      return;
    }
  }

  /// @brief `obs(a(t), y)` / `obs(a(t), y, true|false)` in a body as the atom
  /// obs(a(t), y, flag) = true, after checking a(t) and y against a's declaration.
  Atom obsAtom(const Term& t) {
    if (t.args.size() != 2 && t.args.size() != 3)
      throw ParseError(t.loc, "obs(a, y) or obs(a, y, true|false) expected in a rule body");
    const Term& a = t.args[0];
    if ((a.kind != Term::Kind::Symbol && a.kind != Term::Kind::Compound) ||
        !prog_.findAttribute(a.name) || a.name == "obs")
      throw UnknownSymbolError(a.loc.str() + ": obs(...) needs an attribute term, got '" +
                               toString(a) + "'");
    makeAtom(a, t.args[1]);  // arity, argument sorts and value sort
    Term flag = t.args.size() == 3 ? t.args[2] : Term::symbol("true", t.loc);
    if (flag.kind != Term::Kind::Symbol || (flag.name != "true" && flag.name != "false"))
      throw ParseError(flag.loc, "expected 'true' or 'false' as third argument of obs");
    Atom o;
    o.attr.name = "obs";
    o.attr.args = {a, t.args[1], flag};
    o.attr.loc = t.loc;
    o.value = Term::symbol("true", t.loc);
    o.loc = t.loc;
    return o;
  }

  /// @brief The fact obs(a(t), y, flag) that makes body tests of an observation true.
  Rule obsFact(const Observation& o) {
    Term a;
    a.kind = o.literal.atom.attr.args.empty() ? Term::Kind::Symbol : Term::Kind::Compound;
    a.name = o.literal.atom.attr.name;
    a.args = o.literal.atom.attr.args;
    a.loc = o.loc;
    Rule r;
    r.loc = o.loc;
    Atom h;
    h.attr.name = "obs";
    h.attr.args = {a, o.literal.atom.value, Term::symbol(o.truth ? "true" : "false", o.loc)};
    h.attr.loc = o.loc;
    h.value = Term::symbol("true", o.loc);
    h.loc = o.loc;
    r.head = h;
    return r;
  }

  // Resolve one raw literal into zero or more literals (rewrites may add literals).
  void resolveLit(const RawLit& r, std::vector<Literal>& out) {
    Literal l;
    l.naf = r.naf;
    l.loc = r.loc;
    if (!r.has_op && r.lhs.kind == Term::Kind::Compound && !prog_.findAttribute(r.lhs.name) &&
        r.lhs.name == "do")
      throw ParseError(r.loc, "do(...) in a rule body is not supported (only as a fact or in "
                              "a query condition)");
    if (!r.has_op && r.lhs.kind == Term::Kind::Compound && r.lhs.name == "obs" &&
        usesObsLiterals()) {
      l.kind = Literal::Kind::Atom;
      l.atom = obsAtom(r.lhs);
      out.push_back(l);
      return;
    }
    if (!r.has_op) {
      const Term* t = &r.lhs;
      bool neg = false;
      if (t->kind == Term::Kind::Negate) {
        neg = true;
        t = &t->args[0];
      }
      if (t->kind != Term::Kind::Symbol && t->kind != Term::Kind::Compound)
        throw ParseError(r.loc, "expected a literal, got '" + toString(r.lhs) + "'");
      const AttributeDecl* d = prog_.findAttribute(t->name);
      if (!d) throw UnknownSymbolError(t->loc.str() + ": unknown predicate '" + t->name + "'");
      if (d->range_sort != "boolean")
        throw ParseError(r.loc, "attribute '" + t->name + "' has range " + d->range_sort +
                                    " and needs a value: " + t->name + "=...");
      l.kind = Literal::Kind::Atom;
      l.atom = makeAtom(*t, Term::symbol(neg ? "false" : "true", t->loc));
      out.push_back(l);
      return;
    }
    bool la = isAttributeTerm(r.lhs), ra = isAttributeTerm(r.rhs);
    if (la && ra && (r.op == CompareOp::Eq || r.op == CompareOp::Ne)) {
      // a(t) = y where y is also a declared 0-ary attribute name: prefer the value reading.
      const AttributeDecl* d = prog_.findAttribute(r.lhs.name);
      const SortDecl* s = prog_.findSort(d->range_sort);
      bool is_value = false;
      if (s)
        for (const auto& x : s->values)
          if (x == r.rhs) is_value = true;
      if (is_value) ra = false;
    }
    if ((la || ra) && r.naf && (la && ra))
      throw Error(r.loc.str() + ": 'not' before an equality of two attribute terms is not "
                                "supported; bind them to variables first");
    if (la && !ra && (r.op == CompareOp::Eq || r.op == CompareOp::Ne)) {
      l.kind = Literal::Kind::Atom;
      l.negated = r.op == CompareOp::Ne;
      l.atom = makeAtom(r.lhs, r.rhs);
      out.push_back(l);
      return;
    }
    if (ra && !la && (r.op == CompareOp::Eq || r.op == CompareOp::Ne)) {
      l.kind = Literal::Kind::Atom;
      l.negated = r.op == CompareOp::Ne;
      l.atom = makeAtom(r.rhs, r.lhs);
      out.push_back(l);
      return;
    }
    if (la && ra && r.op == CompareOp::Eq && !r.naf) {
      Term v = freshVar();
      for (const Term* side : {&r.lhs, &r.rhs}) {
        Literal a;
        a.kind = Literal::Kind::Atom;
        a.loc = r.loc;
        a.atom = makeAtom(*side, v);
        out.push_back(a);
      }
      return;
    }
    Term lhs = r.lhs, rhs = r.rhs;
    if (la || ra) {
      if (r.naf)
        throw Error(r.loc.str() + ": 'not' before a comparison of attribute terms is not "
                                  "supported; bind the attribute to a variable first");
      if (la) {
        Term v = freshVar();
        Literal a;
        a.kind = Literal::Kind::Atom;
        a.loc = r.loc;
        a.atom = makeAtom(r.lhs, v);
        out.push_back(a);
        lhs = v;
      }
      if (ra) {
        Term v = freshVar();
        Literal a;
        a.kind = Literal::Kind::Atom;
        a.loc = r.loc;
        a.atom = makeAtom(r.rhs, v);
        out.push_back(a);
        rhs = v;
      }
    }
    checkArith(lhs);
    checkArith(rhs);
    l.kind = Literal::Kind::Comparison;
    l.op = r.op;
    l.lhs = lhs;
    l.rhs = rhs;
    out.push_back(l);
  }

  void checkArith(const Term& t) {
    if (t.kind == Term::Kind::Compound || t.kind == Term::Kind::Symbol) {
      if (prog_.findAttribute(t.name) && t.kind == Term::Kind::Compound)
        throw Error(t.loc.str() + ": attribute term '" + toString(t) +
                    "' inside an arithmetic expression is not supported");
    }
    for (const auto& a : t.args) checkArith(a);
  }

  std::vector<Literal> resolveBody(const std::vector<RawLit>& raw) {
    std::vector<Literal> out;
    for (const auto& r : raw) resolveLit(r, out);
    return out;
  }

  Atom resolveHeadAtom(const RawLit& r, const char* what) {
    if (r.naf) throw ParseError(r.loc, std::string("'not' is not allowed in ") + what);
    const Term* h = &r.lhs;
    if (h->kind == Term::Kind::Negate) h = &h->args[0];
    if ((h->kind == Term::Kind::Symbol || h->kind == Term::Kind::Compound) &&
        !prog_.findAttribute(h->name))
      throw UnknownSymbolError(h->loc.str() + ": undeclared attribute '" + h->name + "' in " +
                               what);
    std::vector<Literal> tmp;
    resolveLit(r, tmp);
    if (tmp.size() != 1 || tmp[0].kind != Literal::Kind::Atom || tmp[0].negated)
      throw ParseError(r.loc, std::string("expected an atom a(t)=y or p(t) as ") + what);
    return tmp[0].atom;
  }

  void typeTerm(const Term& t, const std::string& sort, VariableSorts& vs) {
    if (t.kind == Term::Kind::Variable && !sort.empty() && t.name != "_") vs.emplace(t.name, sort);
    if (t.kind == Term::Kind::Compound && !sort.empty())
      for (size_t i = 0; i < t.args.size(); ++i)
        if (!t.args[i].isGround())
          typeTerm(t.args[i], projectionSort(sort, t.name, t.args.size(), i), vs);
  }

  /// @brief Sort of the i-th argument of the records f(...) of `sort`, so that a variable
  /// nested in a value (`genotype_of(X) = g(g_a, Y)`) ranges over what can stand there. The
  /// sort is hidden (builtin: not exported; a re-parse derives it again).
  std::string projectionSort(const std::string& sort, const std::string& f, size_t arity,
                             size_t i) {
    const SortDecl* s = prog_.findSort(sort);
    if (!s) return "";
    std::string name = "arg_" + sort + "_" + f + std::to_string(arity) + "_" + std::to_string(i);
    if (const SortDecl* old = prog_.findSort(name)) return old->builtin ? name : "";
    SortDecl p;
    p.name = name;
    p.builtin = true;
    p.loc = s->loc;
    std::set<std::string> seen;
    for (const auto& v : s->values)
      if (v.kind == Term::Kind::Compound && v.name == f && v.args.size() == arity &&
          seen.insert(toString(v.args[i])).second)
        p.values.push_back(v.args[i]);
    if (p.values.empty()) return "";
    prog_.sorts.push_back(p);
    return name;
  }

  void typeAtom(const Atom& a, VariableSorts& vs) {
    const AttributeDecl* d = prog_.findAttribute(a.attr.name);
    if (!d) return;
    for (size_t i = 0; i < a.attr.args.size() && i < d->arg_sorts.size(); ++i)
      typeTerm(a.attr.args[i], d->arg_sorts[i], vs);
    typeTerm(a.value, d->range_sort, vs);
  }

  void typeBody(const std::vector<Literal>& b, VariableSorts& vs) {
    for (const auto& l : b)
      if (l.kind == Literal::Kind::Atom) typeAtom(l.atom, vs);
  }

  void typeDomains(const std::vector<std::string>& vars, VariableSorts& vs) {
    for (const auto& v : vars) {
      std::string s = prog_.domainSortOf(v);
      if (!s.empty()) vs[v] = s;
    }
  }

  static void varsOfBody(const std::vector<Literal>& b, std::vector<std::string>& out) {
    for (const auto& l : b) {
      if (l.kind == Literal::Kind::Atom) {
        for (const auto& a : l.atom.attr.args) a.collectVariables(out);
        l.atom.value.collectVariables(out);
      } else {
        l.lhs.collectVariables(out);
        l.rhs.collectVariables(out);
      }
    }
  }
  static void varsOfAtom(const Atom& a, std::vector<std::string>& out) {
    for (const auto& x : a.attr.args) x.collectVariables(out);
    a.value.collectVariables(out);
  }

  void requireGround(const Atom& a, const char* what) {
    if (!a.value.isGround()) throw ParseError(a.loc, std::string(what) + " must be ground");
    for (const auto& x : a.attr.args)
      if (!x.isGround()) throw ParseError(a.loc, std::string(what) + " must be ground");
  }

  Observation resolveObs(const RawObs& o) {
    Observation r;
    r.loc = o.loc;
    r.truth = o.truth;
    std::vector<Literal> tmp;
    resolveLit(o.lit, tmp);
    if (tmp.size() != 1 || tmp[0].kind != Literal::Kind::Atom || tmp[0].naf)
      throw ParseError(o.loc, "obs(...) needs an attribute atom a(t)=y or p(t)");
    r.literal = tmp[0];
    if (r.literal.negated) {
      r.literal.negated = false;
      r.truth = !r.truth;
    }
    requireGround(r.literal.atom, "observed atom");
    return r;
  }

  Intervention resolveDo(const RawLit& l) {
    Intervention d;
    d.loc = l.loc;
    d.atom = resolveHeadAtom(l, "do(...)");
    requireGround(d.atom, "do(...) atom");
    return d;
  }

  // A query/obs/do literal that did not resolve to an attribute atom names an unknown attribute.
  void requireKnownAttribute(const RawLit& r) {
    const Term* t = &r.lhs;
    if (t->kind == Term::Kind::Negate) t = &t->args[0];
    if ((t->kind == Term::Kind::Symbol || t->kind == Term::Kind::Compound) &&
        !prog_.findAttribute(t->name))
      throw UnknownSymbolError(t->loc.str() + ": unknown attribute '" + t->name + "'");
  }

  Query resolveQuery(const RawQuery& rq) {
    if (usesObsLiterals() && !rq.obs.empty())
      throw Error(rq.loc.str() + ": a query that observes is not supported for a program whose "
                                 "rules test obs(...); write the observation as a fact");
    for (const auto& l : rq.formula) requireKnownAttribute(l);
    for (const auto& o : rq.obs) requireKnownAttribute(o.lit);
    for (const auto& d : rq.dos) requireKnownAttribute(d);
    Query q;
    q.loc = rq.loc;
    q.text = rq.text;
    q.formula = resolveBody(rq.formula);
    for (const auto& l : q.formula) {
      if (l.kind != Literal::Kind::Atom)
        throw ParseError(l.loc, "query formula must consist of attribute atoms");
      requireGround(l.atom, "query atom");
    }
    for (const auto& o : rq.obs) q.observations.push_back(resolveObs(o));
    for (const auto& d : rq.dos) q.interventions.push_back(resolveDo(d));
    return q;
  }

  // Declare implicit predicates for undeclared heads of rules/facts.
  void declareImplicit(const std::vector<RawStmt>& stmts) {
    // plog2.0 requires every attribute to be declared in its `attributes` section
    if (plog2_) return;
    for (const auto& s : stmts) {
      if (s.kind != RawStmt::Kind::Rule || !s.head) continue;
      const RawLit& h = *s.head;
      if (h.has_op && !(h.op == CompareOp::Eq && h.rhs.kind == Term::Kind::Symbol &&
                        (h.rhs.name == "true" || h.rhs.name == "false")))
        continue;
      const Term* t = &h.lhs;
      if (t->kind == Term::Kind::Negate) t = &t->args[0];
      if (t->kind != Term::Kind::Symbol && t->kind != Term::Kind::Compound) continue;
      if (prog_.findAttribute(t->name)) continue;
      if (prog_.findSort(t->name) == nullptr || true) {
        AttributeDecl d;
        d.name = t->name;
        d.arg_sorts.assign(t->args.size(), "");
        d.range_sort = "boolean";
        d.implicit = true;
        d.loc = t->loc;
        prog_.attributes.push_back(d);
      }
    }
  }

  /// @brief Give each classic range-only attribute `a : s.` that the statements use with
  /// arguments (`random(place(B))`) that arity; an argument's sort is the #domain sort of a
  /// variable written there, untyped otherwise. The classic solver reads its examples so.
  void inferClassicArity(const std::vector<RawStmt>& stmts) {
    if (range_only_.empty()) return;
    std::map<std::string, std::vector<std::string>> seen;  // name -> argument sorts
    std::function<void(const Term&)> visit = [&](const Term& t) {
      if (t.kind == Term::Kind::Compound && range_only_.count(t.name)) {
        auto it = seen.find(t.name);
        if (it == seen.end()) it = seen.emplace(t.name, std::vector<std::string>(t.args.size())).first;
        if (it->second.size() == t.args.size())
          for (size_t i = 0; i < t.args.size(); ++i)
            if (it->second[i].empty() && t.args[i].kind == Term::Kind::Variable)
              it->second[i] = prog_.domainSortOf(t.args[i].name);
      }
      for (const auto& a : t.args) visit(a);
    };
    auto lit = [&](const RawLit& l) {
      visit(l.lhs);
      if (l.has_op) visit(l.rhs);
    };
    for (const auto& s : stmts) {
      if (s.head) lit(*s.head);
      for (const auto& l : s.body) lit(l);
      for (const auto& l : s.range_body) lit(l);
      lit(s.pr_atom);
      lit(s.obs.lit);
      lit(s.do_lit);
      for (const auto& l : s.query.formula) lit(l);
      for (const auto& o : s.query.obs) lit(o.lit);
      for (const auto& l : s.query.dos) lit(l);
    }
    for (auto& a : prog_.attributes)
      if (a.arg_sorts.empty() && seen.count(a.name)) a.arg_sorts = seen[a.name];
  }

  /// @brief Classic programs overload undeclared predicate names by arity, as ASP does
  /// (Poker: pair(K, S) and pair(K)). One attribute has one arity here, so every arity but the
  /// first one used is renamed `name_<arity>` (a free name) throughout the statements.
  std::vector<RawStmt> splitOverloadedPredicates(const std::vector<RawStmt>& stmts) {
    if (plog2_) return stmts;
    std::map<std::string, std::vector<size_t>> arities;  // first-use order
    auto top = [](const RawLit& l) -> const Term* {
      const Term* t = &l.lhs;
      if (t->kind == Term::Kind::Negate) t = &t->args[0];
      return (t->kind == Term::Kind::Symbol || t->kind == Term::Kind::Compound) ? t : nullptr;
    };
    auto note = [&](const RawLit& l) {
      const Term* t = top(l);
      if (!t || prog_.findAttribute(t->name) || t->name == "obs" || t->name == "do") return;
      auto& v = arities[t->name];
      if (std::find(v.begin(), v.end(), t->args.size()) == v.end()) v.push_back(t->args.size());
    };
    for (const auto& s : stmts) {
      if (s.kind == RawStmt::Kind::Rule && s.head) note(*s.head);
      for (const auto& l : s.body) note(l);
    }
    std::map<std::pair<std::string, size_t>, std::string> rename;
    for (const auto& a : arities) {
      for (size_t k = 1; k < a.second.size(); ++k) {
        std::string n = a.first + "_" + std::to_string(a.second[k]);
        while (prog_.findAttribute(n) || arities.count(n)) n += "_";
        rename[{a.first, a.second[k]}] = n;
      }
    }
    if (rename.empty()) return stmts;
    std::vector<RawStmt> out = stmts;
    auto fix = [&](RawLit& l) {
      Term* t = &l.lhs;
      if (t->kind == Term::Kind::Negate) t = &t->args[0];
      if (t->kind != Term::Kind::Symbol && t->kind != Term::Kind::Compound) return;
      auto it = rename.find({t->name, t->args.size()});
      if (it != rename.end()) t->name = it->second;
    };
    for (auto& s : out) {
      if (s.head) fix(*s.head);
      for (auto& l : s.body) fix(l);
      for (auto& l : s.range_body) fix(l);
      fix(s.pr_atom);
      fix(s.obs.lit);
      for (auto& l : s.query.formula) fix(l);
      for (auto& o : s.query.obs) fix(o.lit);
    }
    return out;
  }

  void resolveAll(const std::vector<RawStmt>& raw) {
    const std::vector<RawStmt> stmts = splitOverloadedPredicates(raw);
    inferClassicArity(stmts);
    declareObsAttribute(stmts);
    declareImplicit(stmts);
    for (const auto& s : stmts) {
      switch (s.kind) {
        case RawStmt::Kind::Rule: {
          Rule r;
          r.loc = s.loc;
          if (s.head) r.head = resolveHeadAtom(*s.head, "a rule head");
          r.body = resolveBody(s.body);
          std::vector<std::string> vars;
          if (r.head) {
            typeAtom(*r.head, r.variable_sorts);
            varsOfAtom(*r.head, vars);
          }
          typeBody(r.body, r.variable_sorts);
          varsOfBody(r.body, vars);
          typeDomains(vars, r.variable_sorts);
          prog_.rules.push_back(std::move(r));
          break;
        }
        case RawStmt::Kind::Random: {
          RandomRule r;
          r.loc = s.loc;
          r.label = s.label;
          const Term& t = s.head->lhs;
          if (t.kind != Term::Kind::Symbol && t.kind != Term::Kind::Compound)
            throw ParseError(s.head->loc, "random(...) needs an attribute term");
          r.attr = toAttr(t);
          const AttributeDecl* d = prog_.findAttribute(t.name);
          r.has_range = s.has_range;
          if (s.has_range) {
            if (!s.range_pred.empty()) {
              r.range_var = "_R" + std::to_string(fresh_++);
              RawLit pl;
              pl.loc = s.head->loc;
              pl.lhs.kind = Term::Kind::Compound;
              pl.lhs.name = s.range_pred;
              pl.lhs.loc = s.head->loc;
              pl.lhs.args.push_back(Term::variable(r.range_var, s.head->loc));
              r.range_body = resolveBody({pl});
            } else {
              r.range_var = s.range_var;
              r.range_body = resolveBody(s.range_body);
            }
            r.variable_sorts.emplace(r.range_var, d->range_sort);
          }
          r.body = resolveBody(s.body);
          std::vector<std::string> vars;
          for (const auto& a : r.attr.args) a.collectVariables(vars);
          for (size_t i = 0; i < r.attr.args.size(); ++i)
            typeTerm(r.attr.args[i], d->arg_sorts[i], r.variable_sorts);
          typeBody(r.body, r.variable_sorts);
          typeBody(r.range_body, r.variable_sorts);
          varsOfBody(r.body, vars);
          varsOfBody(r.range_body, vars);
          typeDomains(vars, r.variable_sorts);
          prog_.random_rules.push_back(std::move(r));
          break;
        }
        case RawStmt::Kind::Pr: {
          PrAtom p;
          p.loc = s.loc;
          p.label = s.label;
          p.atom = resolveHeadAtom(s.pr_atom, "the atom of a pr-atom");
          p.body = resolveBody(s.body);
          p.probability = s.prob;
          p.probability_text = s.prob_text;
          p.priority = s.priority;
          if (!(p.probability >= 0.0 && p.probability <= 1.0))
            throw IncoherentError(s.loc.str() + ": probability " + s.prob_text + " of pr(" +
                                  toString(p.atom) + ") is outside [0,1]");
          std::vector<std::string> vars;
          varsOfAtom(p.atom, vars);
          varsOfBody(p.body, vars);
          typeAtom(p.atom, p.variable_sorts);
          typeBody(p.body, p.variable_sorts);
          typeDomains(vars, p.variable_sorts);
          prog_.pr_atoms.push_back(std::move(p));
          break;
        }
        case RawStmt::Kind::Obs:
          requireKnownAttribute(s.obs.lit);
          prog_.observations.push_back(resolveObs(s.obs));
          if (usesObsLiterals()) prog_.rules.push_back(obsFact(prog_.observations.back()));
          break;
        case RawStmt::Kind::Do:
          requireKnownAttribute(s.do_lit);
          prog_.interventions.push_back(resolveDo(s.do_lit));
          break;
        case RawStmt::Kind::Query:
          prog_.queries.push_back(resolveQuery(s.query));
          break;
      }
    }
  }

  int fresh_ = 0;
  /// @brief The statements are in the plog2.0 dialect (no implicit predicates).
  bool plog2_ = false;
  /// @brief Classic attributes declared with their range only (arity taken from use).
  std::set<std::string> range_only_;

 private:
  Program& prog_;
  std::map<std::string, std::unordered_set<std::string>> sort_cache_;
};

void ensureBoolean(Program& p) {
  if (p.findSort("boolean")) return;
  SortDecl b;
  b.name = "boolean";
  b.builtin = true;
  b.values = {Term::symbol("true"), Term::symbol("false")};
  p.sorts.insert(p.sorts.begin(), b);
}

int freshBase(const Program& p) {
  // Fresh variable numbers must not collide with those of earlier parses into the program.
  return static_cast<int>(p.rules.size() + p.random_rules.size() + p.pr_atoms.size() +
                          p.queries.size()) * 4 + 1000;
}

}  // namespace

void parseInto(Program& program, const std::string& text, const std::string& file_name,
               Dialect dialect) {
  Program work = program;
  ensureBoolean(work);
  Parser parser(text, file_name, work, dialect);
  std::vector<RawStmt> stmts = parser.parseAll();
  Resolver res(work);
  res.fresh_ = freshBase(program);
  res.plog2_ = parser.dialect() == Dialect::Plog2;
  res.range_only_ = parser.rangeOnly();
  res.resolveAll(stmts);
  if (program.sorts.empty() && program.attributes.empty() && program.rules.empty() &&
      program.random_rules.empty() && program.pr_atoms.empty())
    work.dialect = parser.dialect();
  program = std::move(work);
}

Program parseProgram(const std::string& text, const std::string& file_name, Dialect dialect) {
  Program p;
  parseInto(p, text, file_name, dialect);
  return p;
}

Program parseProgram(const std::string& text, const std::string& file_name) {
  return parseProgram(text, file_name, Dialect::Auto);
}

Query parseQuery(const Program& program, const std::string& text, const std::string& file_name) {
  Program work = program;
  ensureBoolean(work);
  Parser parser(text, file_name, work, Dialect::Classic);
  parser.allow_empty_formula_ = true;
  RawQuery rq = parser.parseStandaloneQuery();
  Resolver res(work);
  res.fresh_ = freshBase(program);
  return res.resolveQuery(rq);
}

AttributeTerm parseAttributeTerm(const Program& program, const std::string& text,
                                 const std::string& file_name) {
  Program work = program;
  ensureBoolean(work);
  Parser parser(text, file_name, work, Dialect::Classic);
  Term t = parser.parseStandaloneTerm();
  if (t.kind != Term::Kind::Symbol && t.kind != Term::Kind::Compound)
    throw ParseError(t.loc, "expected an attribute term, got '" + toString(t) + "'");
  Resolver res(work);
  AttributeTerm a = res.toAttr(t);
  for (const auto& x : a.args)
    if (!x.isGround()) throw ParseError(t.loc, "attribute term must be ground");
  return a;
}

}  // namespace plog
}  // namespace krr
