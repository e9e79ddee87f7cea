/**
 * @file plog.cpp
 * @brief `plog FILE... [--query "..."]... [--json] [--backend auto|native|asp] [--dialect d]
 * [--clingo PATH]`: answer the queries contained in P-log files and given on the command
 * line, one line per query. The default back end `auto` uses the native exact engine where
 * the program is inside its fragment and clingo otherwise; `native` refuses programs outside
 * the fragment, `asp` answers everything through clingo.
 *
 * Output: `QUERY : PROBABILITY` per query, or with --json one object per line
 * {"query": ..., "probability": ..., "backend": ...} (the back end that answered; plus
 * "warnings": [...] when the parser left statements out, see --strict-sorts). The files form one program (later files
 * add statements to the first); their queries are answered first, in order, then the
 * --query ones.
 *
 * Exit codes: 0 success, 1 input error (parse, unknown symbol, incoherent program, missing or
 * unreadable file, clingo failure), 2 usage error. Errors go to stderr as
 * `file:line:col: message` (the query's position for errors met while answering it;
 * `FILE: message` when the file itself cannot be read).
 */
#include <cmath>
#include <cstdio>
#include <iostream>
#include <string>
#include <vector>

#include "krr_core/common/cli.h"
#include "krr_core/common/errors.h"
#include "krr_core/common/files.h"
#include "krr_core/common/json.h"
#include "krr_core/common/main_guard.h"
#include "krr_core/plog/asp_backend.h"
#include "krr_core/plog/parser.h"
#include "krr_core/plog/reasoner.h"

namespace {

constexpr const char* kEpilog =
    "--backend auto (the default): the native exact engine where the program is inside its\n"
    "fragment (stratified negation, no loops through `not`, no rule defining a random attribute,\n"
    "factors within limits), clingo otherwise; inside the fragment the native engine alone when\n"
    "its estimated cost is well below clingo's, else both race and the first answer wins (clingo\n"
    "never alone there). --backend native: the native engine only; programs outside it are\n"
    "refused. --backend asp: translate to ASP and enumerate the possible worlds with clingo.\n"
    "A fact or rule whose head has a value outside its declared sort is left out (P-log's sorted\n"
    "grounding, as plog2.0 does) with a warning on stderr (and in the JSON rows, \"warnings\");\n"
    "--strict-sorts makes it an error.\n"
    "Exit status: 0 success, 1 input error, 2 usage error.\n";

std::string fmt(double p) {
  char buf[64];
  std::snprintf(buf, sizeof(buf), "%.10g", p);
  return buf;
}

/// `loc: message` unless the message already starts with a location (a ParseError).
std::string located(const krr::SourceLocation& loc, const std::string& what) {
  if (loc.file.empty() || what.rfind(loc.file + ":", 0) == 0) return what;
  return loc.str() + ": " + what;
}

struct Job {
  krr::plog::Query query;
  std::string text;  ///< as printed
};

}  // namespace

