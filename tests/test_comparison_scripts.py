#!/usr/bin/env python3
"""The comparison scripts' own arithmetic and refusals (docs/pbrt-v4.md, docs/performance.md):
the emitter mask does not wrap around the image's edges; HDR-FLIP of an image with negative
values against itself is 0; compare-pbrt fails a non-finite region instead of passing it,
refuses --grid 0, reports a --box of the images already there and runs pbrt-v4 again when
it crashes; same-images tells identical renders from different ones and refuses an --only
that matches nothing; interleave-render refuses two entries of one name and --rounds 0;
compare-mitsuba refuses --check-seeds 0 before it needs Mitsuba."""
import os
import subprocess
import sys
import tempfile

cbdpt, root = sys.argv[1], sys.argv[2]
sys.path.insert(0, os.path.dirname(os.path.abspath(__file__)))
sys.path.insert(0, os.path.join(root, "scripts"))
import python_env  # noqa: F401,E402  (re-executes under .venv/bin/python, which has numpy)

import numpy as np  # noqa: E402

import cbdpt_results as cr  # noqa: E402
from checks import check, finish  # noqa: E402

scripts = os.path.join(root, "scripts")


def run(*args, **kwargs):
    return subprocess.run([sys.executable, *args], capture_output=True, text=True, timeout=300,
                          **kwargs)


# An emitter on the top edge marks the rows below it, never the bottom rows.
lit = np.zeros((16, 16), bool)
lit[0, 5:8] = True
near = cr.near_pixels(lit, 2)
check(near[:3, 3:10].all() and not near[3:].any() and not near[:, :3].any()
      and not near[:, 10:].any(), f"the mask stays within 2 pixels, no wrap ({np.argwhere(near)})")

# HDR-FLIP clamps both images at 0: a spectral render's negative values against themselves.
image = np.random.default_rng(1).uniform(-0.01, 1.0, (32, 32, 3)).astype(np.float32)
if cr.flip_mean(image, image) is not None:
    check(cr.flip_mean(image, image) == 0.0, f"FLIP of an image against itself "
                                             f"({cr.flip_mean(image, image)})")

