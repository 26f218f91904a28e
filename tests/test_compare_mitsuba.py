#!/usr/bin/env python3
"""scripts/compare-mitsuba without Mitsuba (docs/comparison-mitsuba.md): what it computes before
and after Mitsuba renders, checked where the answer is known.

- The scene reader against `cbdpt info` on scenes/cornell-box.pbrt: triangles, spheres, emitting
  primitives, the film, and the fov as the file gives it.
- The colour matrices it re-derives match the numbers docs/spectral.md states.
- Malformed scenes are refused with the file, the line and the reason.
- The error at equal time on synthetic rounds of known variance and time: each renderer's MSE
  (leave-one-out, so its (K-1)/K factor matters) and the ratio of MSE x seconds, whole image
  and in a mask, within 6% (about 6 standard errors of the medians of 5 rounds x 16,384 pixels).
- The agreement check that gates the timing, on images of known expectation: the same passes,
  3% brighter everywhere or 30% brighter in one block fails (in that block alone), and the
  spectral mode's floor lets a difference below it through.
- Without Mitsuba (a stub package that fails to import) it exits 2 with the install command,
  and a missing scene or --cbdpt is a usage error naming the path, before Mitsuba is needed.
"""
import os
import re
import subprocess
import sys
import tempfile

cbdpt, root = sys.argv[1], sys.argv[2]
sys.path.insert(0, os.path.dirname(os.path.abspath(__file__)))
sys.path.insert(0, os.path.join(root, "scripts"))
import python_env  # noqa: F401,E402  (re-executes under .venv/bin/python, which has numpy)

import numpy as np  # noqa: E402

from checks import check, finish, load_script  # noqa: E402

script = os.path.join(root, "scripts", "compare-mitsuba")
cm = load_script(script, "compare_mitsuba")
check(cm.mi is None and cm.dr is None, "loading the script imports no Mitsuba")

# --- the reader against cbdpt's own parser ------------------------------------------------------
scene_path = os.path.join(root, "scenes", "cornell-box.pbrt")
scene = cm.parse_scene(scene_path)
info = subprocess.run([cbdpt, "info", scene_path], capture_output=True, text=True, timeout=120)
check(info.returncode == 0, f"cbdpt info runs: {info.stderr[-300:]}")


def info_number(key):
    m = re.search(rf"^\s*{key}\s+(\d+)", info.stdout, re.M)
    return int(m.group(1)) if m else None


meshes = [s for s in scene["shapes"] if s["type"] == "mesh"]
spheres = [s for s in scene["shapes"] if s["type"] == "sphere"]
triangles = sum(len(s["indices"]) for s in meshes)
emitting = (sum(len(s["indices"]) for s in meshes if s["emission"] is not None)
            + sum(1 for s in spheres if s["emission"] is not None))
check(triangles == info_number("triangles"),
      f"triangles: reader {triangles}, cbdpt info {info_number('triangles')}")
check(len(spheres) == info_number("spheres"),
      f"spheres: reader {len(spheres)}, cbdpt info {info_number('spheres')}")
check(emitting == info_number("lights"),
      f"emitting primitives: reader {emitting}, cbdpt info {info_number('lights')}")
film = re.search(r"^\s*film\s+(\d+)x(\d+)", info.stdout, re.M)
cam = scene["camera"]
check(film is not None and (cam["width"], cam["height"]) == tuple(map(int, film.groups())),
      f"film: reader {cam['width']}x{cam['height']}, cbdpt info {film and film.group(0)}")
fov = re.search(r'"float fov"\s*\[?\s*([0-9.]+)', open(scene_path).read())
check(fov is not None and abs(cam["fov"] - float(fov.group(1))) < 1e-9,
      f"fov: reader {cam['fov']}, file {fov and fov.group(1)}")
check(abs(cam["imaging_ratio"] - 1.0) < 1e-12, f"imaging ratio {cam['imaging_ratio']}")

