#!/usr/bin/env python3
"""scripts/gpu-check (docs/gpu.md) on PoCL's CPU device, tiny: every method renders in its own
process, is reported and is timed against a baseline binary; the doctest cases run one process
each and are counted."""
import json
import os
import subprocess
import sys
import tempfile

cbdpt, tests, root = sys.argv[1], sys.argv[2], sys.argv[3]
sys.path.insert(0, os.path.dirname(os.path.abspath(__file__)))
from checks import check, finish, load_script  # noqa: E402
from stanford_models import skip_without_models  # noqa: E402

skip_without_models()  # the dragon's renders need them

with tempfile.TemporaryDirectory() as out:
    r = subprocess.run([sys.executable, os.path.join(root, "scripts", "gpu-check"), "--cbdpt",
                        cbdpt, "--tests", tests, "--device", "cpu", "--size", "16", "--spp", "2",
                        "--seconds", "1", "--test-seconds", "3", "--jobs", "2", "--out", out,
                        "--baseline", cbdpt, "--rounds", "1", "--baseline-spp", "2"],
                       capture_output=True, text=True)
    check(r.returncode == 0, f"gpu-check exits 0 ({r.stderr.strip()[-500:]})")
    summary = json.load(open(os.path.join(out, "summary.json")))
    renders = summary["renders"]
    check(len(renders) == 10 and all(row["rc"] == 0 and row["estimates"] >= 1 for row in renders)
          and {row["method"] for row in renders} == {"pt", "cpt", "bdpt", "cbdpt", "mlt"},
          f"every method rendered and was timed ({renders})")
    check(all(row["param_address_reads"] is None for row in renders)
          and not os.path.exists(os.path.join(out, "binaries")),
          "on the CPU device the binaries are not kept unless asked for (--binaries)")
    timing = summary["timing_against_baseline"]
    # The same binary against itself: each ratio is positive and finite, one per render.
    check(len(timing) == 10 and all(0 < t["low"] <= t["median"] <= t["high"] < float("inf")
                                    for t in timing.values()),
          f"every render was timed against the baseline ({timing})")
    counts = summary["test_cases"]
    lines = open(os.path.join(out, "cases.txt")).read().splitlines()
    check(counts["pass"] >= 1 and counts["fail"] == 0
          and sum(counts.values()) == len(lines) > 100,
          f"the test cases were listed, and those run passed ({counts}, {len(lines)} lines)")

# A baseline that fails is reported per render, and the check goes on to the test cases.
with tempfile.TemporaryDirectory() as out:
    r = subprocess.run([sys.executable, os.path.join(root, "scripts", "gpu-check"), "--cbdpt",
                        cbdpt, "--tests", tests, "--device", "cpu", "--size", "8", "--spp", "1",
                        "--seconds", "1", "--test-seconds", "1", "--jobs", "2", "--out", out,
                        "--baseline", "/bin/false", "--rounds", "2", "--baseline-spp", "1"],
                       capture_output=True, text=True)
    summary = json.load(open(os.path.join(out, "summary.json")))
    timing = summary["timing_against_baseline"]
    check(r.returncode == 0 and len(timing) == 10
          and all("/bin/false" in t.get("error", "") for t in timing.values())
          and os.path.exists(os.path.join(out, "cases.txt")),
          f"a failing baseline is named per render and the check goes on ({timing})")

# CBDPT_KERNEL_BINARY_DIR keeps a render's program binaries (PoCL's hold no PTX), and names the
# folder when it cannot write there.
with tempfile.TemporaryDirectory() as folder:
    args = [cbdpt, "render", os.path.join(root, "scenes", "cornell-box.pbrt"), "--integrator",
            "pt", "--width", "8", "--height", "8", "--spp", "1", "-q", "-o",
            os.path.join(folder, "pt.exr")]
    binaries = os.path.join(folder, "binaries")
    os.makedirs(binaries)
    r = subprocess.run(args, env=dict(os.environ, CBDPT_DEVICE="cpu",
                                      CBDPT_KERNEL_BINARY_DIR=binaries),
                       capture_output=True, text=True)
    kept = sorted(os.listdir(binaries))
    check(r.returncode == 0 and kept == ["pt.cl-0.bin"]
          and os.path.getsize(os.path.join(binaries, kept[0])) > 1000,
          f"the render kept its program binary ({r.stderr.strip()[-300:]}, {kept})")
    missing = os.path.join(folder, "missing")
    r = subprocess.run(args, env=dict(os.environ, CBDPT_DEVICE="cpu",
                                      CBDPT_KERNEL_BINARY_DIR=missing),
                       capture_output=True, text=True)
    check(r.returncode != 0 and missing in r.stderr and "writable folder" in r.stderr,
          f"an unwritable binary folder is named ({r.stderr.strip()[-300:]})")

# The binaries' count on a PTX-like file: the parameter-address reads are found.
gpu_check = load_script(os.path.join(root, "scripts", "gpu-check"), "gpu_check")
with tempfile.TemporaryDirectory() as folder:
    with open(os.path.join(folder, "bdpt.cl-0.bin"), "w") as f:
        f.write("\tcvta.param.u64 \t%rd76, %rd67;\n\tcvta.to.local.u64 \t%rd77, %rd76;\n"
                "\tld.param.u32 \t%r4, [%rd66];\n")
    check(gpu_check.param_address_reads(folder) == 1, "a parameter-address read is counted")

finish()
