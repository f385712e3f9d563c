#!/usr/bin/env python3
"""Prints the committed result files that are older than the code they measure.

Reads docs/results/sources.tsv (file glob, measured paths, command; "-" as
the paths marks a dated record of past rounds, never stale). A result file
is stale when a commit that touches one of its measured paths came after
the last commit of the file; the line names the commits since and the command
that regenerates it. Also lists result files under docs/results/ that the
manifest does not cover, and docs/results/ links in README.md and docs/*.md
that name no file.

Exit status 0 (a warning, as CI runs it) unless --strict, which exits 1 when
anything is reported. Needs the git history (a shallow clone gives "unknown").
"""
import argparse
import fnmatch
import glob
import os
import re
import subprocess
import sys

ROOT = os.path.dirname(os.path.dirname(os.path.abspath(__file__)))
MANIFEST = os.path.join("docs", "results", "sources.tsv")


def git(*args):
    r = subprocess.run(["git", "-C", ROOT, *args], capture_output=True, text=True)
    return r.stdout.strip() if r.returncode == 0 else None


def read_manifest():
    rows = []
    with open(os.path.join(ROOT, MANIFEST), encoding="utf-8") as f:
        for n, line in enumerate(f, 1):
            line = line.rstrip("\n")
            if not line.strip() or line.startswith("#"):
                continue
            parts = line.split("\t")
            if len(parts) != 3:
                sys.exit(f"{MANIFEST}:{n}: expected 3 tab-separated columns, got {len(parts)}")
            rows.append((parts[0], parts[1].split(), parts[2]))
    return rows


def main():
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--strict", action="store_true", help="exit 1 when anything is reported")
    args = ap.parse_args()
    reported = 0
    rows = read_manifest()
    covered = set()
    stale = []
    for pattern, measures, command in rows:
        files = sorted(os.path.relpath(p, ROOT) for p in glob.glob(os.path.join(ROOT, pattern)))
        if not files:
            print(f"missing: {pattern} (a {MANIFEST} row) matches no file")
            reported += 1
        for path in files:
            covered.add(path)
            if measures == ["-"]:
                continue  # a dated record of past rounds: it describes the code of its dates
            commit = git("log", "-1", "--format=%H", "--", path)
            if not commit:
                print(f"unknown: {path}: not committed, or no history here (shallow clone?)")
                continue
            date = git("log", "-1", "--format=%cs", commit)
            since = git("rev-list", "--count", f"{commit}..HEAD", "--", *measures)
            if since is None:
                print(f"unknown: {path}: git rev-list failed")
                continue
            if int(since) > 0:
                newest = git("log", "-1", "--format=%cs %h", "--", *measures)
                stale.append((path, date, int(since), newest, measures, command))
    for path, date, since, newest, measures, command in stale:
        print(f"stale: {path} (committed {date}): {since} commit{'s' if since != 1 else ''} to "
              f"{' '.join(measures)} since, the newest {newest}\n       regenerate: {command}")
        reported += 1
    for path in sorted(glob.glob(os.path.join(ROOT, "docs", "results", "*"))):
        rel = os.path.relpath(path, ROOT)
        if os.path.isfile(path) and rel != MANIFEST and rel not in covered:
            print(f"uncovered: {rel} has no row in {MANIFEST} (what it measures, its command)")
            reported += 1
    link = re.compile(r"docs/results/[A-Za-z0-9_.{},*-]+|\(results/[A-Za-z0-9_.-]+\)")
    for doc in ["README.md"] + sorted(glob.glob(os.path.join(ROOT, "docs", "*.md"))):
        doc = os.path.relpath(os.path.join(ROOT, doc), ROOT)
        with open(os.path.join(ROOT, doc), encoding="utf-8") as f:
            text = f.read()
        for m in sorted(set(link.findall(text))):
            name = m.strip("()")
            if name.startswith("results/"):
                name = "docs/" + name
            name = name.rstrip(".,")
            if any(c in name for c in "{}*"):
                pattern = re.sub(r"\{[^}]*\}", "*", name)
                if not any(fnmatch.fnmatch(p, pattern) for p in covered):
                    print(f"dangling: {doc} names {name}, which matches no result file")
                    reported += 1
            elif not os.path.exists(os.path.join(ROOT, name)):
                print(f"dangling: {doc} names {name}, which does not exist")
                reported += 1
    print(f"{len(covered)} result files, {len(stale)} stale, {reported} reported "
          f"({'--strict: failing' if args.strict and reported else 'a warning, not a failure'})")
    return 1 if args.strict and reported else 0


if __name__ == "__main__":
    sys.exit(main())
