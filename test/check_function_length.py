#!/usr/bin/python3
"""Check that no C++ function in src/ (outside tests) is longer than 120 lines (issue 25).
Exit 1 and list every violation.

Scans every *.cpp and *.h under src/, skipping test/ directories, and finds the function
bodies with a brace-matching scan that skips comments, string and character literals (raw
strings too) and preprocessor lines. A function's length counts from the line of its name in
the signature to the line of its closing brace. Classes, structs, unions, enums and
namespaces are scopes, not functions; what a function body holds (lambdas, local classes and
their member functions) counts as part of that function. In-class member functions and
lambdas at namespace or class scope are functions of their own.

A function may stay long only while it is listed in the allowlist (default
test/function_length_allowlist.txt): one `path:function_name` a line, with a comment (`#`) why,
the path relative to the repository root and the name as this script reports it (qualified by
its class, e.g. `Reader::read`). The check fails on
  - a function longer than the limit that the allowlist does not list, and
  - an allowlist entry that names no function longer than the limit any more (split, renamed
    or removed): the list can only shrink.

Usage: check_function_length.py [--root REPO] [--allowlist FILE] [--limit N]
"""
import argparse
import os
import re
import sys

LIMIT = 120
SOURCE_EXT = (".cpp", ".h")
SKIP_DIRS = {"test", ".git", "__pycache__", "node_modules"}
ALLOWLIST = os.path.join("test", "function_length_allowlist.txt")

# Comments, string and character literals (raw strings too) and preprocessor lines, blanked
# with spaces (newlines kept, so offsets and line numbers stay) before the braces are matched.
LEXEMES = re.compile(r'//[^\n]*|/\*.*?\*/|\b(?:u8|u|U|L)?R"([^(\s]*)\(.*?\)\1"'
                     r'|"(?:\\.|[^"\\\n])*"'
                     r"|(?<![\w'])'(?:\\.|[^'\\\n])*'"
                     r"|^[ \t]*#(?:\\\n|[^\n])*", re.S | re.M)
SCOPE_KEYWORD = re.compile(r"\b(?:namespace|class|struct|union|enum)\b")
ACCESS = re.compile(r"\b(?:public|private|protected)\s*:(?!:)")
ATTRIBUTE = re.compile(r"\[\[.*?\]\]", re.S)
OPERATOR_NAME = re.compile(r"\boperator\s*(?:\(\s*\)|\[\s*\]|[^\w\s(]+|\s\w[\w\s:<>*&]*)\s*$")
NAME = re.compile(r"(~?[A-Za-z_]\w*)\s*(?:<[^()]*>)?\s*$")
QUALIFIER = re.compile(r"([A-Za-z_]\w*)\s*(?:<[^()]*>)?\s*::\s*$")
VARIABLE = re.compile(r"([A-Za-z_]\w*)\s*=\s*$")


def blank_lexemes(text):
    """`text` with comments, literals and preprocessor lines replaced by spaces (lines kept)."""
    return LEXEMES.sub(lambda m: re.sub(r"[^\n]", " ", m.group(0)), text)


def strip_templates(header):
    """`header` without its `template <...>` prefixes (their parameters may say `class`)."""
    out, i = [], 0
    for m in re.finditer(r"\btemplate\s*<", header):
        if m.start() < i:
            continue
        out.append(header[i:m.start()])
        depth, j = 1, m.end()
        while j < len(header) and depth:
            depth += {"<": 1, ">": -1}.get(header[j], 0)
            j += 1
        out.append(" " * (j - m.start()))
        i = j
    out.append(header[i:])
    return "".join(out)


def paren_groups(header):
    """(open, close) offsets of the top-level () groups of `header`; None when unbalanced."""
    groups, depth, start = [], 0, 0
    for i, c in enumerate(header):
        if c in "([":
            if depth == 0 and c == "(":
                start = i
            depth += 1
        elif c in ")]":
            depth -= 1
            if depth < 0:
                return None
            if depth == 0 and c == ")":
                groups.append((start, i))
    return groups if depth == 0 else None


