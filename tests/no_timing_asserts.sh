#!/usr/bin/env bash
# No test asserts a time, a rate or a ratio of them (issue 30): on a shared 2-core machine two
# configurations a few milliseconds apart rank either way, so how fast something is belongs to the
# bench's report, never to the gate a change must pass. This reads every test's assertions (python
# `assert`, C `CHECK`/`CHECK_MSG`, shell `[ ... ]`/`test`) that name a time or a rate (`_ms`, `_ns`,
# `per_s`, `vs_embree`, `vs_front`, `vs_exact`, `vs_one`, `vs_sum`, `elapsed`, `seconds`, `speed`)
# and fails on any ordering comparison (<, <=, >, >=, and the shell's -lt, -le, -gt, -ge) in them,
# except the two that measure nothing:
# a time that is reported at all (`> 0`), and an identity of the report's own arithmetic within
# its rounding (`abs(a - b) < 1e-N`: a cell's time is its passes' sum, a copied figure its source).
# Choices checked against the times the run itself reported (==, quality_rule.py) are not orderings.
# It reads an assertion's first line only: one split over lines is checked as far as that line goes.
set -u
exec python3 - "$(dirname "$0")" <<'PY'
import os, re, sys
root = sys.argv[1]
timing = re.compile(r"_ms\b|_ns\b|per_s\b|vs_(embree|front|exact|one|sum)\b|elapsed|seconds|speed")
assertion = re.compile(r"^\s*(assert\b|CHECK(_MSG)?\(|\[\s|test\s)")
ordering = re.compile(r"(?<![-<>=!])(<=|>=|<|>|-lt\b|-le\b|-gt\b|-ge\b)(?![<>=])\s*([^\s,)\]]+)")
identity = re.compile(r"abs\([^()]*(\([^()]*\)[^()]*)*\)\s*<\s*\d+(\.\d+)?e-\d+")
found = []
files = 0
for dirpath, _, names in os.walk(root):
    for name in sorted(names):
        if not name.endswith((".sh", ".py", ".c", ".h")) or name == "no_timing_asserts.sh":
            continue
        files += 1
        path = os.path.join(dirpath, name)
        for n, line in enumerate(open(path, errors="replace"), 1):
            code = line.split("#")[0] if name.endswith((".sh", ".py")) else line.split("//")[0]
            if not assertion.search(code) or not timing.search(code):
                continue
            rest = identity.sub("", code)
            for op, rhs in ordering.findall(rest):
                if not (op in (">", "-gt") and rhs.strip('"') == "0"):
                    found.append("%s:%d: %s" % (os.path.relpath(path, root), n, line.strip()))
                    break
for f in found:
    print("FAIL: an assertion orders times:", f)
print("%d test files read, %d assertions ordering times" % (files, len(found)))
sys.exit(1 if found else 0)
PY
