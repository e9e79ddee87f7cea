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
    : text_(text), file_(file) {
  bool inToken = false;
  for (const char c : text) {
    const bool space = std::isspace(static_cast<unsigned char>(c)) != 0;
    if (!space && !inToken) ++total_;
    inToken = !space;
  }
}

bool TokenReader::scan() {
  const std::size_t end = text_.size();
  while (pos_ < end && std::isspace(static_cast<unsigned char>(text_[pos_]))) ++pos_;
  if (pos_ >= end) return false;
  std::size_t j = pos_;
  while (j < end && !std::isspace(static_cast<unsigned char>(text_[j]))) ++j;
  cur_.text.assign(text_, pos_, j - pos_);
  cur_.offset = pos_;
  pos_ = j;
  return true;
}

const Tok& TokenReader::need(const char* what) {
  if (!scan())
    throw ParseError(locationOf(text_, text_.size(), file_),
                     std::string("unexpected end of file, expected ") + what);
  ++used_;
  return cur_;
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
  if (n > total_ - used_)
    throw errorAt(t, std::string(what) + " " + t.text + " exceeds the " +
                         std::to_string(total_ - used_) + " values left in the file");
  return n;
}

void TokenReader::finish() {
  if (scan()) throw errorAt(cur_, "unexpected trailing token '" + cur_.text + "'");
}

}  // namespace detail
}  // namespace pomdp
}  // namespace krr