# --- the colour matrices against docs/spectral.md --------------------------------------------
doc = open(os.path.join(root, "docs", "spectral.md")).read()
white = cm.reflectance_bins_to_rgb().sum(1)
stated = re.search(r"\((0\.99\d+), (1\.00\d+), (0\.99\d+)\)", doc)
check(stated is not None and np.allclose(white, [float(x) for x in stated.groups()], atol=2e-6),
      f"M * ones {white} against docs/spectral.md's {stated and stated.groups()}")
flat = cm.bin_cmf_integrals().sum(1)
flat /= flat[1]
check("(0.99738, 1, 0.99469)" in doc and np.allclose(flat, [0.99738, 1, 0.99469], atol=6e-6),
      f"a flat spectrum's film XYZ {flat} against docs/spectral.md's (0.99738, 1, 0.99469)")

# --- refusals name the file, the line and the reason ------------------------------------------
BAD = {
    "scale-short": ("LookAt 0 0 0  0 0 1  0 1 0\nScale -1 1\nWorldBegin\n", 2, "takes 3 numbers"),
    "lookat-short": ("\n\nLookAt 0 0 0  0 0 1\nCamera \"perspective\"\n", 3, "takes 9 numbers"),
    "unclosed": ('Film "rgb" "integer xresolution" [ 64 ]\n'
                 '  "integer yresolution" [ 64\nCamera "perspective"\n', 2, "is not closed"),
    "unknown": ('Film "rgb"\n# a comment\nTexture "t" "spectrum" "imagemap"\n', 3,
                "not supported"),
    "ends-inside": ('Film "rgb"\nCamera\n', 2, "ends inside 'Camera'"),
    "unmatched-end": ("AttributeBegin\nAttributeEnd\nAttributeEnd\n", 3, "without a matching"),
    "not-a-number": ('Film "rgb" "integer xresolution" [ 64\n  6x4 ]\n', 2,
                     "'6x4' is not a number"),
    "no-camera": ('Film "rgb"\nWorldBegin\n', 2, "without a Camera"),
}
with tempfile.TemporaryDirectory() as tmp:
    for name, (text, line, reason) in BAD.items():
        path = os.path.join(tmp, name + ".pbrt")
        with open(path, "w") as f:
            f.write(text)
        try:
            cm.parse_scene(path)
            message = None
        except cm.CompareError as e:
            message = str(e)
        check(message is not None and message.startswith(f"{path}:{line}: ")
              and reason in message,
              f"{name}: expected '{path}:{line}: ... {reason} ...', got {message!r}")

# --- error at equal time on synthetic rounds -------------------------------------------------
rng = np.random.default_rng(11)
rounds, size = 5, 128
sigma_ours = np.ones((size, size))
sigma_ours[:, :16] = 3.0  # variance 9 in a strip that the mask leaves out
mask = np.ones((size, size), dtype=bool)
mask[:, :16] = False
ours = [0.5 + sigma_ours * rng.standard_normal((size, size)) for _ in range(rounds)]
theirs = [0.5 + np.sqrt(3.0) * rng.standard_normal((size, size)) for _ in range(rounds)]
# ours takes 2 s per image, Mitsuba 1 s: MSE x s is 2 for ours away from the strip, 3 for theirs.
result = cm.equal_error(ours, [2.0] * rounds, theirs, [1.0] * rounds,
                        {"whole": np.ones_like(mask), "away": mask})
whole_ours = (9.0 * 16 + 1.0 * (size - 16)) / size
expected = {"whole": (whole_ours, 3.0, 3.0 / (2.0 * whole_ours)), "away": (1.0, 3.0, 1.5)}
for label, (mse_ours, mse_theirs, ratio) in expected.items():
    r = result[label]
    got = (r["ours"]["mse"]["median"], r["mitsuba"]["mse"]["median"], r["ratio_median"])
    want = (mse_ours, mse_theirs, ratio)
    check(all(abs(g / e - 1.0) < 0.06 for g, e in zip(got, want)),
          f"{label}: MSE ours, Mitsuba and the ratio {got}, expected {want}")
    check(r["ratio_min"] <= r["ratio_median"] <= r["ratio_max"],
          f"{label}: the pairs' range holds the median: {r}")
    check(abs(r["ours"]["mse_times_seconds"]["median"] / (2.0 * mse_ours) - 1.0) < 0.06,
          f"{label}: ours' MSE x seconds {r['ours']['mse_times_seconds']}")

