/**
 * @file errors.h
 * @brief Typed exceptions of the KRR-RL core.
 *
 * The core never logs and never exits: it throws one of these, and the caller (a CLI or a
 * ROS node) catches it at its boundary, reports it and carries on. Every error names what
 * went wrong and where, so that a user can fix the input without reading the code.
 */
#pragma once

#include <stdexcept>
#include <string>

namespace krr {

/// @brief Base of every error the core throws, so callers can catch them in one place.
class Error : public std::runtime_error {
 public:
  explicit Error(const std::string& what) : std::runtime_error(what) {}
};

/// @brief A position in a text input, for errors that point the user at the offending token.
struct SourceLocation {
  std::string file;  ///< file name, or "<string>" for inline text
  int line = 0;      ///< 1-based
  int column = 0;    ///< 1-based
  /// @brief "file:line:col", the format compilers use so editors can jump to it.
  std::string str() const {
    return file + ":" + std::to_string(line) + ":" + std::to_string(column);
  }
};

/// @brief Malformed text input (P-log, .pomdp, YAML): what() is "file:line:col: message".
class ParseError : public Error {
 public:
  ParseError(const SourceLocation& loc, const std::string& message)
      : Error(loc.str() + ": " + message), location_(loc), message_(message) {}
  const SourceLocation& location() const { return location_; }
  const std::string& message() const { return message_; }

 private:
  SourceLocation location_;
  std::string message_;
};

/// @brief A well-formed program or model that has no meaning (e.g. probabilities above 1).
class IncoherentError : public Error {
 public:
  using Error::Error;
};

/// @brief A P-log program outside the native engine's exact fragment (negation that is not
/// stratified, cyclic rules or selections, a rule defining a random attribute, factors beyond
/// its size limits): its answer would not be exact, so another back end (ASP) must answer.
class OutsideFragmentError : public Error {
 public:
  using Error::Error;
};

/// @brief A name the program or model does not define (sort, attribute, room, cell...).
class UnknownSymbolError : public Error {
 public:
  using Error::Error;
};

/// @brief An out-of-range or inconsistent parameter; what() names the field and the value.
class ConfigError : public Error {
 public:
  using Error::Error;
};

/// @brief A map that cannot be loaded: what() names the file and the field.
class MapError : public Error {
 public:
  using Error::Error;
};

/// @brief A goal that cannot be reached from the start (planner or navigation model).
class NoPathError : public Error {
 public:
  using Error::Error;
};

/// @brief File-system failures (cannot read, cannot write atomically).
class IoError : public Error {
 public:
  using Error::Error;
};

}  // namespace krr
