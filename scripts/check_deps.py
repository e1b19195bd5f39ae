#!/usr/bin/env python3
"""The dependency rule of docs/architecture.md, checked against the code.

Each stage is a folder src/autoscan/<stage>/ with one CMake target declared by
`autoscan_module(<stage> DEPS ...)`. The rule:
  1. a stage includes headers only of itself and of the stages in its DEPS (exact: no undeclared
     include), and every stage in DEPS is included somewhere in it (no unused declaration);
  2. the stages form layers in the order of AUTOSCAN_MODULES in the top CMakeLists.txt: a stage
     depends only on stages listed before it (so no cycle can form).
Exit 0 when the code follows the rule, 1 with one line per violation otherwise.
Usage: scripts/check_deps.py [ROOT]
"""
import pathlib
import re
import sys

root = pathlib.Path(sys.argv[1] if len(sys.argv) > 1 else pathlib.Path(__file__).resolve().parent.parent)
src = root / "src" / "autoscan"
top = (root / "CMakeLists.txt").read_text()
m = re.search(r"set\(AUTOSCAN_MODULES([^)]*)\)", top)
if not m:
    sys.exit("check_deps: AUTOSCAN_MODULES not found in CMakeLists.txt")
order = m.group(1).split()
rank = {s: i for i, s in enumerate(order)}

problems = []
for stage in order:
    cm = src / stage / "CMakeLists.txt"
    if not cm.exists():
        problems.append(f"{stage}: listed in AUTOSCAN_MODULES but src/autoscan/{stage}/CMakeLists.txt is missing")
        continue
    decl = re.search(r"autoscan_module\(\s*" + re.escape(stage) + r"\b([^)]*)\)", cm.read_text(), re.S)
    if not decl:
        problems.append(f"{stage}: no autoscan_module({stage} ...) in {cm.relative_to(root)}")
        continue
    words = decl.group(1).split()
    deps = set()
    if "DEPS" in words:
        for w in words[words.index("DEPS") + 1:]:
            if w.isupper():  # the next keyword (LIBS, PRIVATE_LIBS)
                break
            deps.add(w)
    used = {}
    for f in sorted((src / stage).rglob("*")):
        if f.suffix not in (".hpp", ".cpp", ".h"):
            continue
        for n, line in enumerate(f.read_text(errors="replace").splitlines(), 1):
            inc = re.match(r'\s*#\s*include\s+"autoscan/([a-z_]+)/', line)
            if inc and inc.group(1) != stage:
                used.setdefault(inc.group(1), f"{f.relative_to(root)}:{n}")
    for d, where in sorted(used.items()):
        if d not in rank:
            problems.append(f"{stage}: includes autoscan/{d}/, which is not a stage ({where})")
        elif d not in deps:
            problems.append(f"{stage}: includes autoscan/{d}/ without declaring it in DEPS ({where})")
    for d in sorted(deps):
        if d not in rank:
            problems.append(f"{stage}: DEPS names '{d}', which is not a stage")
            continue
        if d not in used:
            problems.append(f"{stage}: DEPS declares '{d}' but no file of the stage includes it")
        if rank[d] >= rank[stage]:
            problems.append(f"{stage}: depends on '{d}', which comes after it in AUTOSCAN_MODULES (layers point down)")

for p in problems:
    print(p)
if problems:
    print(f"check_deps: {len(problems)} violation(s) of the dependency rule (docs/architecture.md)")
    sys.exit(1)
print(f"check_deps: {len(order)} stages follow the dependency rule")