/// @brief The program; main() runs it under guardedMain so that no exception aborts it.
static int mainBody(int argc, char** argv) {
  std::vector<std::string> files, cli_queries;
  bool json = false;
  krr::plog::Backend backend = krr::plog::Backend::Auto;
  std::string clingo = "clingo";
  krr::plog::Dialect dialect = krr::plog::Dialect::Auto;
  bool strict_sorts = false;
  krr::OptionParser cli("plog",
                        "Answer the queries in the P-log files (one program: later files add\n"
                        "statements to the first) and those given with --query, one line per query.");
  cli.positional("FILE", "P-log file", [&](const std::string& v) { files.push_back(v); }, true);
  cli.add("--query", "QUERY", "a query, e.g. \"?{a=y} | obs(..), do(..)\" (repeatable)",
          &cli_queries)
      .alias("-q");
  cli.flag("--json", "one JSON object per answer: query, probability, backend (, warnings)",
           &json);
  cli.add("--backend", "auto|native|asp", "the back end that answers (see below)",
          [&](const std::string& v) { backend = krr::plog::parseBackend(v); }, "auto");
  cli.add("--dialect", "classic|plog2", "syntax of the first file",
          [&](const std::string& v) {
            if (v == "classic") dialect = krr::plog::Dialect::Classic;
            else if (v == "plog2") dialect = krr::plog::Dialect::Plog2;
            else throw krr::ConfigError("unknown dialect '" + v + "' (expected classic or plog2)");
          },
          "detected from the file");
  cli.add("--clingo", "PATH", "the clingo program of the asp back end", &clingo);
  cli.flag("--strict-sorts", "a head value outside its sort is an error, not a warning",
           &strict_sorts);
  cli.epilog(kEpilog);
  if (const auto status = cli.parse(argc, argv, [&]() {
        if (files.empty()) throw krr::ConfigError("no input file");
      }))
    return *status;
  // Never destroyed: the process ends after the answers, and freeing the grounding takes
  // a tenth of a one-query run on the 50x50 navigation knowledge (the OS reclaims it).
  krr::plog::Reasoner& r = *new krr::plog::Reasoner;
  r.setStrictSorts(strict_sorts);
  // All files form one program; each keeps its name for error locations.
  r.loadFile(files[0], dialect);
  for (size_t i = 1; i < files.size(); ++i)
    r.addStatements(krr::readFile(files[i]), "", files[i]);
  for (const auto& w : r.warnings()) std::cerr << w << "\n";
  std::string warnings_json;
  for (const auto& w : r.warnings())
    warnings_json += (warnings_json.empty() ? "" : ", ") + krr::jsonString(w);
  std::vector<Job> jobs;
  for (const auto& q : r.program().queries) jobs.push_back({q, q.text});
  int rc = 0;
  for (const auto& text : cli_queries) {
    try {
      jobs.push_back({krr::plog::parseQuery(r.program(), text, "<command line>"), text});
    } catch (const krr::Error& e) {
      std::cerr << e.what() << "\n";
      rc = 1;
    }
  }
  const bool asp = backend == krr::plog::Backend::Asp;
  krr::plog::AspOptions opt;
  opt.clingo_path = clingo;
  r.setAspOptions(opt);
  r.setBackend(backend);
  auto print = [&](const std::string& q, double p, krr::plog::Backend answered) {
    if (json)
      std::cout << "{\"query\": " << krr::jsonString(q)
                << ", \"probability\": " << krr::jsonNumber(p) << ", \"backend\": \""
                << krr::plog::backendName(answered) << "\""
                << (warnings_json.empty() ? "" : ", \"warnings\": [" + warnings_json + "]")
                << "}\n";
    else
      std::cout << q << " : " << fmt(p) << "\n";
  };
  if (asp) {
    // One clingo process answers every query (a multi-shot run per intervention set).
    krr::plog::AspBackend asp_backend(opt);
    std::vector<krr::plog::Query> queries;
    for (const auto& j : jobs) queries.push_back(j.query);
    std::vector<std::string> errors;
    const std::vector<double> p = asp_backend.probabilities(r.program(), queries, &errors);
    // probability sums renormalised within rounding, as the native engine reports them
    for (const auto& w : asp_backend.warnings()) {
      std::cerr << w << "\n";
      warnings_json += (warnings_json.empty() ? "" : ", ") + krr::jsonString(w);
    }
    for (size_t i = 0; i < jobs.size(); ++i) {
      if (!errors[i].empty() || std::isnan(p[i])) {
        std::cerr << located(jobs[i].query.loc, errors[i]) << "\n";
        rc = 1;
      } else {
        print(jobs[i].text, p[i], krr::plog::Backend::Asp);
      }
    }
  } else {
    size_t warned = r.warnings().size();
    for (const auto& j : jobs) {
      try {
        const double p = r.probability(j.query);
        // warnings met while answering (probability sums renormalised within rounding)
        for (; warned < r.warnings().size(); ++warned) std::cerr << r.warnings()[warned] << "\n";
        print(j.text, p, r.stats().last_backend);
      } catch (const krr::Error& e) {
        std::cerr << located(j.query.loc, e.what()) << "\n";
        rc = 1;
      }
    }
  }
  return rc;
}

int main(int argc, char** argv) {
  return krr::guardedMain("plog", mainBody, argc, argv);
}
