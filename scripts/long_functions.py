#!/usr/bin/env python3
"""Functions longer than N lines in src/ (issue 16: "no function over 100 lines").

A brace-depth counter over src/**/*.cpp and src/**/*.hpp, with comments, string and character
literals and preprocessor lines blanked first. A `{` opened at namespace or class scope whose
preceding declaration has a parameter list `(...)` starts a function (free function, member
function, constructor, namespace-scope lambda); everything up to its matching `}` (nested lambdas
and local classes included) belongs to it. Its length is counted from the line of its name to the
line of its closing brace, both included. Brace initialisers (`= {...}` tables, `x_{a}` in a
constructor's initialiser list, `int n{3};`) are not functions.

Prints `file:line name length` for every function longer than N lines, longest first. With
--check, exits 1 when one is found that is not in ALLOWED below (the ctest `style.function_length`).
Usage: scripts/long_functions.py [--max N] [--check] [ROOT]
"""
import argparse
import pathlib
import re
import sys

# Functions allowed over the limit, each with its reason (file relative to src/, qualified name).
ALLOWED: set = set()  # none left (the scanner's run was split with issue 17)


def blank(text):
    """Comments, string/char literals and preprocessor lines replaced by spaces (newlines kept)."""
    out = []
    i, n = 0, len(text)
    line_start = True
    while i < n:
        c = text[i]
        if line_start and c == "#" or (line_start and c in " \t" and text[i:].lstrip(" \t").startswith("#")):
            # preprocessor line (with continuations)
            j = i
            while j < n:
                k = text.find("\n", j)
                if k < 0:
                    k = n
                if k > 0 and text[k - 1] == "\\":
                    j = k + 1
                    continue
                break
            seg = text[i:k]
            out.append(re.sub(r"[^\n]", " ", seg))
            i = k
            line_start = False
            continue
        if c == "\n":
            out.append(c)
            i += 1
            line_start = True
            continue
        if c not in " \t":
            line_start = False
        if text.startswith("//", i):
            k = text.find("\n", i)
            k = n if k < 0 else k
            out.append(" " * (k - i))
            i = k
            continue
        if text.startswith("/*", i):
            k = text.find("*/", i + 2)
            k = n if k < 0 else k + 2
            out.append(re.sub(r"[^\n]", " ", text[i:k]))
            i = k
            continue
        m = re.match(r'R"([^(\s]*)\(', text[i:i + 20]) if c == "R" and (i == 0 or not (text[i - 1].isalnum() or text[i - 1] == "_")) else None
        if m:
            end = ")" + m.group(1) + '"'
            k = text.find(end, i + m.end())
            k = n if k < 0 else k + len(end)
            out.append('"' + re.sub(r"[^\n]", " ", text[i + 1:k - 1]) + '"')
            i = k
            continue
        if c == '"' or (c == "'" and not (i > 0 and text[i - 1].isalnum())):  # 1'000 digit separators
            j = i + 1
            while j < n and text[j] != c:
                j += 2 if text[j] == "\\" else 1
            out.append(c + " " * (min(j, n) - i - 1) + (c if j < n else ""))
            i = j + 1
            continue
        out.append(c)
        i += 1
    return "".join(out)


def function_name(decl):
    """(qualified name, offset in decl) of the function a declaration defines, or (None, 0)."""
    lam = re.search(r"([A-Za-z_]\w*)\s*=\s*\[", decl)
    m = re.search(r"((?:[A-Za-z_]\w*\s*(?:<[^()]*>)?\s*::\s*)*~?(?:operator\s*(?:\(\)|[^\s(]+)|[A-Za-z_]\w*))\s*\(", decl)
    if lam and (not m or lam.start() < m.start()):
        return lam.group(1), lam.start()
    if not m:
        return None, 0
    return re.sub(r"\s+", "", m.group(1)), m.start()


def classify(seg, prev):
    """What a `{` at namespace or class scope opens: 'ns', 'class', 'func' or 'other'."""
    s = seg.strip()
    if re.match(r"(inline\s+)?namespace\b", s) or re.match(r'extern\s*"', s):
        return "ns"
    if re.match(r"(template\s*<.*>\s*)?(class|struct|union|enum)\b", s, re.S) and ")" not in s:
        return "class"
    if ")" not in s:
        return "other"
    if prev == ")":
        return "func"
    if prev == "}" and re.search(r"\)\s*:", s):  # constructor whose initialiser list ends in x_{a}
        return "func"
    if re.search(r"\)\s*(?:(?:const|noexcept|override|final|mutable|&&|&)\s*)*(?:->[^;{}=]*)?$", s):
        return "func"
    return "other"


def functions(path):
    """(line, name, length) of every function defined in the file."""
    text = blank(path.read_text(errors="replace"))
    stack = []  # kinds: 'ns', 'class', 'func', 'other'
    seg_start = 0  # start of the current declaration at namespace/class scope
    found = []
    func_open = None
    for i, c in enumerate(text):
        in_func = "func" in stack
        if c == ";" and not in_func and (not stack or stack[-1] in ("ns", "class")):
            seg_start = i + 1
        elif c == "{":
            if in_func or (stack and stack[-1] == "other"):
                stack.append("other")
                continue
            seg = text[seg_start:i]
            before = text[:i].rstrip()
            kind = classify(seg, before[-1:] if before else "")
            stack.append(kind)
            if kind == "func":
                name, off = function_name(seg)
                if name is None:
                    name, off = "?", len(seg) - len(seg.lstrip())
                func_open = (text.count("\n", 0, seg_start + off) + 1, name)
            elif kind in ("ns", "class"):
                seg_start = i + 1
        elif c == "}":
            kind = stack.pop() if stack else "other"
            if kind == "func" and "func" not in stack:
                line = text.count("\n", 0, i) + 1
                found.append((func_open[0], func_open[1], line - func_open[0] + 1))
                seg_start = i + 1
            elif kind in ("ns", "class"):
                seg_start = i + 1
    return found


def main():
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--max", type=int, default=100, help="longest function allowed, in lines (100)")
    ap.add_argument("--check", action="store_true", help="exit 1 on a long function not in ALLOWED")
    ap.add_argument("root", nargs="?", default=str(pathlib.Path(__file__).resolve().parent.parent))
    a = ap.parse_args()
    src = pathlib.Path(a.root) / "src"
    rows = []
    for f in sorted(src.rglob("*")):
        if f.suffix in (".cpp", ".hpp") and f.is_file():
            rel = f.relative_to(src).as_posix()
            for line, name, length in functions(f):
                if length > a.max:
                    rows.append((length, rel, line, name))
    rows.sort(key=lambda r: (-r[0], r[1], r[2]))
    bad = 0
    for length, rel, line, name in rows:
        allowed = (rel, name) in ALLOWED
        bad += 0 if allowed else 1
        print(f"src/{rel}:{line} {name} {length}" + ("  (allowed, see ALLOWED)" if allowed else ""))
    print(f"long_functions: {len(rows)} function(s) over {a.max} lines, {bad} not allowed")
    if a.check and bad:
        sys.exit(1)


if __name__ == "__main__":
    main()
