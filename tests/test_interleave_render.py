#!/usr/bin/env python3
"""scripts/interleave-render (docs/performance.md): one tiny round of PT and CPT (coherence
tile 2), with and without the host's shared sample vectors, gives every run a positive time,
one CSV row per run, and CPT's ratio to PT; malformed entries are refused with the entry named.
No timing assertions.

Usage: test_interleave_render.py PATH/TO/cbdpt SOURCE_DIR"""
import csv
import os
import subprocess
import sys
import tempfile

cbdpt, root = sys.argv[1], sys.argv[2]
script = os.path.join(root, "scripts", "interleave-render")
failures = []


def check(condition, message):
    if not condition:
        failures.append(message)
        print("FAIL:", message)


with tempfile.TemporaryDirectory() as tmp:
    table = os.path.join(tmp, "runs.csv")
    r = subprocess.run([sys.executable, script, "-r", "1", "--scenes", "cornell-box",
                        "--methods", "pt", "cpt", "--size", "16", "--estimates", "2",
                        "--coherence-tile", "2", "--csv",
                        table, f"now={cbdpt}", f"own={cbdpt}:CBDPT_SHARED_SAMPLES=0"],
                       capture_output=True, text=True, timeout=600)
    check(r.returncode == 0, f"a round runs (exit {r.returncode}: {r.stderr})")
    if r.returncode == 0:
        rows = list(csv.DictReader(open(table)))
        check(len(rows) == 4, f"one row per (method, entry): {len(rows)}")
        check(all(float(row["cpu_per_estimate"]) > 0 for row in rows), "positive CPU times")
        cpt = [line for line in r.stdout.splitlines() if line.startswith("cornell-box  cpt")]
        check(len(cpt) == 2 and all("/pt " in line for line in cpt),
              f"CPT's ratio to PT per entry: {cpt}")
        check("coherence tile 2" in r.stdout, f"the coherence tile stated: {r.stdout}")

    for entry, expected in [("nobinary", "is not NAME=CBDPT"),
                            ("x=/no/such/cbdpt", "no binary at /no/such/cbdpt"),
                            (f"x={cbdpt}:NOVALUE", "'NOVALUE' in entry")]:
        r = subprocess.run([sys.executable, script, entry], capture_output=True, text=True,
                           timeout=60)
        check(r.returncode != 0 and expected in r.stderr,
              f"entry {entry!r} refused with '{expected}' (exit {r.returncode}: {r.stderr})")

if failures:
    sys.exit(1)
print("interleave-render: ok")