def classify(header):
    """What a '{' after `header` opens: ("scope", name), ("function", (name, offset)) or
    ("init", None) (an initialiser: the statement goes on after its '}').

    `header` is the code since the last ';', '{' or '}' of the enclosing scope."""
    h = strip_templates(ATTRIBUTE.sub(lambda m: " " * len(m.group(0)), header))
    h = ACCESS.sub(lambda m: " " * len(m.group(0)), h)
    groups = paren_groups(h)
    first_paren = groups[0][0] if groups else len(h)
    kw = SCOPE_KEYWORD.search(h)
    if kw and kw.start() < first_paren:
        m = re.match(r"\s*(?:final\b\s*)?(?:alignas\s*\([^)]*\)\s*)?([A-Za-z_]\w*)?",
                     h[kw.end():])
        name = m.group(1) if m and m.group(1) and kw.group(0) != "namespace" else ""
        return "scope", name
    if re.match(r"\s*extern\s*$", h):
        return "scope", ""
    if not groups or not h.strip():
        return "init", None
    # A brace initialiser in a constructor's member-initialiser list: `: a_(x), b_{y}`.
    after = h[groups[0][1] + 1:]
    if re.search(r"(?<!:):(?!:)", after) and re.search(r"[\w>]\s*$", h):
        return "init", None
    # The name: the identifier (or operator) before the first top-level parenthesis.
    before = h[:first_paren]
    if re.search(r"\boperator\s*$", before) and len(groups) > 1:  # operator()
        name, at = "operator()", re.search(r"\boperator\s*$", before).start()
        before = before[:at]
    else:
        m = OPERATOR_NAME.search(before) or NAME.search(before)
        if m and m.group(0).lstrip().startswith("operator"):
            name, at = " ".join(m.group(0).split()), m.start()
            before = before[:at]
        elif m:
            name, at = m.group(1), m.start(1)
            before = before[:at]
        else:  # a lambda: `auto f = [&](int x) {`
            v = VARIABLE.search(before.rsplit("[", 1)[0])
            if not v:
                return "function", ("(lambda)", first_paren)
            return "function", (v.group(1), v.start(1))
    qualifiers = []
    while True:
        q = QUALIFIER.search(before)
        if not q:
            break
        qualifiers.insert(0, q.group(1))
        before = before[:q.start()]
    return "function", ("::".join(qualifiers + [name]), at)


def functions(text):
    """(name, first line, length in lines) of every function defined in C++ `text`."""
    code = blank_lexemes(text)
    out = []
    stack = []  # per open brace: (kind, scope name or function record)
    hstart = 0  # where the current declaration's header starts
    in_function = 0  # open braces inside the outermost function body
    for i, c in enumerate(code):
        if in_function:
            if c == "{":
                in_function += 1
            elif c == "}":
                in_function -= 1
                if in_function == 0:
                    name, first = stack.pop()[1]
                    last = code.count("\n", 0, i) + 1
                    out.append((name, first, last - first + 1))
                    hstart = i + 1
            continue
        if c == ";":
            hstart = i + 1
        elif c == "{":
            kind, what = classify(code[hstart:i])
            if kind == "function":
                name, offset = what
                classes = [w for k, w in stack if k == "scope" and w]
                qualified = "::".join(classes + [name])
                stack.append((kind, (qualified, code.count("\n", 0, hstart + offset) + 1)))
                in_function = 1
            else:
                stack.append((kind, what))
                if kind == "scope":
                    hstart = i + 1
        elif c == "}":
            if stack:
                kind, _ = stack.pop()
                if kind == "scope":
                    hstart = i + 1
            else:
                hstart = i + 1
    return out


