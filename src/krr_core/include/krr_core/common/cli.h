/**
 * @file cli.h
 * @brief The one command-line option parser of the krr_core programs, so that help, errors and
 * exit codes are the same everywhere:
 *  - `-h` / `--help` prints the generated usage on stdout and exits 0 without running anything;
 *  - an unknown option, a missing value, a malformed number or a failed check prints
 *    "program: message" and the usage on stderr and exits 2.
 *
 * @code
 *   krr::OptionParser cli("nav_transfer", "Learn one task, apply to another.");
 *   cli.add("--trials", "N", "trials to run", &trials);
 *   cli.flag("--json", "print JSON", &json);
 *   if (const auto status = cli.parse(argc, argv)) return *status;
 * @endcode
 */
#pragma once

#include <cstddef>
#include <cstdint>
#include <functional>
#include <optional>
#include <string>
#include <vector>

namespace krr {

/// @brief `value` as a finite number. @throws ConfigError naming `option`.
double parseNumberOption(const std::string& option, const std::string& value);

/// @brief `value` as a non-negative integer (at most 1e15). @throws ConfigError naming `option`.
std::size_t parseCountOption(const std::string& option, const std::string& value);

/// @brief A comma-separated list of numbers ("0.1,0.5"). @throws ConfigError naming `option`.
std::vector<double> parseNumberListOption(const std::string& option, const std::string& value);

/// @brief A comma-separated list of non-negative integers. @throws ConfigError naming `option`.
std::vector<std::size_t> parseCountListOption(const std::string& option, const std::string& value);

/// @brief `value` split at `separator` (empty items kept, an empty value gives one empty item).
std::vector<std::string> splitOption(const std::string& value, char separator = ',');

/**
 * @brief Declared options (name, value name, help text, default) and positional arguments;
 * generates the usage text and parses argv into the declared targets.
 *
 * Every declaring call returns the parser; required(), alias() and defaultText() amend the
 * option declared last. Values may follow as the next argument or as `--name=value`; `--`
 * ends the options. A setter may throw krr::Error (e.g. ConfigError) to reject a value.
 */
class OptionParser {
 public:
  /// @brief A setter receives the option's value (the argument, for positionals).
  using Setter = std::function<void(const std::string& value)>;

  /**
   * @param program the program's name, the prefix of every message
   * @param summary what the program does, printed after the usage line
   */
  OptionParser(std::string program, std::string summary = "");

  /// @brief An option without a value: sets `*target` to true.
  OptionParser& flag(const std::string& name, const std::string& help, bool* target);
  /// @brief An option without a value that runs `action`.
  OptionParser& flag(const std::string& name, const std::string& help,
                     std::function<void()> action);

  /// @brief An option with a value. The default shown is `*target` at declaration (strings:
  /// when not empty). Numbers are checked (counts: non-negative integers).
  OptionParser& add(const std::string& name, const std::string& value_name,
                    const std::string& help, std::string* target);
  OptionParser& add(const std::string& name, const std::string& value_name,
                    const std::string& help, double* target);
  OptionParser& add(const std::string& name, const std::string& value_name,
                    const std::string& help, std::size_t* target);
  OptionParser& add(const std::string& name, const std::string& value_name,
                    const std::string& help, std::uint32_t* target);
  OptionParser& add(const std::string& name, const std::string& value_name,
                    const std::string& help, int* target);
  /// @brief Each occurrence appends its value (a repeatable option).
  OptionParser& add(const std::string& name, const std::string& value_name,
                    const std::string& help, std::vector<std::string>* target);
  /// @brief An option whose value `setter` interprets; `default_text` is shown as the default.
  OptionParser& add(const std::string& name, const std::string& value_name,
                    const std::string& help, Setter setter, const std::string& default_text = "");

  /// @brief A positional argument; `repeated` takes all remaining ones (shown as NAME...).
  OptionParser& positional(const std::string& value_name, const std::string& help, Setter setter,
                           bool repeated = false);

  /// @brief The option declared last must be given.
  OptionParser& required();
  /// @brief Another name of the option declared last (e.g. --trials for --samples).
  OptionParser& alias(const std::string& name);
  /// @brief An old name of the option declared last, still accepted but not listed in the
  /// usage: using it prints one line on stderr ("program: option --repo is deprecated: use
  /// --root"), so scripts keep working while their authors learn the new name.
  OptionParser& deprecatedAlias(const std::string& name);
  /// @brief The default shown for the option declared last ("" shows none).
  OptionParser& defaultText(const std::string& text);
  /// @brief Text printed at the end of the usage (details, file formats).
  OptionParser& epilog(const std::string& text);

  /**
   * @brief Parse argv[1..argc). Then `check` (if any) runs: it may throw krr::Error to reject
   * the combination of options.
   * @return the exit status when the program must stop now (0 after --help, 2 after an
   * error, both reported as described in the file comment), std::nullopt to run.
   */
  std::optional<int> parse(int argc, const char* const* argv,
                           const std::function<void()>& check = {});
  std::optional<int> parse(int argc, char** argv, const std::function<void()>& check = {}) {
    return parse(argc, const_cast<const char* const*>(argv), check);
  }

  /// @brief Whether the option (any of its names) was given in the last parse().
  bool given(const std::string& name) const;
  /// @brief The generated usage text (what --help prints).
  std::string usage() const;
  /// @brief Report "program: message" and the usage on stderr; returns 2, the status to exit with.
  int fail(const std::string& message) const;
  const std::string& program() const { return program_; }

 private:
  struct Option {
    std::vector<std::string> names;
    std::vector<std::string> deprecated_names;  ///< accepted, not listed, warned about
    std::string value_name, help, default_text;
    Setter setter;               ///< options with a value
    std::function<void()> action;  ///< flags
    bool is_required = false, given = false;
  };
  struct Positional {
    std::string value_name, help;
    Setter setter;
    bool repeated = false;
  };

  OptionParser& declare(Option o);
  Option* find(const std::string& name);
  void parseArguments(int argc, const char* const* argv, bool* help);

  std::string program_, summary_, epilog_;
  std::vector<Option> options_;
  std::vector<Positional> positionals_;
  bool last_is_option_ = false;
};

}  // namespace krr
