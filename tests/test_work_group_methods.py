#!/usr/bin/env python3
"""PoCL compiles each kernel's work-group function by one of several methods: its default here
("auto", LLVM's loop vectoriser over the work-items) and "loops" (plain loops). Both must compute
the same images. A wrongly compiled function shared by every method escapes the tests that
compare one method with another; it cannot escape this one unless both compilations agree on it.
The default once rendered a bump-mapped sphere 1.3% dark where "loops" rendered it right
(kernels/cb_intersect.h, surfacePointMapped).

Each render runs in its own process with its own empty PoCL kernel cache, so that neither reuses
the other's binaries. The two compilations order the same IEEE operations differently in
machine code but compute the same values: bit for bit with Debian's PoCL 3.1. A value counts as
different beyond 1e-5 of its own size plus the image mean; a newer PoCL's vector maths may move
a few, so at most 0.1% of the values may differ, and the image means must agree to 1e-5.

Usage: test_work_group_methods.py PATH/TO/cbdpt REPO_ROOT"""
import os
import subprocess
import sys
import tempfile

cbdpt, root = os.path.abspath(sys.argv[1]), os.path.abspath(sys.argv[2])
sys.path.insert(0, os.path.join(root, "scripts"))
sys.path.insert(0, os.path.dirname(os.path.abspath(__file__)))
import cbdpt_results as cr  # noqa: E402
import numpy as np  # noqa: E402
from checks import check, finish  # noqa: E402

# Scenes whose kernels hold the most features together (normal and bump maps on spheres and
# triangles, conductors, coats over both bases, alpha, textured roughness, dispersion, the
# thesis's spectral box), and the kernels of every method between them.
RENDERS = [
    ("pbrt-v4/sphere-maps.pbrt", "pt"),
    ("pbrt-v4/sphere-maps.pbrt", "cbdpt"),
    ("pbrt-v4/coatedconductor.pbrt", "bdpt"),
    ("pbrt-v4/roughness-texture.pbrt", "cpt"),
    ("pbrt-v4/alpha.pbrt", "mlt"),
    ("pbrt-v4/dispersion.pbrt", "pt"),
    ("cornell-box.pbrt", "cbdpt"),
]


def pocl_platform():
    r = subprocess.run([cbdpt, "--version"], capture_output=True, text=True)
    return r.returncode == 0 and "PoCL" in r.stdout + r.stderr


def render(scene, method, work_group_method, cache, out):
    env = dict(os.environ, POCL_CACHE_DIR=cache)
    env.pop("POCL_WORK_GROUP_METHOD", None)
    if work_group_method:
        env["POCL_WORK_GROUP_METHOD"] = work_group_method
    r = subprocess.run([cbdpt, "render", os.path.join(root, "scenes", scene), "--integrator",
                        method, "--width", "24", "--height", "24", "--spp", "2", "--seed", "1",
                        "-q", "-o", out, "--png", out[:-4] + ".png"],
                       env=env, capture_output=True, text=True)
    check(r.returncode == 0, f"{scene} {method} renders under {work_group_method or 'the default'} "
                             f"({r.stderr.strip()[-400:]})")
    return r.returncode == 0


def kernel_binaries(cache):
    """{kernel name: bytes} of the work-group functions PoCL compiled into `cache`."""
    found = {}
    for folder, _, files in os.walk(cache):
        for name in files:
            if name.endswith(".so"):
                with open(os.path.join(folder, name), "rb") as f:
                    found[name] = f.read()
    return found


if not pocl_platform():
    print("cbdpt-skip: the OpenCL platform is not PoCL; the work-group methods are PoCL's")
    sys.exit(0)

with tempfile.TemporaryDirectory() as tmp:
    for index, (scene, method) in enumerate(RENDERS):
        images, binaries = [], []
        for work_group_method in ("", "loops"):
            tag = f"{index}-{work_group_method or 'default'}"
            cache, out = os.path.join(tmp, "cache-" + tag), os.path.join(tmp, tag + ".exr")
            if not render(scene, method, work_group_method, cache, out):
                break
            images.append(cr.read_exr(out).astype(np.float64))
            binaries.append(kernel_binaries(cache))
        if len(images) < 2:
            continue
        a, b = images
        # The variable took effect: each cache holds its own machine code for the same kernels.
        shared = sorted(set(binaries[0]) & set(binaries[1]))
        check(shared and all(binaries[0][k] != binaries[1][k] for k in shared),
              f"{scene} {method}: the two methods compiled different code for {shared}")
        mean = float(np.abs(b).mean())
        differing = int((np.abs(a - b) > 1e-5 * (np.abs(b) + mean)).sum())
        check(mean > 0 and a.shape == b.shape, f"{scene} {method}: the image is not black")
        check(differing <= 0.001 * b.size,
              f"{scene} {method}: {differing} of {b.size} values differ between the default "
              f"work-group method and \"loops\" (largest {float(np.abs(a - b).max()):.3g})")
        check(abs(float(a.mean()) - float(b.mean())) <= 1e-5 * mean,
              f"{scene} {method}: image means {a.mean():.7g} and {b.mean():.7g}")
        print(f"{scene} {method}: {differing} of {b.size} values differ, "
              f"largest {float(np.abs(a - b).max()):.3g}")
finish()
