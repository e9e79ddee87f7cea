/**
 * @file policy_text.h
 * @brief Internal: the token reader shared by the policy text formats (alpha-vector and
 * turn-limited policies), so both report malformed files the same way (file:line:col).
 */
#pragma once

#include <cstddef>
#include <string>
#include <vector>

#include "krr_core/common/errors.h"

namespace krr {
namespace pomdp {
namespace detail {

/// @brief file:line:col of a byte offset in a text.
SourceLocation locationOf(const std::string& text, std::size_t offset, const std::string& file);

/// @brief One whitespace-separated token and its byte offset.
struct Tok {
  std::string text;
  std::size_t offset;
};

/// @brief The tokens of text[begin, end).
std::vector<Tok> tokenize(const std::string& text, std::size_t begin, std::size_t end);
/// @throws ParseError unless the token is a finite-range number.
double parseDouble(const Tok& t, const std::string& text, const std::string& file);
/// @throws ParseError unless the token is a non-negative integer.
long parseInt(const Tok& t, const std::string& text, const std::string& file);
/// @brief 17 significant digits: an exact round trip of a double.
std::string fmt(double v);

/// @brief Reads the tokens of a whole text in order, one at a time: nothing is copied but the
/// current token (a 150,000-vector policy is 6 M tokens; kept all at once they took 5 times
/// the file's size).
class TokenReader {
 public:
  /// @brief Counts the tokens (for count()) without copying any.
  TokenReader(const std::string& text, const std::string& file);
  /// @brief The next token, valid until the next call. @throws ParseError at the end of the text.
  const Tok& need(const char* what);
  /// @brief The next token must be `kw`.
  void keyword(const char* kw);
  long integer(const char* what) { return parseInt(need(what), text_, file_); }
  double number(const char* what) { return parseDouble(need(what), text_, file_); }
  /// @brief A ParseError at token t.
  ParseError errorAt(const Tok& t, const std::string& message) const;
  /// @brief A count read next that must not exceed the tokens left (a declared size the file
  /// cannot hold is refused before anything is allocated for it).
  std::size_t count(const char* what);
  /// @throws ParseError if tokens are left.
  void finish();

 private:
  /// @brief Scan the token at or after pos_ into cur_; false at the end of the text.
  bool scan();
  const std::string& text_;
  const std::string& file_;
  std::size_t pos_ = 0, total_ = 0, used_ = 0;
  Tok cur_;
};

}  // namespace detail
}  // namespace pomdp
}  // namespace krr
