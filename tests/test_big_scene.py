#!/usr/bin/env python3
"""scripts/make-big-scene writes a scene cbdpt renders: a closed bumpy sphere of about the asked
triangle count in the dragon scene's shell. Small here (5,000 triangles, its tree fits any cache);
the prefetch it is for is tested bit for bit in tests/test_coherent.cpp.

Usage: test_big_scene.py PATH/TO/cbdpt SOURCE_DIR"""
import json
import os
import re
import subprocess
import sys
import tempfile

from checks import check, finish

cbdpt, source = sys.argv[1], sys.argv[2]
with tempfile.TemporaryDirectory() as tmp:
    r = subprocess.run([os.path.join(source, "scripts", "make-big-scene"), "--out", tmp,
                        "--triangles", "5000"], capture_output=True, text=True, timeout=300)
    check(r.returncode == 0, f"make-big-scene exits 0 ({r.returncode}: {r.stderr})")
    scene = os.path.join(tmp, "big-sphere.pbrt")
    info = subprocess.run([cbdpt, "info", scene], capture_output=True, text=True, timeout=300)
    m = re.search(r"triangles\s+(\d+)", info.stdout)
    # 4,900 of the sphere (2 x 50^2 less the poles' 2 x 50) and the shell's 10.
    check(m is not None and int(m.group(1)) == 4910,
          f"the scene holds the sphere's 4,900 triangles and the shell's 10 ({info.stdout})")
    stats = os.path.join(tmp, "s.json")
    r = subprocess.run([cbdpt, "render", scene, "--integrator", "cpt", "--width", "32",
                        "--height", "32", "--spp", "2", "-q", "-o", os.path.join(tmp, "i.exr"),
                        "--stats", stats], capture_output=True, text=True, timeout=300)
    check(r.returncode == 0, f"cbdpt renders it ({r.returncode}: {r.stderr})")
    if r.returncode == 0:
        s = json.load(open(stats))
        check(s["mean_standard_error"] > 0 and s["tree_prefetch"] is False,
              f"a lit image, and a tree that fits is not prefetched ({s})")
    r = subprocess.run([os.path.join(source, "scripts", "make-big-scene"), "--out", tmp,
                        "--triangles", "3"], capture_output=True, text=True, timeout=300)
    check(r.returncode != 0 and "--triangles 3" in r.stderr,
          f"too few triangles are refused, naming the value ({r.stderr.strip()})")
finish()
