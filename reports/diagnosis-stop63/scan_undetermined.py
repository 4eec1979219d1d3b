#!/usr/bin/env python3
"""Lists, over every stored diagnosis.json under the folders given (default: reports/), the
candidates the new rule could touch: an `explained` verdict whose best candidate (ranking[0])
has no finite uncertainty on any of its parameters. The rule (verdict::undetermined_at_search_end)
sets such a candidate aside only when every value also sits at an end of its search range, which
the registry (src/scenario/effects.rs) states; this script prints the values to check against it.

Usage: python3 scan_undetermined.py [DIR ...]
"""
import glob
import json
import os
import sys

roots = sys.argv[1:] or ["reports"]
files = sorted({f for r in roots for f in glob.glob(os.path.join(r, "**", "diagnosis.json"), recursive=True)})
read = 0
hits = []
for f in files:
    try:
        with open(f) as fh:
            d = json.load(fh)
    except (OSError, ValueError):
        continue
    read += 1
    if d.get("verdict") != "explained" or not d.get("ranking"):
        continue
    best = d["ranking"][0]
    stds = list(best.get("params_std", {}).values())
    if stds and all(s is None for s in stds):
        hits.append((f, "+".join(best["effects"]), best["params"]))
print(f"{read} diagnosis.json read; {len(hits)} explained with no finite ± on the best's parameters")
for f, effects, params in hits:
    print(f"{f}: {effects} {json.dumps(params, sort_keys=True)}")