# --- the agreement check that gates every timing ---------------------------------------------
# Ours: one image with its per-pixel standard error; Mitsuba: 4 independent runs. The same
# expectation passes; 3% brighter everywhere, or 30% brighter in one 64 x 64 block, fails.
truth = np.ones((256, 256, 3)) * np.array([0.5, 0.3, 0.1])
noise = 0.05 * truth
ours_image = truth + noise * rng.standard_normal(truth.shape)
ours_se = noise


def mitsuba_runs(expectation):
    return [expectation + 2.0 * noise * rng.standard_normal(truth.shape) for _ in range(4)]


same = cm.agreement(ours_image, ours_se, mitsuba_runs(truth), 8, 5.0, 0.0, "same")
check(same["ok"] and same["blocks_failed"] == 0 and same["block_rms_z"] < 1.5,
      f"the same expectation agrees: blocks failed {same['blocks_failed']}, rms z "
      f"{same['block_rms_z']:.2f}")
brighter = cm.agreement(ours_image, ours_se, mitsuba_runs(1.03 * truth), 8, 5.0, 0.0, "3%")
check(not brighter["ok"] and brighter["blocks_failed"] > 100,
      f"3% brighter fails: blocks failed {brighter['blocks_failed']}")
local = truth.copy()
local[64:96, 128:160] *= 1.3
one_block = cm.agreement(ours_image, ours_se, mitsuba_runs(local), 8, 5.0, 0.0, "one block")
check(not one_block["ok"] and [c[:2] for c in one_block["blocks_failed_where"]] == [[2, 4]] * 3,
      f"a change in one block fails there only: {one_block['blocks_failed_where']}")
# The spectral tolerance floor (a fraction of the brightest channel) lets the 3% through.
floored = cm.agreement(ours_image, ours_se, mitsuba_runs(1.03 * truth), 8, 5.0, 0.04, "floor")
check(floored["ok"], f"a 3% difference passes a 4% floor: {floored['blocks_failed']}")

# --- without Mitsuba, and refusals before it is needed ---------------------------------------
with tempfile.TemporaryDirectory() as stubs:
    for package in ("drjit", "mitsuba"):
        os.makedirs(os.path.join(stubs, package))
        with open(os.path.join(stubs, package, "__init__.py"), "w") as f:
            f.write("raise ImportError('a stand-in for a missing package')\n")
    env = dict(os.environ, PYTHONPATH=stubs)
    r = subprocess.run([sys.executable, script, "--cbdpt", cbdpt, "--modes", "rgb"], env=env,
                       capture_output=True, text=True, timeout=120)
    check(r.returncode == 2 and "scripts/install-deps --mitsuba" in r.stderr,
          f"without Mitsuba: exit 2 with the install command (exit {r.returncode}: "
          f"{r.stderr.strip()[-300:]})")
    r = subprocess.run([sys.executable, script, "--help"], env=env, capture_output=True,
                       text=True, timeout=120)
    check(r.returncode == 0 and "--repeats" in r.stdout, f"--help without Mitsuba: {r.returncode}")
    for args, named in ((["--cbdpt", cbdpt, "--scene", "/nonexistent/box.pbrt"],
                         "/nonexistent/box.pbrt"),
                        (["--cbdpt", "/nonexistent/cbdpt"], "/nonexistent/cbdpt")):
        r = subprocess.run([sys.executable, script, *args], env=env, capture_output=True,
                           text=True, timeout=120)
        check(r.returncode == 2 and named in r.stderr and "usage:" in r.stderr,
              f"{args}: a usage error naming the path (exit {r.returncode}: "
              f"{r.stderr.strip()[-300:]})")
    r = subprocess.run([sys.executable, script, "--cbdpt", cbdpt, "--repeats", "2"], env=env,
                       capture_output=True, text=True, timeout=120)
    check(r.returncode == 2 and "at least 3" in r.stderr,
          f"--repeats 2 is refused (exit {r.returncode}: {r.stderr.strip()[-300:]})")
finish()
