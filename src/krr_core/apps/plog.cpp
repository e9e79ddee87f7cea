/**
 * @file plog.cpp
 * @brief `plog FILE... [--query "..."]... [--json] [--dialect classic|plog2]`: answer the
 * queries contained in P-log files and given on the command line, one line per query.
 *
 * Exit codes: 0 success, 1 input error (parse, unknown symbol, incoherent program, I/O),
 * 2 usage error. Errors go to stderr as `file:line:col: message`.
 */
#include <cstdio>
#include <iostream>
#include <string>
#include <vector>

#include "krr_core/common/errors.h"
#include "krr_core/common/files.h"
#include "krr_core/common/json.h"
#include "krr_core/plog/parser.h"
#include "krr_core/plog/reasoner.h"

namespace {

void usage(std::ostream& os) {
  os << "usage: plog FILE... [--query \"?{a=y} | obs(..), do(..)\"]... [--json] "
        "[--dialect classic|plog2]\n"
        "  Answers the queries in the files and on the command line, one line per query.\n";
}

std::string fmt(double p) {
  char buf[64];
  std::snprintf(buf, sizeof(buf), "%.10g", p);
  return buf;
}

}  // namespace

int main(int argc, char** argv) {
  std::vector<std::string> files, queries;
  bool json = false;
  krr::plog::Dialect dialect = krr::plog::Dialect::Auto;
  for (int i = 1; i < argc; ++i) {
    std::string a = argv[i];
    if (a == "--json") {
      json = true;
    } else if (a == "--query" || a == "-q") {
      if (i + 1 >= argc) {
        std::cerr << "plog: --query needs an argument\n";
        usage(std::cerr);
        return 2;
      }
      queries.push_back(argv[++i]);
    } else if (a == "--dialect") {
      if (i + 1 >= argc) {
        std::cerr << "plog: --dialect needs an argument\n";
        return 2;
      }
      std::string d = argv[++i];
      if (d == "classic") dialect = krr::plog::Dialect::Classic;
      else if (d == "plog2") dialect = krr::plog::Dialect::Plog2;
      else {
        std::cerr << "plog: unknown dialect '" << d << "' (expected classic or plog2)\n";
        return 2;
      }
    } else if (a == "--help" || a == "-h") {
      usage(std::cout);
      return 0;
    } else if (!a.empty() && a[0] == '-' && a != "-") {
      std::cerr << "plog: unknown option '" << a << "'\n";
      usage(std::cerr);
      return 2;
    } else {
      files.push_back(a);
    }
  }
  if (files.empty()) {
    std::cerr << "plog: no input file\n";
    usage(std::cerr);
    return 2;
  }
  try {
    krr::plog::Reasoner r;
    // All files form one program; each keeps its name for error locations.
    r.loadFile(files[0], dialect);
    for (size_t i = 1; i < files.size(); ++i)
      r.addStatements(krr::readFile(files[i]), "", files[i]);
    auto print = [&](const std::string& q, double p) {
      if (json)
        std::cout << "{\"query\": " << krr::jsonString(q)
                  << ", \"probability\": " << krr::jsonNumber(p) << "}\n";
      else
        std::cout << q << " : " << fmt(p) << "\n";
    };
    int rc = 0;
    for (const auto& q : r.program().queries) {
      try {
        print(q.text, r.probability(q));
      } catch (const krr::Error& e) {
        std::cerr << e.what() << "\n";
        rc = 1;
      }
    }
    for (const auto& q : queries) {
      try {
        print(q, r.probability(krr::plog::parseQuery(r.program(), q, "<command line>")));
      } catch (const krr::Error& e) {
        std::cerr << e.what() << "\n";
        rc = 1;
      }
    }
    return rc;
  } catch (const krr::Error& e) {
    std::cerr << e.what() << "\n";
    return 1;
  } catch (const std::exception& e) {
    std::cerr << "plog: internal error: " << e.what() << "\n";
    return 1;
  }
  return 0;
}
