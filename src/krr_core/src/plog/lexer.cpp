/**
 * @file lexer.cpp
 * @brief Tokens of P-log text (both dialects): identifiers, variables, numbers, operators,
 * with file:line:col for every token.
 */
#include "parser_syntax.h"

#include <cctype>

#include "krr_core/common/errors.h"

namespace krr {
namespace plog {
namespace syntax {

std::vector<Token> lex(const std::string& src, const std::string& file, MemoryGuard* guard) {
  std::vector<Token> out;
  // About one token per 3 bytes of statements: reserved up front so that a large text is not
  // copied as the vector grows (parseInto checked the memory budget for twice as many)
  out.reserve(src.size() / 3 + 16);
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
    t.line = line;
    t.column = col;
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
            throw ParseError(t.loc(file), "unexpected character " + shown);
          }
        }
      }
      t.text = src.substr(i, n);
      adv(n);
    }
    if (guard) guard->tickAt("reading the text (tokens)", [&] { return t.loc(file); });
    out.push_back(std::move(t));
  }
  Token e;
  e.kind = Tok::End;
  e.line = line;
  e.column = col;
  out.push_back(e);
  return out;
}

}  // namespace syntax
}  // namespace plog
}  // namespace krr
