#!/usr/bin/env python3
"""Keeps the library code readable in pieces: no function over --max-function lines and no source file
over --max-file lines in the given folders' .cpp/.hpp files (tests are not checked).

A function's length is counted from the line of its opening brace to the line of its closing brace.
Functions are found by brace matching after comments, strings and preprocessor lines are blanked: a
brace block at namespace or class scope whose header ends like a parameter list (qualifiers, a trailing
return type or a constructor's initializer list may follow) is a function; blocks inside it (lambdas,
local classes) count towards it. Exit 1 with one line per offender, file:line: what and how long.

  tools/check-code-size.py [--max-function 120] [--max-file 600] [--list N] [--allow ITEM=LINES]... FOLDER...

--allow names a known offender that may not grow: PATH=LINES for a file, PATH:FUNCTION=LINES for a
function (paths as found under the folders given); it fails only above LINES, and says when it is no
longer needed.
"""
import argparse
import os
import re
import sys

KEYWORDS = {"if", "for", "while", "switch", "catch", "return", "sizeof", "decltype", "alignof", "static_assert",
            "noexcept", "requires", "defined"}


def blank(text):
    """The text with comments, string and character literals and preprocessor lines replaced by spaces
    (newlines kept, so that line numbers stay)."""
    out = []
    i, n = 0, len(text)
    line_start = True
    while i < n:
        c = text[i]
        if line_start and c == "#":  # a preprocessor line, with its continuations
            j = i
            while j < n and (text[j] != "\n" or text[j - 1] == "\\"):
                j += 1
            out.append(re.sub(r"[^\n]", " ", text[i:j]))
            i = j
            continue
        if c in " \t":
            out.append(c)
            i += 1
            continue
        line_start = c == "\n"
        if text.startswith("//", i):
            j = text.find("\n", i)
            j = n if j < 0 else j
            out.append(" " * (j - i))
            i = j
        elif text.startswith("/*", i):
            j = text.find("*/", i + 2)
            j = n if j < 0 else j + 2
            out.append(re.sub(r"[^\n]", " ", text[i:j]))
            i = j
        elif c == "R" and text.startswith('R"', i) and (i == 0 or not (text[i - 1].isalnum() or text[i - 1] == "_")):
            m = re.match(r'R"([^()\\ ]{0,16})\(', text[i:])
            if not m:
                out.append(c)
                i += 1
                continue
            end = text.find(")" + m.group(1) + '"', i + m.end())
            j = n if end < 0 else end + len(m.group(1)) + 2
            out.append(re.sub(r"[^\n]", " ", text[i:j]))
            i = j
        elif c in "\"'":
            if c == "'" and i > 0 and text[i - 1].isalnum():  # a digit separator (1'000)
                out.append(" ")
                i += 1
                continue
            j = i + 1
            while j < n and text[j] != c and text[j] != "\n":
                j += 2 if text[j] == "\\" else 1
            j = min(j + 1, n)
            out.append(c + " " * (j - i - 2) + c if j - i >= 2 else " ")
            i = j
        else:
            out.append(c)
            i += 1
    return "".join(out)


def is_function_header(header):
    h = " ".join(header.split())
    if not h or "(" not in h:
        return False
    if re.match(r"^(namespace|class|struct|union|enum)\b", h) or re.search(r"\b(class|struct|union|enum)\s+\w+\s*(final\s*)?(:[^:][^()]*)?$", h):
        return False
    if h.endswith("="):  # an aggregate initializer
        return False
    first = re.match(r"^\s*(\w+)", h)
    if first and first.group(1) in KEYWORDS:
        return False
    # The header ends with the parameter list, optionally followed by qualifiers, a trailing return type or
    # a constructor's initializer list.
    tail = r"(\s*(const|volatile|noexcept(\([^()]*\))?|override|final|mutable|&|&&|->\s*[\w:<>,\s*&]+))*"
    return bool(re.search(r"\)" + tail + r"$", h) or re.search(r"\)" + tail + r"\s*:(?!:)", h))


def function_name(header):
    h = " ".join(header.split())
    h = re.sub(r"^template\s*<.*?>\s*", "", h)
    for m in re.finditer(r"(operator\s*[^\s(]+|~?[A-Za-z_][\w:]*(<[^()]*>)?)\s*\(", h):
        name = m.group(1)
        if name.split("::")[-1] not in KEYWORDS and not name.startswith("["):
            return name
    return h[:40]


