/**
 * @file parser.cpp
 * @brief Recursive-descent parser of P-log text (classic and plog2.0 dialects) into raw
 * statements, and the public parse functions (lexer.cpp makes the tokens, resolver.cpp
 * turns the raw statements into a Program).
 */
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

#include "parser_syntax.h"

namespace krr {
namespace plog {

using namespace syntax;

namespace {

class Parser {
 public:
  Parser(const std::string& text, const std::string& file, Program& prog, Dialect dialect,
         MemoryGuard* guard = nullptr)
      : toks_(lex(text, file, guard)), text_(text), file_(file), prog_(prog), dialect_(dialect),
        guard_(guard) {}

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
    size_t dots = 0;  // an upper bound on the statements: no reallocation while reading
    for (const auto& t : toks_) dots += t.kind == Tok::Dot;
    if (guard_) guard_->check("parsing", locOf(toks_.front()), (dots + 1) * sizeof(RawStmt));
    out.reserve(dots + 1);
    parseStatements(out);
    for (const auto& d : pending_domains_)
      if (!prog_.findSort(d.sort))
        throw UnknownSymbolError(d.loc.str() + ": unknown sort '" + d.sort + "' in #domain");
    for (const auto& n : pending_sorts_) {
      if (!prog_.findSort(n.text))
        throw UnknownSymbolError(locOf(n).str() + ": unknown sort '" + n.text + "'");
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
      if (guard_) guard_->tickAt("parsing", [&] { return locOf(peek()); });
      parseStatement(out);
    }
  }

  Dialect dialect() const { return dialect_; }
  /// @brief Frees the tokens once the statements are read (they are no longer needed).
  void releaseTokens() { std::vector<Token>().swap(toks_); }
  /// @brief Classic `a : s.` attributes: the classic solver takes their arity from use.
  const std::set<std::string>& rangeOnly() const { return range_only_; }
  bool allow_empty_formula_ = false;
  int generation_ = 0;

