#include "policy_text.h"

#include <cctype>
#include <cerrno>
#include <cstdlib>
#include <sstream>

namespace krr {
namespace pomdp {
namespace detail {

SourceLocation locationOf(const std::string& text, std::size_t offset, const std::string& file) {
  SourceLocation loc{file, 1, 1};
  for (std::size_t i = 0; i < offset && i < text.size(); ++i) {
    if (text[i] == '\n') {
      ++loc.line;
      loc.column = 1;
    } else {
      ++loc.column;
    }
  }
  return loc;
}

std::vector<Tok> tokenize(const std::string& text, std::size_t begin, std::size_t end) {
  std::vector<Tok> out;
  std::size_t i = begin;
  while (i < end) {
    while (i < end && std::isspace(static_cast<unsigned char>(text[i]))) ++i;
    if (i >= end) break;
    std::size_t j = i;
    while (j < end && !std::isspace(static_cast<unsigned char>(text[j]))) ++j;
    out.push_back({text.substr(i, j - i), i});
    i = j;
  }
  return out;
}

double parseDouble(const Tok& t, const std::string& text, const std::string& file) {
  const char* p = t.text.c_str();
  char* e = nullptr;
  errno = 0;
  double v = std::strtod(p, &e);
  if (e == p || *e != '\0' || errno == ERANGE)
    throw ParseError(locationOf(text, t.offset, file), "expected a number, got '" + t.text + "'");
  return v;
}

long parseInt(const Tok& t, const std::string& text, const std::string& file) {
  const char* p = t.text.c_str();
  char* e = nullptr;
  errno = 0;
  long v = std::strtol(p, &e, 10);
  if (e == p || *e != '\0' || errno == ERANGE || v < 0)
    throw ParseError(locationOf(text, t.offset, file),
                     "expected a non-negative integer, got '" + t.text + "'");
  return v;
}

std::string fmt(double v) {
  std::ostringstream ss;
  ss.precision(17);
  ss << v;
  return ss.str();
}

TokenReader::TokenReader(const std::string& text, const std::string& file)
    : text_(text), file_(file), toks_(tokenize(text, 0, text.size())) {}

const Tok& TokenReader::need(const char* what) {
  if (i_ >= toks_.size())
    throw ParseError(locationOf(text_, text_.size(), file_),
                     std::string("unexpected end of file, expected ") + what);
  return toks_[i_++];
}

void TokenReader::keyword(const char* kw) {
  const Tok& t = need(kw);
  if (t.text != kw) throw errorAt(t, std::string("expected '") + kw + "', got '" + t.text + "'");
}

ParseError TokenReader::errorAt(const Tok& t, const std::string& message) const {
  return ParseError(locationOf(text_, t.offset, file_), message);
}

std::size_t TokenReader::count(const char* what) {
  const Tok& t = need(what);
  const auto n = static_cast<std::size_t>(parseInt(t, text_, file_));
  if (n > toks_.size() - i_)
    throw errorAt(t, std::string(what) + " " + t.text + " exceeds the " +
                         std::to_string(toks_.size() - i_) + " values left in the file");
  return n;
}

void TokenReader::finish() const {
  if (i_ < toks_.size()) throw errorAt(toks_[i_], "unexpected trailing token '" + toks_[i_].text + "'");
}

}  // namespace detail
}  // namespace pomdp
}  // namespace krr