with tempfile.TemporaryDirectory() as tmp:
    scene = os.path.join(tmp, "box.pbrt")
    with open(os.path.join(root, "scenes", "pbrt-v4", "disk-light.pbrt")) as f:
        text = f.read().replace('"integer xresolution" 192 "integer yresolution" 192',
                                '"integer xresolution" 16 "integer yresolution" 16')
    with open(scene, "w") as f:
        f.write(text)
    # A stand-in for pbrt-v4 that writes a 16x16 PFM whose pixel (0, 0) is NaN.
    fake = os.path.join(tmp, "fake-pbrt")
    with open(fake, "w") as f:
        f.write(f"#!{sys.executable}\nimport sys\nimport numpy as np\n"
                "out = sys.argv[sys.argv.index('--outfile') + 1]\n"
                "img = np.full((16, 16, 3), 0.5, np.float32)\nimg[15, 0] = np.nan\n"
                "open(out, 'wb').write(b'PF\\n16 16\\n-1\\n' + img.astype('<f4').tobytes())\n")
    os.chmod(fake, 0o755)
    common = ["--pbrt", fake, "--cbdpt", cbdpt, "--spp", "2", "--threads", "1",
              "--out", os.path.join(tmp, "cp")]
    r = run(os.path.join(scripts, "compare-pbrt"), *common, "--tolerance", "10", scene)
    check(r.returncode == 1 and "FAIL" in r.stdout, f"a NaN region fails compare-pbrt's tolerance "
                                                    f"({r.returncode}: {r.stdout[-300:]} {r.stderr[-300:]})")
    r = run(os.path.join(scripts, "compare-pbrt"), *common, "--grid", "0", scene)
    check(r.returncode == 2 and "--grid" in r.stderr, f"--grid 0 refused ({r.stderr[-200:]})")
    # --box on the images already there: the bottom half, away from the NaN (the PFM's first
    # row is the image's bottom), against pbrt's 0.5.
    r = run(os.path.join(scripts, "compare-pbrt"), *common, "--no-render", "--box",
            "bottom=0,8,16,16", scene)
    ours = cr.read_exr(os.path.join(tmp, "cp", "box-cbdpt.exr")).astype(np.float64)
    expected = (ours[8:] @ cr.LUMINANCE).mean() / 0.5
    line = [x for x in r.stdout.splitlines() if x.strip().startswith("bottom ")]
    check(r.returncode == 0 and "compare-pbrt: /" not in r.stdout and len(line) == 1
          and abs(float(line[0].split()[1]) - expected) < 1e-4 * expected,
          f"--no-render --box bottom reports the bottom half's ratio {expected:.4f} ({r.stdout[-400:]})")
    r = run(os.path.join(scripts, "compare-pbrt"), *common, "--no-render", "--box",
            "big=0,0,17,8", scene)
    check(r.returncode != 0 and "outside the 16x16 image" in r.stderr + r.stdout,
          f"a box outside the image is refused ({r.stderr[-200:]})")
    # pbrt-v4 dying of SIGSEGV (as it does at start-up with a camera in a scattering medium) is
    # run again, up to 10 times; any other failure, or a tenth crash, fails the comparison.
    flaky = os.path.join(tmp, "flaky-pbrt")
    with open(flaky, "w") as f:
        f.write(f"#!{sys.executable}\nimport os, signal, sys\n"
                f"count = os.path.join({tmp!r}, 'crashes')\n"
                "n = int(open(count).read()) if os.path.exists(count) else 0\n"
                "if n < int(os.environ['CRASHES']):\n"
                "    open(count, 'w').write(str(n + 1))\n"
                "    os.kill(os.getpid(), signal.SIGSEGV)\n"
                f"os.execv({fake!r}, [{fake!r}] + sys.argv[1:])\n")
    os.chmod(flaky, 0o755)
    flaky_args = ["--pbrt", flaky] + common[2:]
    for crashes, expect_ok, reruns in ((2, True, 2), (10, False, 9)):
        if os.path.exists(os.path.join(tmp, "crashes")):
            os.remove(os.path.join(tmp, "crashes"))
        r = run(os.path.join(scripts, "compare-pbrt"), *flaky_args, scene,
                env=dict(os.environ, CRASHES=str(crashes)))
        retries = r.stdout.count("died of SIGSEGV; running it again")
        check((r.returncode == 0) == expect_ok and retries == reruns
              and (expect_ok or "exit status -11" in r.stderr),
              f"pbrt-v4 crashing {crashes} times: {retries} reruns, exit {r.returncode} "
              f"({r.stdout[-300:]} {r.stderr[-300:]})")

    # same-images: one binary twice is the same; a binary that renders with another sampler
    # is not; an --only that matches no case is an error.
    other = os.path.join(tmp, "other-cbdpt")
    with open(other, "w") as f:
        f.write(f"#!/bin/sh\nexec {cbdpt} \"$@\" --sampler independent\n")
    os.chmod(other, 0o755)
    same = [os.path.join(scripts, "same-images"), "--size", "8", "--spp", "2", "--only",
            "cornell-rgb-pt", "--keep", os.path.join(tmp, "same")]
    r = run(same[0], cbdpt, cbdpt, *same[1:])
    check(r.returncode == 0 and "0 of 1 case(s) differ" in r.stdout,
          f"same-images: one binary is the same ({r.returncode}: {r.stdout}{r.stderr[-300:]})")
    r = run(same[0], cbdpt, other, *same[1:])
    check(r.returncode == 1 and "DIFFERENT" in r.stdout,
          f"same-images: another sampler differs ({r.returncode}: {r.stdout}{r.stderr[-300:]})")
    r = run(same[0], cbdpt, cbdpt, "--only", "cornel-rgb-typo")
    check(r.returncode != 0 and "no case" in r.stderr, f"same-images --only typo ({r.stderr})")

    interleave = os.path.join(scripts, "interleave-render")
    r = run(interleave, "-r", "1", f"a={cbdpt}", f"a={cbdpt}:CBDPT_PACKETS=0")
    check(r.returncode != 0 and "names must differ" in r.stderr,
          f"interleave-render refuses two entries named a ({r.stderr.strip()})")
    r = run(interleave, "-r", "0", f"a={cbdpt}")
    check(r.returncode != 0 and "--rounds" in r.stderr, f"--rounds 0 refused ({r.stderr.strip()})")

r = run(os.path.join(scripts, "compare-mitsuba"), "--cbdpt", cbdpt, "--check-seeds", "0")
check(r.returncode == 2 and "--check-seeds" in r.stderr and "Traceback" not in r.stderr,
      f"compare-mitsuba --check-seeds 0 is a usage error ({r.returncode}: {r.stderr[-300:]})")
finish()