  // Query parsing entry (for parseQuery): "?" optional.
  RawQuery parseStandaloneQuery() {
    if (peek().kind == Tok::Question) next();
    RawQuery q = parseQueryBody(locOf(peek()));
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
    throw ParseError(locOf(t), "unexpected " + got + ", expected " + expected);
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

  /// @brief The arrow of a consistency-restoring rule `h :+ body.` (plog2.0): consumed and
  /// true when next, so the statement is read as a rule marked consistency-restoring.
  bool acceptCrArrow() {
    if (peek().kind == Tok::Colon && peek(1).kind == Tok::Plus) {
      next();
      next();
      return true;
    }
    return false;
  }

  /// @brief Body of a rule after its head: `:- body`, `:+ body`, `:+` or nothing.
  void parseRuleTail(RawStmt& st) {
    if (acceptCrArrow()) {
      st.consistency_restoring = true;
      if (peek().kind != Tok::Dot) st.body = parseBody();
    } else if (accept(Tok::If)) {
      st.body = parseBody();
    }
  }

  /// @brief Observations and actions are facts (plog2.0 manual, section on statements); a
  /// conditional `do(a, y) :- b.` would need actions that depend on the world.
  void refuseBody(const char* what) {
    if (peek().kind == Tok::If)
      throw ParseError(locOf(peek()), std::string(what) + " must be a fact: a rule with " + what +
                                       " as its head is not supported");
  }

  // Statement terminator: '.' (a query at end of input may omit it).
  void endStatement() { expect(Tok::Dot, "'.' at end of statement"); }

  /// @brief One statement: declarations and directives go into prog_ at once, everything
  /// else (rules, selections, pr-atoms, obs, do, queries) is appended to `out` raw.
  void parseStatement(std::vector<RawStmt>& out) {
    const Token& first = peek();
    if (first.kind == Tok::Hash) {
      parseHashStatement();
      return;
    }
    if (parseDeclaration()) return;
    RawStmt st;
    st.loc = locOf(first);
    if (first.kind == Tok::LBracket) parseLabel(st);
    parseRawStatement(st, first);
    out.push_back(std::move(st));
  }

  /// @brief A statement starting with '#': `#generation N.`, `#domain`, `#const` or a plog2.0
  /// sort declaration `#s = ...`.
  void parseHashStatement() {
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

  /// @brief A classic sort declaration `s = {...}` / `s = 1..n` or attribute declarations
  /// (`a : s.`, `a1, a2 : s.`), read into prog_; false (nothing read) for other statements.
  bool parseDeclaration() {
    const Token& first = peek();
    if (first.kind == Tok::Ident && peek(1).kind == Tok::Eq &&
        (peek(2).kind == Tok::LBrace ||
         (peek(2).kind == Tok::Int && peek(3).kind == Tok::DotDot) ||
         (peek(2).kind == Tok::Hash))) {
      parseSortDecl();
      return true;
    }
    if (first.kind == Tok::Ident && peek(1).kind == Tok::Colon && peek(2).kind != Tok::Plus) {
      // (`a :+ b.` is a consistency-restoring rule, not a declaration)
      parseAttributeDecl();
      return true;
    }
    if (first.kind == Tok::Ident && peek(1).kind == Tok::Comma) return parseAttributeDeclList();
    return false;
  }

  /// @brief `a1, a2, a3 : s.` declares several attributes with the same signature; false
  /// (nothing read) when the names are not followed by ':'.
  bool parseAttributeDeclList() {
    size_t k = 0;
    while (peek(k).kind == Tok::Ident && peek(k + 1).kind == Tok::Comma) k += 2;
    if (peek(k).kind != Tok::Ident || peek(k + 1).kind != Tok::Colon) return false;
    std::vector<Token> names;
    for (size_t j = 0; j <= k; j += 2) names.push_back(peek(j));
    size_t save = pos_;
    for (const auto& n : names) {
      pos_ = save + k;  // re-parse the signature for each name
      parseAttributeDecl();
      prog_.attributes.back().name = n.text;
      prog_.attributes.back().loc = locOf(n);
    }
    return true;
  }

  /// @brief The label `[r]` (or classic `[r(B)]`) of a selection rule or pr-atom, which must
  /// follow it.
  void parseLabel(RawStmt& st) {
    next();
    const Token& l = peek();
    if (l.kind != Tok::Ident && l.kind != Tok::Var && l.kind != Tok::Int)
      fail(l, "label name after '['");
    st.w().label = next().text;
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

  /// @brief The statement after any label, by its first tokens: a selection rule, pr-atom,
  /// obs, do, query, constraint (`:- body`, `:+ body`) or rule. `first` is the statement's
  /// first token (the label's '[' when it has one).
  void parseRawStatement(RawStmt& st, const Token& first) {
    if (isIdent("random") && peek(1).kind == Tok::LParen) {
      parseRandom(st);
    } else if (isIdent("pr") && peek(1).kind == Tok::LParen) {
      parsePr(st);
    } else if (isIdent("obs") && peek(1).kind == Tok::LParen) {
      next();
      next();
      st.kind = RawStmt::Kind::Obs;
      st.w().obs = parseObsArgs(st.loc);
      refuseBody("obs(...)");
      endStatement();
    } else if (isIdent("do") && peek(1).kind == Tok::LParen) {
      next();
      next();
      st.kind = RawStmt::Kind::Do;
      st.w().do_lit = parseDoArgs(&st.w().do_args);
      refuseBody("do(...)");
      endStatement();
    } else if (first.kind == Tok::Question) {
      next();
      st.kind = RawStmt::Kind::Query;
      st.w().query = parseQueryBody(locOf(first));
      if (peek().kind != Tok::End) endStatement();
    } else if (first.kind == Tok::If) {
      next();
      st.kind = RawStmt::Kind::Rule;
      st.body = parseBody();
      endStatement();
    } else if (first.kind == Tok::Colon && peek(1).kind == Tok::Plus) {
      // headless consistency-restoring rule `:+ body.` (plog2.0: its head is the false
      // literal 0 != 0, so applying it can only make a world inconsistent)
      next();
      next();
      st.kind = RawStmt::Kind::Rule;
      st.consistency_restoring = true;
      st.body = parseBody();
      endStatement();
    } else {
      st.kind = RawStmt::Kind::Rule;
      st.head = parseLiteral(false);
      parseRuleTail(st);
      endStatement();
    }
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
      throw ParseError(locOf(n), "constant '" + n.text + "' defined twice");
    consts_[n.text] = x;
    endStatement();
  }

  void parseDomain() {
    SourceLocation loc = locOf(peek());
    next();  // '#'
    next();  // domain
    do {
      DomainDecl d;
      d.loc = locOf(peek());
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
    if (guard_)
      guard_->check(("expanding the range of sort " + s.name).c_str(), loc,
                    static_cast<std::size_t>(n) * (sizeof(Term) + 64));
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
      SourceLocation aloc = locOf(peek());
      SortDecl arg;
      arg.name = s.name;
      std::set<std::string> aseen;
      int r = 0, o = 0;
      parseSortUnion(arg, aseen, r, o);
      if (peek().kind == Tok::LParen)
        throw ParseError(locOf(peek()), "record sorts with variables and conditions "
                                     "(f(#s(X)) : ...) are not supported");
      if (arg.values.empty()) throw ParseError(aloc, "empty sort in record sort " + f.text);
      args.push_back(std::move(arg.values));
    } while (accept(Tok::Comma));
    expect(Tok::RParen, "')' closing record sort");
    unsigned long long total = 1;
    for (const auto& a : args) {
      total *= a.size();
      if (total > kMaxSortValues)
        throw ParseError(locOf(f), "record sort " + f.text + "(...) has more than " +
                                    std::to_string(kMaxSortValues) + " values");
    }
    if (guard_)
      guard_->check(("expanding the record sort " + f.text + "(...) of sort " + s.name).c_str(),
                    locOf(f), static_cast<std::size_t>(total) * (sizeof(Term) * (args.size() + 1) + 64));
    std::vector<size_t> idx(args.size(), 0);
    for (unsigned long long k = 0; k < total; ++k) {
      Term c;
      c.kind = Term::Kind::Compound;
      c.name = f.text;
      c.loc = locOf(f);
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
    if (!other) throw UnknownSymbolError(locOf(n).str() + ": unknown sort '" + n.text + "'");
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
    s.loc = locOf(peek());
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
        throw UnknownSymbolError(locOf(n).str() + ": unknown sort '" + n.text + "'");
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
    a.loc = locOf(peek());
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
    h.loc = locOf(peek());
    h.lhs = parseExpr();
    st.head = h;
    if (accept(Tok::Colon)) {
      st.w().has_range = true;
      if (accept(Tok::LBrace)) {
        st.w().range_var = expect(Tok::Var, "range variable in '{X : p(X)}'").text;
        expect(Tok::Colon, "':' after range variable");
        st.w().range_body = parseBody();
        expect(Tok::RBrace, "'}' closing dynamic range");
      } else {
        st.w().range_pred = expect(Tok::Ident, "'{' or predicate name for dynamic range").text;
      }
    } else if (accept(Tok::Comma)) {
      st.w().has_range = true;
      st.w().range_pred = expect(Tok::Ident, "dynamic range predicate name").text;
    }
    expect(Tok::RParen, "')' closing random(...)");
    parseRuleTail(st);
    endStatement();
  }

  /// @brief A probability's number or a fraction's part, refused at its token when it does
  /// not fit a double (a 400-digit 10...0/20...0 was inf / inf = nan, reported as a value
  /// outside [0, 1]; a 400-digit denominator made any numerator 0).
  double finiteProbabilityPart(const Token& t) {
    const double v = std::strtod(t.text.c_str(), nullptr);
    if (!std::isfinite(v))
      throw ParseError(locOf(t), "number " +
                                  (t.text.size() > 40 ? t.text.substr(0, 40) + "..." : t.text) +
                                  " in probability is too large for a double");
    return v;
  }

  void parsePr(RawStmt& st) {
    st.kind = RawStmt::Kind::Pr;
    st.priority = generation_;
    next();  // pr
    next();  // (
    st.w().pr_atom = parseLiteral(false);
    if (accept(Tok::Bar)) st.body = parseBody();
    expect(Tok::RParen, "')' or '|' in pr-atom");
    expect(Tok::Eq, "'=' before the probability");
    const Token& n = peek();
    std::string txt;
    double v;
    if (n.kind == Tok::Int || n.kind == Tok::Decimal) {
      next();
      txt = n.text;
      v = finiteProbabilityPart(n);
      if (accept(Tok::Slash)) {
        const Token& d = peek();
        if (d.kind != Tok::Int && d.kind != Tok::Decimal) fail(d, "denominator");
        next();
        double dv = finiteProbabilityPart(d);
        if (dv == 0) throw ParseError(locOf(d), "zero denominator in probability");
        v /= dv;
        txt += "/" + d.text;
      }
    } else {
      fail(n, "probability (number, fraction or decimal)");
    }
    st.w().prob = v;
    st.w().prob_text = txt;
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
        o.lit.setRhs() = v;
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
        o.lit.setRhs() = v;
      }
    }
    expect(Tok::RParen, "')' closing obs(...)");
    return o;
  }

  /// @brief Arguments of do(...) after `do(`; args (when given) receives the comma-separated
  /// argument terms as written (`do(a, y, true)` -> {a, y, true}), for do-facts tested in
  /// rule bodies and the agent form do(agent, a, y).
  RawLit parseDoArgs(std::vector<Term>* args = nullptr) {
    RawLit l = parseLiteral(false);
    if (accept(Tok::Comma)) {
      if (l.has_op) fail(peek(), "')' closing do(...)");
      l.has_op = true;
      l.op = CompareOp::Eq;
      l.setRhs() = parseExpr();
      if (args) *args = {l.lhs, l.rhs()};
      if (accept(Tok::Comma)) {
        // plog2.0 `do(a, y, true)`; an intervention cannot make a = y false
        Term flag = parseExpr();
        if (args) args->push_back(flag);
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
          SourceLocation l = locOf(next());
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
    l.loc = locOf(peek());
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
      l.setRhs() = parseExpr();
    }
    return l;
  }

  /// @brief Largest number of arithmetic operators left in one term after constant folding.
  /// A term is a tree as deep as its operator chain (`X+1+1+...`), and every later pass over it
  /// (resolution, export, grounding, the ASP translation) recurses through it: the limit keeps
  /// that recursion far from the stack's end. Ground integer arithmetic (`1+1+...+1`) is folded
  /// as it is read, so it never counts.
  static constexpr int kMaxTermOperators = 10000;

  /// @brief `lhs op rhs`: folded to an integer when both sides are integers and the operation
  /// is defined (overflow and division by zero stay terms, reported where they are evaluated).
  Term makeBinary(Term lhs, const Token& op_token, std::string op, Term rhs) {
    if (lhs.kind == Term::Kind::Integer && rhs.kind == Term::Kind::Integer) {
      long long r = 0;
      if (checkedBinary(op, lhs.value, rhs.value, &r) == ArithStatus::Ok) {
        lhs.value = r;
        return lhs;
      }
    }
    if (++term_operators_ > kMaxTermOperators)
      throw ParseError(locOf(op_token), "term too large: more than " +
                                         std::to_string(kMaxTermOperators) +
                                         " arithmetic operators in one term (the limit of a "
                                         "term's size; fold it or split it with variables)");
    Term b;
    b.kind = Term::Kind::Binary;
    b.loc = locOf(op_token);
    b.name = std::move(op);
    b.args.reserve(2);
    b.args.push_back(std::move(lhs));
    b.args.push_back(std::move(rhs));
    return b;
  }

  Term parseExpr() {
    if (depth_ == 0) term_operators_ = 0;  // a new top-level term
    if (++depth_ > 200) throw ParseError(locOf(peek()), "expression nested too deeply");
    Term t = parseProduct();
    while (peek().kind == Tok::Plus || peek().kind == Tok::Minus) {
      const Token& op = next();
      Term rhs = parseProduct();
      t = makeBinary(std::move(t), op, op.text, std::move(rhs));
    }
    --depth_;
    return t;
  }

  Term parseProduct() {
    Term t = parseUnary();
    while (peek().kind == Tok::Star || peek().kind == Tok::Slash || isIdent("mod") ||
           isIdent("div")) {
      const Token& op = next();
      Term rhs = parseUnary();
      t = makeBinary(std::move(t), op, op.text == "div" ? "/" : op.text, std::move(rhs));
    }
    return t;
  }

  Term parseUnary() {
    if (peek().kind == Tok::Minus) {
      SourceLocation loc = locOf(next());
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
        if (errno == ERANGE) throw ParseError(locOf(t), "integer too large '" + t.text + "'");
        return Term::integer(v, locOf(t));
      }
      case Tok::Var:
        next();
        return Term::variable(t.text, locOf(t));
      case Tok::Ident: {
        next();
        if (accept(Tok::LParen)) {
          Term c;
          c.kind = Term::Kind::Compound;
          c.name = t.text;
          c.loc = locOf(t);
          c.args.push_back(parseExpr());
          while (accept(Tok::Comma)) c.args.push_back(parseExpr());
          expect(Tok::RParen, "')' or ',' in argument list");
          return c;
        }
        auto c = consts_.find(t.text);
        if (c != consts_.end()) return Term::integer(c->second, locOf(t));
        return Term::symbol(t.text, locOf(t));
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
  /// @brief The text's file name, for the locations of tokens (Token::loc).
  std::string file_;
  SourceLocation locOf(const Token& t) const { return t.loc(file_); }
  Program& prog_;
  Dialect dialect_;
  size_t pos_ = 0;
  int depth_ = 0;
  MemoryGuard* guard_ = nullptr;
  /// @brief Operators of the term being read (see kMaxTermOperators).
  int term_operators_ = 0;
  /// @brief Sorts named in classic declarations before their own declaration.
  std::vector<Token> pending_sorts_;
  std::set<std::string> range_only_;
  /// @brief #domain declarations whose sort is checked at the end of the text.
  std::vector<DomainDecl> pending_domains_;
  /// @brief `#const` definitions seen so far (name -> value).
  std::map<std::string, long long> consts_;
};

}  // namespace

void parseInto(Program& program, const std::string& text, const std::string& file_name,
               Dialect dialect) {
  parseInto(program, text, file_name, dialect, ParseOptions());
}

void parseInto(Program& program, const std::string& text, const std::string& file_name,
               Dialect dialect, const ParseOptions& options) {
  MemoryGuard guard(options.memory_budget);
  guard.check("reading the text", SourceLocation{file_name, 1, 1}, text.size() / 2 * sizeof(Token));
  Program work = program;
  ensureBoolean(work);
  Parser parser(text, file_name, work, dialect, &guard);
  std::vector<RawStmt> stmts = parser.parseAll();
  parser.releaseTokens();
  ResolveSettings settings;
  settings.fresh = freshBase(program);
  settings.plog2 = parser.dialect() == Dialect::Plog2;
  settings.range_only = parser.rangeOnly();
  settings.strict_sorts = options.strict_sorts;
  settings.guard = &guard;
  resolveStatements(work, stmts, settings);
  if (program.sorts.empty() && program.attributes.empty() && program.rules.empty() &&
      program.random_rules.empty() && program.pr_atoms.empty())
    work.dialect = parser.dialect();
  program = std::move(work);
}

Program parseProgram(const std::string& text, const std::string& file_name, Dialect dialect) {
  return parseProgram(text, file_name, dialect, ParseOptions());
}

Program parseProgram(const std::string& text, const std::string& file_name, Dialect dialect,
                     const ParseOptions& options) {
  Program p;
  parseInto(p, text, file_name, dialect, options);
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
  return resolveRawQuery(work, rq, freshBase(program));
}

AttributeTerm parseAttributeTerm(const Program& program, const std::string& text,
                                 const std::string& file_name) {
  Program work = program;
  ensureBoolean(work);
  Parser parser(text, file_name, work, Dialect::Classic);
  Term t = parser.parseStandaloneTerm();
  if (t.kind != Term::Kind::Symbol && t.kind != Term::Kind::Compound)
    throw ParseError(t.loc, "expected an attribute term, got '" + toString(t) + "'");
  AttributeTerm a = resolveAttributeTerm(work, t);
  for (const auto& x : a.args)
    if (!x.isGround()) throw ParseError(t.loc, "attribute term must be ground");
  return a;
}

}  // namespace plog
}  // namespace krr