def functions(text):
    """(name, first line, last line) of every function defined at namespace or class scope."""
    code = blank(text)
    found = []
    stack = []  # per open brace: "scope" (namespace/class/extern), "function", "opaque" (an initializer)
    header_start = 0  # where the current declaration's text starts
    i, n = 0, len(code)
    function_open = None
    while i < n:
        c = code[i]
        if c == "{":
            in_function = any(kind == "function" for kind, _ in stack)
            if in_function:
                stack.append(("inner", i))
            else:
                header = code[header_start:i]
                if is_function_header(header):
                    stack.append(("function", i))
                    function_open = (function_name(header), code.count("\n", 0, i) + 1)
                elif re.search(r"\b(namespace|class|struct|union|extern)\b|\benum\b", " ".join(header.split())) and "=" not in header:
                    stack.append(("scope", i))
                    header_start = i + 1
                else:
                    stack.append(("opaque", i))
        elif c == "}":
            kind, _ = stack.pop() if stack else ("scope", 0)
            if kind == "function":
                name, first = function_open
                found.append((name, first, code.count("\n", 0, i) + 1))
                header_start = i + 1
            elif kind == "scope":
                header_start = i + 1
            # opaque and inner blocks: part of the declaration or function around them
        elif c == ";" and not any(kind in ("function", "opaque", "inner") for kind, _ in stack):
            header_start = i + 1
        elif c == ":" and not any(kind in ("function", "opaque", "inner") for kind, _ in stack):
            # an access specifier (public:, private:, protected:) ends nothing else a header could need
            m = re.search(r"\b(public|private|protected)\s*$", code[header_start:i])
            if m and code[i + 1:i + 2] != ":":
                header_start = i + 1
        i += 1
    return found


def main():
    ap = argparse.ArgumentParser(description=__doc__, formatter_class=argparse.RawDescriptionHelpFormatter)
    ap.add_argument("folders", nargs="+")
    ap.add_argument("--max-function", type=int, default=120)
    ap.add_argument("--max-file", type=int, default=600)
    ap.add_argument("--list", type=int, default=0, help="also print the N longest functions")
    ap.add_argument("--allow", action="append", default=[], help="PATH=LINES or PATH:FUNCTION=LINES: a known offender's ceiling")
    a = ap.parse_args()
    allowed = {}
    for item in a.allow:
        key, _, lines = item.rpartition("=")
        if not key or not lines.isdigit():
            ap.error(f"--allow {item}: expected PATH=LINES or PATH:FUNCTION=LINES")
        allowed[key] = int(lines)
    used = set()

    def over(key, length, limit):
        if length <= limit:
            return False
        if key in allowed:
            used.add(key)
            return length > allowed[key]
        return True

    offenders, every = [], []
    for folder in a.folders:
        for root, _, names in sorted(os.walk(folder)):
            for name in sorted(names):
                if not name.endswith((".cpp", ".hpp")):
                    continue
                path = os.path.join(root, name)
                with open(path, encoding="utf-8") as f:
                    text = f.read()
                lines = text.count("\n") + (0 if text.endswith("\n") or not text else 1)
                if over(path, lines, a.max_file):
                    offenders.append(f"{path}: {lines} lines (at most {allowed.get(path, a.max_file)} for this file: split it by topic)")
                for fn, first, last in functions(text):
                    length = last - first + 1
                    every.append((length, f"{path}:{first}: {fn}"))
                    key = f"{path}:{fn}"
                    if over(key, length, a.max_function):
                        offenders.append(f"{path}:{first}: {fn}: {length} lines (at most {allowed.get(key, a.max_function)} "
                                         "for this function: split it into named steps)")
    for length, where in sorted(every, reverse=True)[:a.list]:
        print(f"{length:5d}  {where}")
    for key in sorted(set(allowed) - used):
        print(f"note: --allow {key}={allowed[key]} is no longer needed (within the limit or gone): remove it")
    for line in offenders:
        print(line)
    if offenders:
        return 1
    print(f"{len(every)} functions in {' '.join(a.folders)}: none over {a.max_function} lines, no file over {a.max_file}")
    return 0


if __name__ == "__main__":
    sys.exit(main())
