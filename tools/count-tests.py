#!/usr/bin/env python3
"""Counts test cases in meson's testlog.json files (TAP subtests included;
several files: several runs of the suite, added up) and prints the closing
line 'N passed, N failed[, N skipped]'. --failed-builds N: builds that
failed (tools/test), each counted as one failed case."""
import json
import re
import sys

passed = failed = skipped = 0
paths = sys.argv[1:]
if paths[:1] == ["--failed-builds"]:
    failed += int(paths[1])
    paths = paths[2:]
for path in paths:
    with open(path) as log:
        for line in log:
            test = json.loads(line)
            cases = [l for l in test.get("stdout", "").splitlines()
                     if re.match(r"(not )?ok \d+", l)]
            if not cases or test["result"] == "TIMEOUT":
                # Not TAP (or killed): the program counts as one case.
                if test["result"] in ("OK", "EXPECTEDFAIL"):
                    passed += 1
                elif test["result"] == "SKIP":
                    skipped += 1
                else:
                    failed += 1
                continue
            for case in cases:
                if case.startswith("not ok"):
                    # A known, documented failure (TAP TODO) is not a pass.
                    if "# TODO" in case:
                        skipped += 1
                    else:
                        failed += 1
                elif "# SKIP" in case:
                    skipped += 1
                else:
                    passed += 1
            if test["result"] not in ("OK", "SKIP", "EXPECTEDFAIL") and \
                    not any(c.startswith("not ok") for c in cases):
                failed += 1   # crashed after its last reported case
line = f"{passed} passed, {failed} failed"
if skipped:
    line += f", {skipped} skipped"
print(line)
sys.exit(1 if failed else 0)
