#!/usr/bin/env python3
"""scripts/equal-time-pbrt --regions (docs/pbrt-v4.md): the per-cell ratio of MSE x CPU seconds
recovers known variances. Synthetic seeds: cbdpt's pixels have variance 4 in the top-left cell
of a 2 x 2 grid and 1 elsewhere, pbrt-v4's 2 everywhere, pbrt-v4 takes 1.5x the CPU seconds:
ratios 0.75 in that cell and 3 elsewhere, within 10% (about 12 standard errors of the
estimates from 64 seeds x 1024 pixels per cell); a cell outside the mask has none. The
equal-time sample counts, zsobol's powers of two included. And --pbrt-lightsampler with
--integrator bdpt, and a zsobol --pbrt-spp that is not a power of two, are refused, with the
reason. The comparison scripts' refusals: a missing scene or a --pbrt that is not a program is a
usage error naming it (exit 2); a child that fails ends the script with its command and exit
status (scripts/cbdpt_results.py's check_inputs and run_checked)."""
import os
import subprocess
import sys
import tempfile

root = sys.argv[1]
sys.path.insert(0, os.path.dirname(os.path.abspath(__file__)))
sys.path.insert(0, os.path.join(root, "scripts"))
import python_env  # noqa: F401,E402  (re-executes under .venv/bin/python, which has numpy)

import numpy as np  # noqa: E402

from checks import check, finish, load_script  # noqa: E402

path = os.path.join(root, "scripts", "equal-time-pbrt")
module = load_script(path, "equal_time_pbrt")


class Seeds:
    def __init__(self, images, cpu):
        self.images, self.cpu = images, cpu


rng = np.random.default_rng(5)
seeds, size = 64, 64
sigma = np.ones((size, size))
sigma[:32, :32] = 2.0  # standard deviation: variance 4 in the top-left cell
ours = Seeds([1.0 + sigma * rng.standard_normal((size, size)) for _ in range(seeds)], [10.0] * 4)
theirs = Seeds([1.0 + np.sqrt(2.0) * rng.standard_normal((size, size)) for _ in range(seeds)],
               [15.0] * 4)
mask = np.ones((size, size), dtype=bool)
grid = module.region_ratios(ours, theirs, mask, 2)
expected = [[0.75, 3.0], [3.0, 3.0]]
for i in range(2):
    for j in range(2):
        check(abs(grid[i][j] / expected[i][j] - 1.0) < 0.1,
              f"cell ({i}, {j}): ratio {grid[i][j]:.3f}, expected {expected[i][j]}")
mask[32:, 32:] = False
grid = module.region_ratios(ours, theirs, mask, 2)
check(grid[1][1] is None and grid[0][0] is not None,
      f"a cell outside the mask has no ratio: {grid}")

# Equal-time counts. pbrt-v4's zsobol renders 2^floor(log2 spp): asked for 7 it renders 4 (in
# half the time a count of 7 would take, measured), for 10 it renders 8.
check([module.pbrt_renders("zsobol", n) for n in (1, 7, 8, 10, 16)] == [1, 4, 8, 8, 16] and
      module.pbrt_renders("independent", 7) == 7, "pbrt-v4's rendered counts")
# cbdpt 0.25 s per sample, pbrt-v4 1.1 s: 32 of cbdpt's take the time of 7.3 of pbrt-v4's; zsobol
# gets the nearest power of two, 8, and cbdpt the 35 samples of its 8.8 s; other samplers get 7
# for cbdpt's 32.
check(module.equal_time_counts("zsobol", 32, 0.25, 1.1) == (35, 8),
      f"zsobol's equal-time counts: {module.equal_time_counts('zsobol', 32, 0.25, 1.1)}")
check(module.equal_time_counts("independent", 32, 0.25, 1.1) == (32, 7),
      f"independent's: {module.equal_time_counts('independent', 32, 0.25, 1.1)}")
# 5.5 of pbrt-v4's (2^2.46) go to 4, not 8: nearest in log scale.
check(module.equal_time_counts("zsobol", 22, 0.25, 1.0) == (16, 4),
      f"zsobol, nearest in log scale: {module.equal_time_counts('zsobol', 22, 0.25, 1.0)}")

# pbrt-v4's bdpt integrator has no light sampler to choose: refused before anything renders.
scene = os.path.join(root, "scenes", "cornell-box.pbrt")
r = subprocess.run([sys.executable, path, "--pbrt", "/nonexistent/pbrt", "--integrator", "bdpt",
                    "--pbrt-lightsampler", "power", scene],
                   capture_output=True, text=True, timeout=60)
check(r.returncode == 2 and "always chooses lights by power" in r.stderr,
      f"--pbrt-lightsampler with bdpt is refused with the reason (exit {r.returncode}: "
      f"{r.stderr.strip()[-200:]})")
# A zsobol count pbrt-v4 would round down is refused, naming what it would render.
r = subprocess.run([sys.executable, path, "--pbrt", "/nonexistent/pbrt", "--pbrt-spp", "10",
                    scene], capture_output=True, text=True, timeout=60)
check(r.returncode == 2 and "renders 8" in r.stderr,
      f"--pbrt-spp 10 with zsobol is refused (exit {r.returncode}: {r.stderr.strip()[-200:]})")

# Inputs checked before anything renders; a failing child named with its exit status.
r = subprocess.run([sys.executable, path, "--pbrt", "/nonexistent/pbrt", scene],
                   capture_output=True, text=True, timeout=60)
check(r.returncode == 2 and "'/nonexistent/pbrt': not an executable program" in r.stderr,
      f"a --pbrt that is not a program is named (exit {r.returncode}: {r.stderr.strip()[-200:]})")
r = subprocess.run([sys.executable, path, "--pbrt", "/bin/true", "/nonexistent/box.pbrt"],
                   capture_output=True, text=True, timeout=60)
check(r.returncode == 2 and "'/nonexistent/box.pbrt': no such file" in r.stderr,
      f"a missing scene is named (exit {r.returncode}: {r.stderr.strip()[-200:]})")
compare = os.path.join(root, "scripts", "compare-pbrt")
with tempfile.TemporaryDirectory() as out:
    r = subprocess.run([sys.executable, compare, "--pbrt", "/bin/false", "--out", out, scene],
                       capture_output=True, text=True, timeout=60)
check(r.returncode == 1 and "failed (exit status 1): /bin/false" in r.stderr
      and "Traceback" not in r.stderr,
      f"a failing pbrt-v4 ends compare-pbrt with its command and status (exit {r.returncode}: "
      f"{r.stderr.strip()[-300:]})")
finish()
