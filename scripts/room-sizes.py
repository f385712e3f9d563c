#!/usr/bin/env python3
"""Files over 450 lines and functions over 100 lines in library folders.

    scripts/room-sizes.py [FOLDER ...]        (default: worlds runtime)

Counts every .h and .cpp under the folders; function extents come from
universal-ctags (its end: field), so a lambda counts inside the function
that holds it. Prints one line per file or function over the limit and a
summary; exits 1 if any is over.
"""
import os
import subprocess
import sys

FILE_LIMIT, FUNCTION_LIMIT = 450, 100

roots = sys.argv[1:] or ["worlds", "runtime"]
files = sorted(os.path.join(d, f) for r in roots for d, _, fs in os.walk(r) for f in fs
               if f.endswith((".h", ".cpp")))
over = 0
for path in files:
    with open(path, encoding="utf-8") as f:
        n = sum(1 for _ in f)
    if n > FILE_LIMIT:
        print(f"file     {n:5d} lines  {path}")
        over += 1
tags = subprocess.run(["ctags", "--c++-kinds=fp", "--fields=+ne", "-f", "-"] + files,
                      capture_output=True, text=True, check=True).stdout
longest = (0, "")
for line in tags.splitlines():
    parts = line.split("\t")
    fields = dict(p.split(":", 1) for p in parts[3:] if ":" in p)
    if "end" not in fields or "line" not in fields or parts[0].startswith("__anon"):
        continue
    length = int(fields["end"]) - int(fields["line"]) + 1
    where = f"{parts[1]}:{fields['line']} {fields.get('class', fields.get('struct', ''))}::{parts[0]}"
    longest = max(longest, (length, where))
    if length > FUNCTION_LIMIT:
        print(f"function {length:5d} lines  {where}")
        over += 1
print(f"{len(files)} files in {' '.join(roots)}; longest function {longest[0]} lines ({longest[1]}); "
      f"{over} over the limits ({FILE_LIMIT} lines a file, {FUNCTION_LIMIT} a function)")
sys.exit(1 if over else 0)
