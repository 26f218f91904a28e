#!/usr/bin/env python3
"""End-to-end tests of `cbdpt combine` and of what `cbdpt render` records for it: the render
record in the EXR header, the halves of the estimates (also through --resume), every
combination on real renders, --split-budget, and the refusal of inputs that cannot be combined.

Usage: test_combine_cli.py PATH/TO/cbdpt REPO_ROOT"""
import os
import shutil
import subprocess
import sys
import tempfile

cbdpt, root = sys.argv[1], sys.argv[2]
sys.path.insert(0, os.path.join(root, "scripts"))
import cbdpt_results as cr  # noqa: E402  (re-executes under the scripts' .venv/ first)
import numpy as np  # noqa: E402
from checks import check, finish  # noqa: E402

scene = os.path.join(root, "scenes", "cornell-box.pbrt")


def render(out, *args, sampler="independent"):
    """The independent sampler unless said: the combinations that weight one half of an input
    by the other need independent halves, which a Sobol render's are not."""
    r = subprocess.run([cbdpt, "render", scene, "--width", "24", "--height", "24", "-o", out,
                        "-q", "--sampler", sampler] + list(args), capture_output=True, text=True)
    check(r.returncode == 0, f"render {args} exits 0 ({r.stderr.strip()})")
    return r


def combine(*args):
    return subprocess.run([cbdpt, "combine", "-q"] + list(args), capture_output=True, text=True)


