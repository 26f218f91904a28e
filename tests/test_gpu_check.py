#!/usr/bin/env python3
"""scripts/gpu-check (docs/gpu.md) on PoCL's CPU device, tiny: every method renders in its own
process and is reported, the doctest cases run one process each and are counted."""
import json
import os
import subprocess
import sys
import tempfile

cbdpt, tests, root = sys.argv[1], sys.argv[2], sys.argv[3]
sys.path.insert(0, os.path.dirname(os.path.abspath(__file__)))
from checks import check, finish  # noqa: E402
from stanford_models import skip_without_models  # noqa: E402

skip_without_models()  # the dragon's renders need them

with tempfile.TemporaryDirectory() as out:
    r = subprocess.run([sys.executable, os.path.join(root, "scripts", "gpu-check"), "--cbdpt",
                        cbdpt, "--tests", tests, "--device", "cpu", "--size", "16", "--spp", "2",
                        "--seconds", "1", "--test-seconds", "3", "--jobs", "2", "--out", out],
                       capture_output=True, text=True)
    check(r.returncode == 0, f"gpu-check exits 0 ({r.stderr.strip()[-500:]})")
    summary = json.load(open(os.path.join(out, "summary.json")))
    renders = summary["renders"]
    check(len(renders) == 10 and all(row["rc"] == 0 and row["estimates"] >= 1 for row in renders)
          and {row["method"] for row in renders} == {"pt", "cpt", "bdpt", "cbdpt", "mlt"},
          f"every method rendered and was timed ({renders})")
    counts = summary["test_cases"]
    lines = open(os.path.join(out, "cases.txt")).read().splitlines()
    check(counts["pass"] >= 1 and counts["fail"] == 0
          and sum(counts.values()) == len(lines) > 100,
          f"the test cases were listed, and those run passed ({counts}, {len(lines)} lines)")

finish()
