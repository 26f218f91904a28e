#!/usr/bin/env python3
"""scripts/gpu-bisect (docs/gpu.md) on PoCL's CPU device: every variant's anchors are found in
the current kernels, the variants build and render, and a candidate fix leaves the image bit for
bit as it was (it changes how NVIDIA's compiler sees the code, not what it computes)."""
import json
import os
import subprocess
import sys
import tempfile

cbdpt, root = sys.argv[1], sys.argv[2]
sys.path.insert(0, os.path.dirname(os.path.abspath(__file__)))
from checks import check, finish  # noqa: E402

with tempfile.TemporaryDirectory() as out:
    r = subprocess.run([sys.executable, os.path.join(root, "scripts", "gpu-bisect"), "--out", out,
                        "--run", "--cbdpt", cbdpt, "--device", "cpu", "--size", "8",
                        "--only", "base,settings-copy,connect-general-a", "--integrators", "bdpt"],
                       capture_output=True, text=True)
    check(r.returncode == 0, f"gpu-bisect exits 0 ({r.stderr.strip()[-400:]})")
    lines = [line for line in r.stdout.splitlines() if " rc=" in line]
    check(len(lines) == 3 and all(" rc=0 " in line for line in lines),
          f"the three variants chosen rendered ({r.stdout.strip()[-600:]})")
    check(len([d for d in os.listdir(out) if os.path.isdir(os.path.join(out, d))]) >= 15,
          f"every variant was written ({sorted(os.listdir(out))})")
    c = subprocess.run([cbdpt, "compare", os.path.join(out, "settings-copy-bdpt.exr"),
                        os.path.join(out, "base-bdpt.exr"), "--json"], capture_output=True,
                       text=True)
    check(c.returncode == 0 and json.loads(c.stdout)["mae"] == 0.0,
          f"the candidate fix renders the same pixels ({c.stdout.strip()[-300:]})")
    cut = subprocess.run([cbdpt, "compare", os.path.join(out, "connect-general-a-bdpt.exr"),
                          os.path.join(out, "base-bdpt.exr"), "--json"], capture_output=True,
                         text=True)
    check(cut.returncode == 0 and json.loads(cut.stdout)["mae"] > 0.0,
          "a cut changes the image (the variants are really used)")
    bad = subprocess.run([sys.executable, os.path.join(root, "scripts", "gpu-bisect"), "--out",
                          out, "--only", "no-such-variant"], capture_output=True, text=True)
    check(bad.returncode != 0 and "no-such-variant" in bad.stderr,
          f"an unknown variant is refused by name ({bad.stderr.strip()})")

finish()