def source_files(root):
    base = os.path.join(root, "src")
    for d, dirs, files in os.walk(base):
        dirs[:] = sorted(x for x in dirs if x not in SKIP_DIRS)
        for f in sorted(files):
            if f.endswith(SOURCE_EXT):
                yield os.path.relpath(os.path.join(d, f), root).replace(os.sep, "/")


def read_allowlist(path):
    """{(file, function): line number} of the allowlist (missing file: empty)."""
    entries = {}
    if not os.path.isfile(path):
        return entries
    with open(path, encoding="utf-8") as f:
        for n, line in enumerate(f, 1):
            line = line.split("#", 1)[0].strip()
            if not line:
                continue
            rel, sep, name = line.partition(":")
            if not sep or not rel or not name:
                raise ValueError("%s:%d: expected path:function_name, got '%s'" % (path, n, line))
            entries[(rel.strip(), name.strip())] = n
    return entries


def check(root, allowlist_path, limit=LIMIT):
    """(problems, long functions [(file, line, name, length)], files checked, functions)."""
    allowed = read_allowlist(allowlist_path)
    long_functions, files, count = [], 0, 0
    lengths = {}  # (file, name) -> longest length
    for rel in source_files(root):
        files += 1
        with open(os.path.join(root, rel), encoding="utf-8", errors="replace") as f:
            text = f.read()
        for name, line, length in functions(text):
            count += 1
            lengths[(rel, name)] = max(lengths.get((rel, name), 0), length)
            if length > limit:
                long_functions.append((rel, line, name, length))
    problems = []
    for rel, line, name, length in long_functions:
        if (rel, name) not in allowed:
            problems.append("%s:%d: %s is %d lines, longer than %d: split it by responsibility"
                            % (rel, line, name, length, limit))
    shown = os.path.relpath(allowlist_path, root) if allowlist_path.startswith(root) \
        else allowlist_path
    for (rel, name), n in sorted(allowed.items(), key=lambda x: x[1]):
        length = lengths.get((rel, name))
        if length is None:
            problems.append("%s:%d: %s:%s names no function (removed or renamed?): remove "
                            "the entry" % (shown, n, rel, name))
        elif length <= limit:
            problems.append("%s:%d: %s:%s is %d lines now, within %d: remove the entry"
                            % (shown, n, rel, name, length, limit))
    return problems, long_functions, files, count


def main():
    here = os.path.dirname(os.path.dirname(os.path.realpath(__file__)))
    ap = argparse.ArgumentParser(description=__doc__.split("\n", 1)[0])
    ap.add_argument("--root", default=here, help="repository root (default: %(default)s)")
    ap.add_argument("--allowlist", help="allowlist file (default: ROOT/" + ALLOWLIST + ")")
    ap.add_argument("--limit", type=int, default=LIMIT, help="longest function allowed, in "
                    "lines (default: %(default)s)")
    args = ap.parse_args()
    root = os.path.abspath(args.root)
    if not os.path.isdir(os.path.join(root, "src")):
        print("check_function_length: no src/ under %s" % root, file=sys.stderr)
        return 2
    allowlist = os.path.abspath(args.allowlist or os.path.join(root, ALLOWLIST))
    try:
        problems, long_functions, files, count = check(root, allowlist, args.limit)
    except ValueError as e:
        print("check_function_length: %s" % e, file=sys.stderr)
        return 2
    allowed = read_allowlist(allowlist)
    listed = [f for f in long_functions if (f[0], f[2]) in allowed]
    for rel, line, name, length in listed:
        print("allowlisted: %s:%d: %s is %d lines" % (rel, line, name, length))
    for p in problems:
        print(p)
    print("function length: %d files, %d functions checked, %d longer than %d lines "
          "(%d allowlisted), %d problem%s" % (files, count, len(long_functions), args.limit,
                                              len(listed), len(problems),
                                              "" if len(problems) == 1 else "s"))
    return 1 if problems else 0


if __name__ == "__main__":
    sys.exit(main())
