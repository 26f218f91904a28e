#!/usr/bin/env python3
"""scripts/interleave-traverse (docs/performance.md): one small round of two entries, the
renderers' wide traversal and the `ray8` packets named among an entry's options, lists each
entry's rows (mesh, rays, entry, one cpu-ratio per round) from its own traversal's lines of
cbdpt-bench; no timing assertions. Usage: test_interleave_traverse.py PATH/TO/cbdpt-bench
SOURCE_DIR"""
import os
import subprocess
import sys

import stanford_models
from checks import check, finish

bench, root = sys.argv[1], sys.argv[2]
stanford_models.skip_without_models()

script = os.path.join(root, "scripts", "interleave-traverse")
r = subprocess.run([script, "-r", "1", "-c", "primary", "-m", "bunny", "-n", "4096",
                    f"wide={bench}", f"ray8={bench}:--traversal ray8"],
                   capture_output=True, text=True, timeout=600)
check(r.returncode == 0, f"a round runs (exit {r.returncode}: {r.stderr})")
rows = {}
for line in r.stdout.splitlines()[1:]:
    fields = line.split()
    rows[(fields[0], fields[1], fields[2])] = fields[3:]
for entry in ("wide", "ray8"):
    values = rows.get(("bunny", "primary", entry))
    check(values is not None and len(values) == 1,
          f"entry {entry}: one row for the bunny's primary rays with one round's value "
          f"({values}; output {r.stdout!r})")
# Each entry's rows come from its own traversal: a bench run with --traversal wide never
# prints ray8 lines, so the ray8 entry has rows only if its option was passed and read.
check(len({k[2] for k in rows}) == 2, f"rows of both entries and no other: {sorted(rows)}")
finish()