with tempfile.TemporaryDirectory() as tmp:
    pt1, pt2, cb1, cb2 = (os.path.join(tmp, n) for n in ("pt1.exr", "pt2.exr", "cb1.exr",
                                                           "cb2.exr"))
    render(pt1, "--integrator", "pt", "--eye-vertices", "6", "--spp", "16", "--seed", "1")
    render(pt2, "--integrator", "pt", "--eye-vertices", "6", "--spp", "16", "--seed", "2")
    for path, seed in ((cb1, "3"), (cb2, "4")):
        render(path, "--integrator", "cbdpt", "--eye-vertices", "3", "--light-vertices", "3",
               "--spp", "8", "--seed", seed)

    # The render record and the halves.
    rec = cr.read_exr_attributes(cb1)
    check(rec.get("cbdpt_method") == "cbdpt" and rec.get("cbdpt_eye_vertices") == 3
          and rec.get("cbdpt_light_vertices") == 3 and rec.get("cbdpt_seed") == 3
          and rec.get("cbdpt_estimates") == 8 and rec.get("cbdpt_estimate_ranges") == "0:8"
          and rec.get("cbdpt_scene") == "cornell-box.pbrt"
          and len(rec.get("cbdpt_scene_hash", "")) == 16
          and rec.get("cbdpt_render_cpu_seconds", 0) > 0, f"render record in the header ({rec})")
    mean, h0, h1 = (cr.read_exr(cb1, layer) for layer in ("", "half0", "half1"))
    check(np.allclose((h0 + h1) / 2, mean, rtol=1e-5, atol=1e-6),
          "the halves of 8 estimates average to the mean")
    check(not np.allclose(h0, h1), "the halves differ (independent estimates)")

    # --resume keeps the halves and adds the earlier run's time to the record.
    kept = os.path.join(tmp, "kept.exr")
    render(kept, "--spp", "6", "--seed", "7", "--keep-state")
    first = cr.read_exr_attributes(kept)["cbdpt_render_seconds"]
    render(kept, "--spp", "10", "--seed", "7", "--resume")
    rec = cr.read_exr_attributes(kept)
    mean, h0, h1 = (cr.read_exr(kept, layer) for layer in ("", "half0", "half1"))
    check(rec["cbdpt_estimates"] == 10 and rec["cbdpt_render_seconds"] > first,
          f"resumed record: 10 estimates, time of both runs ({rec}, first run {first})")
    check(np.allclose((h0 + h1) / 2, mean, rtol=1e-5, atol=1e-6),
          "after --resume the halves (5 + 5 estimates) still average to the mean")

    # Every combination runs; the plain mean is the inputs' mean; a method with itself (two
    # seeds) under inverse variance is close to their plain mean.
    for how in ("mean", "inverse-variance", "inverse-variance-naive", "median", "reject",
                "guided"):
        out = os.path.join(tmp, how + ".exr")
        r = combine(pt1, cb1, cb2, "--how", how, "-o", out)
        check(r.returncode == 0 and os.path.exists(out) and os.path.exists(out[:-4] + ".png"),
              f"combine --how {how} writes EXR and PNG ({r.stderr.strip()})")
        if r.returncode == 0:
            rec = cr.read_exr_attributes(out)
            check(rec["cbdpt_method"] == "combine:" + how and rec["cbdpt_estimates"] == 32,
                  f"{how}: the output's record ({rec})")
    check(np.allclose(cr.read_exr(os.path.join(tmp, "mean.exr")),
                      (cr.read_exr(pt1) + cr.read_exr(cb1) + cr.read_exr(cb2)) / 3, atol=1e-6),
          "mean is the inputs' plain mean")
    out_mean, out_iv = os.path.join(tmp, "pp-mean.exr"), os.path.join(tmp, "pp-iv.exr")
    combine(pt1, pt2, "--how", "mean", "-o", out_mean)
    combine(pt1, pt2, "--how", "inverse-variance", "--variance-radius", "2", "-o", out_iv)
    se = cr.read_exr(out_mean, "stderr")
    diff = cr.read_exr(out_iv) - cr.read_exr(out_mean)
    check(np.sqrt((diff ** 2).mean()) < 0.5 * np.sqrt((se ** 2).mean()),
          "PT with PT: inverse variance within half a standard error of the plain mean")

    # Refusals, each naming what differs.
    def refused(args, words, what):
        r = combine(*args, "-o", os.path.join(tmp, "refused.exr"))
        check(r.returncode != 0 and all(w in r.stderr for w in words),
              f"{what} refused naming {words} ({r.returncode}: {r.stderr.strip()})")

    refused([pt1, pt1], ["not independent", "pt1.exr"], "the same render twice")
    check(cr.read_exr_attributes(pt1).get("cbdpt_sampler") == "independent",
          "the record names the sampler")
    # The Sobol sampler: even and odd estimates (the halves) and disjoint estimate sets of one
    # seed are parts of one randomised sequence, correlated, so what needs independence refuses.
    so1, so2, so3 = (os.path.join(tmp, n) for n in ("so1.exr", "so2.exr", "so3.exr"))
    render(so1, "--eye-vertices", "6", "--spp", "8", "--seed", "21", sampler="sobol")
    render(so2, "--eye-vertices", "6", "--spp", "8", "--seed", "22", sampler="sobol")
    for how in ("inverse-variance", "guided"):
        refused([so1, cb1, "--how", how], ["needs independent halves", "so1.exr", "Sobol"],
                f"{how} of a Sobol render")
    r = combine(so1, so2, "--how", "mean", "-o", os.path.join(tmp, "so-mean.exr"))
    check(r.returncode == 0, f"the mean of Sobol renders of two seeds runs ({r.stderr})")
    render(so3, "--eye-vertices", "6", "--spp", "16", "--estimates", "8:16", "--seed", "21",
           sampler="sobol")
    refused([so1, so3, "--how", "mean"], ["one seed with the Sobol sampler", "cbdpt merge"],
            "disjoint estimates of one Sobol seed")
    in1, in2 = os.path.join(tmp, "in1.exr"), os.path.join(tmp, "in2.exr")
    render(in1, "--eye-vertices", "6", "--spp", "8", "--estimates", "0:4", "--seed", "23")
    render(in2, "--eye-vertices", "6", "--spp", "8", "--estimates", "4:8", "--seed", "23")
    r = combine(in1, in2, "--how", "mean", "-o", os.path.join(tmp, "in-mean.exr"))
    check(r.returncode == 0, f"disjoint estimates of one independent seed combine ({r.stderr})")
    # Other parts of the film, and a one-strategy debugging image, are not the image.
    top, bottom = os.path.join(tmp, "top.exr"), os.path.join(tmp, "bottom.exr")
    render(top, "--eye-vertices", "6", "--spp", "4", "--seed", "24",
           "--cropwindow", "0", "1", "0", "0.5")
    render(bottom, "--eye-vertices", "6", "--spp", "4", "--seed", "25",
           "--cropwindow", "0", "1", "0.5", "1")
    refused([top, bottom, "--how", "mean"], ["different parts of the film", "0 24 0 12"],
            "two crop windows of one size")
    one = os.path.join(tmp, "strategy.exr")
    render(one, "--integrator", "bdpt", "--eye-vertices", "3", "--light-vertices", "3",
           "--strategy", "1,2", "--spp", "4", "--seed", "26")
    refused([cb1, one, "--how", "mean"], ["renders only strategy 1,2"], "a --strategy image")
    pt8 = os.path.join(tmp, "pt8.exr")
    render(pt8, "--integrator", "pt", "--eye-vertices", "8", "--spp", "4", "--seed", "9")
    refused([pt1, pt8], ["vertex caps", "6 vs 8"], "other caps")
    small = os.path.join(tmp, "small.exr")
    subprocess.run([cbdpt, "render", scene, "--width", "16", "--height", "16", "--eye-vertices",
                    "6", "--spp", "4", "--seed", "9", "-o", small, "-q"], check=True)
    refused([pt1, small], ["differ in size", "24x24 vs 16x16"], "another size")
    other_dir = os.path.join(tmp, "other")
    os.makedirs(other_dir)
    shutil.copy(scene, other_dir)
    with open(os.path.join(other_dir, "cornell-box.pbrt"), "a") as f:
        f.write("\n# changed\n")
    other = os.path.join(tmp, "other.exr")
    subprocess.run([cbdpt, "render", os.path.join(other_dir, "cornell-box.pbrt"), "--width", "24",
                    "--height", "24", "--eye-vertices", "6", "--spp", "4", "--seed", "9", "-o",
                    other, "-q"], check=True)
    refused([pt1, other], ["different scenes"], "a scene file of the same name, other content")
    bare = os.path.join(tmp, "bare.exr")  # an EXR of the right size without cbdpt's record
    cr.write_exr(bare, {"": cr.read_exr(pt1), "stderr": cr.read_exr(pt1, "stderr")})
    refused([pt1, bare], ["no cbdpt render record"], "a file without a record")
    refused([pt1], ["at least two"], "a single input")
    refused([pt1, pt2, "--how", "guided"], ["pattern-prone"], "guided without a CBDPT input")
    out = os.path.join(tmp, "blend.exr")
    r = combine(pt1, cb1, "--how", "guided", "--guide-blend", "-o", out)
    check(r.returncode == 0 and os.path.exists(out), f"guided --guide-blend runs ({r.stderr})")

    # --split-budget: two methods in one budget, shares recorded, parts kept.
    out = os.path.join(tmp, "split.exr")
    parts = os.path.join(tmp, "parts")
    r = combine("--split-budget", "1.5", "--methods", "pt,cbdpt", "--shares", "0.4",
                "--eye-vertices", "3", "--light-vertices", "3", "--width", "24", "--height", "24",
                scene, "--how", "guided", "-o", out, "--keep-inputs", parts, "--stats",
                out[:-4] + ".json")
    check(r.returncode == 0 and os.path.exists(out), f"--split-budget runs ({r.stderr.strip()})")
    if r.returncode == 0:
        import json
        stats = json.load(open(out[:-4] + ".json"))
        secs = [i["render_seconds"] for i in stats["inputs"]]
        check(stats["split_budget"]["shares"] == [0.4, 0.6]
              and abs(secs[0] - 0.6) < 0.5 and abs(secs[1] - 0.9) < 0.5
              and [i["method"] for i in stats["inputs"]] == ["pt", "cbdpt"]
              and stats["inputs"][0]["eye_vertices"] == 6,
              f"split budget: shares, methods, caps and times ({stats})")
        p0 = cr.read_exr_attributes(os.path.join(parts, "0-pt.exr"))
        p1 = cr.read_exr_attributes(os.path.join(parts, "1-cbdpt.exr"))
        check(p0["cbdpt_seed"] != p1["cbdpt_seed"], "the methods of a split get distinct seeds")
    r = combine("--split-budget", "1", "--methods", "pt,cbdpt", "--shares", "0.4,0.4", scene,
                "-o", out)
    check(r.returncode != 0 and "--shares" in r.stderr, f"bad shares refused ({r.stderr.strip()})")
    # Outputs that cannot be written are refused before the budget's renders, naming them.
    for args, name in ((["-o", os.path.join(tmp, "missing", "x.exr")], "(-o)"),
                       (["-o", out, "--stats", "-q"], "(--stats)")):
        r = combine("--split-budget", "1", "--methods", "pt,cbdpt", "--width", "8", "--height",
                    "8", scene, *args)
        check(r.returncode != 0 and name in r.stderr and "estimates" not in r.stderr,
              f"combine {' '.join(args)} is refused before rendering ({r.stderr.strip()})")

    # --max-vertices: every method under the total-length cap N (PT's integral), recorded in the
    # parts' headers; per-subpath caps of another total are refused against them.
    capped = os.path.join(tmp, "capped")
    r = combine("--split-budget", "1", "--methods", "pt,cbdpt", "--max-vertices", "5",
                "--width", "24", "--height", "24", scene, "-o", out, "--keep-inputs", capped)
    check(r.returncode == 0, f"--split-budget --max-vertices runs ({r.stderr.strip()})")
    if r.returncode == 0:
        p0 = cr.read_exr_attributes(os.path.join(capped, "0-pt.exr"))
        p1 = cr.read_exr_attributes(os.path.join(capped, "1-cbdpt.exr"))
        check(p0["cbdpt_max_vertices"] == 5 and p1["cbdpt_max_vertices"] == 5
              and p1["cbdpt_eye_vertices"] == 5 and p1["cbdpt_light_vertices"] == 4,
              f"the total cap reaches both methods ({p0}, {p1})")
        other = os.path.join(tmp, "cb-3p3.exr")
        render(other, "--integrator", "cbdpt", "--eye-vertices", "3", "--light-vertices", "3",
               "--spp", "2", "--seed", "9")
        r = combine(os.path.join(capped, "0-pt.exr"), other, "-o", out)
        check(r.returncode != 0 and "vertex caps" in r.stderr and "N=5" in r.stderr,
              f"N=5 against 3+3 refused, naming both ({r.stderr.strip()})")
    r = combine("--split-budget", "1", "--methods", "pt,cbdpt", "--max-vertices", "5",
                "--eye-vertices", "3", scene, "-o", out)
    check(r.returncode != 0 and "--max-vertices" in r.stderr,
          f"--max-vertices with --eye-vertices refused ({r.stderr.strip()})")

finish()
