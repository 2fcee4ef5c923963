#!/usr/bin/env python3
"""Compares two line-coverage reports of engine/ (gcovr's JSON, ci/coverage.sh) file by file.

    tests/coverage_compare.py BEFORE.json BEFORE_SOURCE AFTER.json AFTER_SOURCE

A line covered before is lost when the same line, found in the after tree's file by a diff of the
two sources (difflib; a line the change rewrote or removed has no counterpart and is listed apart,
not as lost), is not covered after. Prints a row per file with covered lines before and after,
lost and gained, and the totals; exits 1 when any file lost a covered line."""
import difflib
import json
import os
import sys


def covered(report):
    out = {}
    for f in json.load(open(report))["files"]:
        lines = out.setdefault(f["file"], {})
        for line in f["lines"]:
            if line.get("gcovr/noncode"):
                continue
            n = line["line_number"]
            lines[n] = lines.get(n, 0) + line["count"]  # a line may be listed per function
    return {name: {n for n, c in lines.items() if c > 0} for name, lines in out.items()}, out


def source(root, name):
    path = os.path.join(root, name)
    return open(path, errors="replace").read().splitlines() if os.path.exists(path) else []


def main():
    if len(sys.argv) != 5:
        sys.exit(__doc__)
    before, before_lines = covered(sys.argv[1])
    after, after_lines = covered(sys.argv[3])
    rows, lost_total, changed_total = [], 0, 0
    for name in sorted(set(before) | set(after)):
        b, a = before.get(name, set()), after.get(name, set())
        old, new = source(sys.argv[2], name), source(sys.argv[4], name)
        mapping = {}
        for tag, i1, i2, j1, _ in difflib.SequenceMatcher(None, old, new, autojunk=False).get_opcodes():
            if tag == "equal":
                for k in range(i2 - i1):
                    mapping[i1 + k + 1] = j1 + k + 1
        lost = sorted(n for n in b if n in mapping and mapping[n] not in a)
        changed = sorted(n for n in b if n not in mapping)
        lost_total += len(lost)
        changed_total += len(changed)
        rows.append((name, len(b), len(a), len(lost), len(changed), lost))
    print("%-44s %8s %8s %6s %8s" % ("file", "before", "after", "lost", "rewrote"))
    for name, nb, na, nl, nc, lost in rows:
        if nb != na or nl or nc:
            print("%-44s %8d %8d %6d %8d%s" % (name, nb, na, nl, nc, "  lines %s" % lost[:12] if lost else ""))
    tb, ta = sum(r[1] for r in rows), sum(r[2] for r in rows)
    lines_b = sum(len(v) for v in before_lines.values())
    lines_a = sum(len(v) for v in after_lines.values())
    print("%-44s %8d %8d %6d %8d" % ("total (files listed: those that differ)", tb, ta, lost_total, changed_total))
    print("line coverage of engine/: before %d of %d (%.1f%%), after %d of %d (%.1f%%)"
          % (tb, lines_b, 100.0 * tb / max(lines_b, 1), ta, lines_a, 100.0 * ta / max(lines_a, 1)))
    sys.exit(1 if lost_total else 0)


main()
