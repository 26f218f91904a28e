#!/usr/bin/env python3
"""End-to-end tests of the cbdpt command line: render writes EXR, PNG and statistics; Ctrl-C
mid-render writes the estimates done; bad requests fail with a clear message and exit code.

Usage: test_cli.py PATH/TO/cbdpt REPO_ROOT"""
import json
import os
import re
import signal
import subprocess
import sys
import tempfile
import time

cbdpt, root = sys.argv[1], sys.argv[2]
sys.path.insert(0, os.path.join(root, "scripts"))
import cbdpt_results as cr  # noqa: E402
import numpy as np  # noqa: E402
from checks import check, finish  # noqa: E402
scene = os.path.join(root, "scenes", "cornell-box.pbrt")


def same_pixels(a, b):
    """Every layer bit for bit (the headers differ: they record each run's render time)."""
    layers = ("", "stderr", "half0", "half0.stderr", "half1", "half1.stderr")
    return all(cr.read_exr(a, layer).tobytes() == cr.read_exr(b, layer).tobytes()
               for layer in layers)


with tempfile.TemporaryDirectory() as tmp:
    exr, png, stats = (os.path.join(tmp, n) for n in ("c.exr", "c.png", "c.json"))

    # A small complete render.
    r = subprocess.run([cbdpt, "render", scene, "--spp", "4", "--width", "32", "--height", "32",
                        "-o", exr, "--png", png, "--stats", stats], capture_output=True, text=True)
    check(r.returncode == 0, f"render exits 0 (got {r.returncode}: {r.stderr})")
    check(os.path.getsize(exr) > 1000, "EXR written")
    with open(png, "rb") as f:
        check(f.read(8) == b"\x89PNG\r\n\x1a\n", "PNG written with a PNG signature")
    s = json.load(open(stats))
    check(s["estimates"] == 4 and s["channels"] == 16, f"stats: 4 estimates, spectral ({s})")
    check(s["non_finite_samples"] == 0, "no non-finite samples")
    check(0 < s["mean_standard_error"] < 1, "standard error is positive and sane")
    # Timing fields: the first estimate (which includes PoCL's lazy compilation at the first
    # launch) is reported apart; seconds_per_estimate is the rate of the others. Identities only.
    check(s["estimates_rendered"] == 4 and 0 < s["first_estimate_seconds"] <= s["render_seconds"],
          f"first estimate within the render time ({s})")
    check(abs(s["seconds_per_estimate"] * 3 + s["first_estimate_seconds"] - s["render_seconds"])
          <= 1e-9 * s["render_seconds"] + 1e-12,
          f"seconds_per_estimate * (n - 1) + first_estimate_seconds = render_seconds ({s})")
    # The console's rate is the statistics' steady one (3 significant digits), not render / n.
    m = re.search(r"4 estimates in \S+ \(([0-9.e+-]+) s/estimate", r.stderr)
    check(m is not None and float(m.group(1)) == float(f"{s['seconds_per_estimate']:.3g}"),
          f"the summary line's s/estimate is seconds_per_estimate ({r.stderr} {s})")
    check(not any(n.startswith(".") for n in os.listdir(tmp)), "no temporary files left behind")

    # A pbrt-v4 file's Sampler and Integrator lines are defaults: pixelsamples 64 -> 64
    # estimates, "path" with maxdepth 5 -> PT with 7 vertices; the command line overrides them.
    pbrt_scene = os.path.join(root, "scenes", "pbrt-v4", "cornell-box.pbrt")
    r = subprocess.run([cbdpt, "render", pbrt_scene, "--width", "8", "--height", "8", "-o", exr,
                        "--png", png, "--stats", stats, "-q"], capture_output=True, text=True)
    check(r.returncode == 0, f"pbrt-v4 file renders (got {r.returncode}: {r.stderr})")
    s = json.load(open(stats))
    check(s["estimates"] == 64 and s["integrator"] == "pt" and s["eye_vertices"] == 7,
          f"Sampler/Integrator defaults applied ({s})")
    check(r.stderr.count("not used") == 1, f"the sampler is reported once ({r.stderr})")
    r = subprocess.run([cbdpt, "render", pbrt_scene, "--width", "8", "--height", "8", "--spp", "2",
                        "--integrator", "bdpt", "--eye-vertices", "3", "-o", exr, "--png", png,
                        "--stats", stats, "-q"], capture_output=True, text=True)
    s = json.load(open(stats))
    check(r.returncode == 0 and s["estimates"] == 2 and s["integrator"] == "bdpt" and
          s["eye_vertices"] == 3 and s["light_vertices"] == 3,
          f"the command line overrides the file; maxdepth 5 -> Nl = 3 ({s})")
    # Without subpath caps, a bidirectional method takes pbrt-v4's convention: maxdepth 5 is the
    # total-length cap N = 7 (Ne = 7, Nl = 6, strategies with s + t <= 7).
    r = subprocess.run([cbdpt, "render", pbrt_scene, "--width", "8", "--height", "8", "--spp", "2",
                        "--integrator", "bdpt", "-o", exr, "--png", png, "--stats", stats, "-q"],
                       capture_output=True, text=True)
    s = json.load(open(stats)) if r.returncode == 0 else {}
    check(r.returncode == 0 and (s["max_vertices"], s["eye_vertices"], s["light_vertices"]) ==
          (7, 7, 6), f"maxdepth 5 -> --max-vertices 7 for bdpt ({r.stderr} {s})")

    # Every integrator renders from the command line; MLT reports its chain statistics.
    for integrator, extra in (("bdpt", ["--light-vertices", "3"]), ("cbdpt", ["--light-vertices", "3"]),
                              ("cpt", ["--coherence-tile", "2"]),
                              ("mlt", ["--light-vertices", "3", "--chains", "16", "--bootstrap", "1024"])):
        r = subprocess.run([cbdpt, "render", scene, "--integrator", integrator, "--eye-vertices", "3",
                            "--spp", "2", "--width", "16", "--height", "16", "-o", exr, "--png", png,
                            "--stats", stats, "-q"] + extra, capture_output=True, text=True)
        check(r.returncode == 0, f"{integrator} renders (got {r.returncode}: {r.stderr})")
        s = json.load(open(stats))
        check(s["integrator"] == integrator and s["estimates"] == 2, f"{integrator} stats ({s})")
        check(abs(s["seconds_per_estimate"] + s["first_estimate_seconds"] - s["render_seconds"])
              <= 1e-9 * s["render_seconds"] + 1e-12, f"{integrator} timing fields add up ({s})")
        # The Cornell box's tree fits any cache: no method prefetches it.
        check(s.get("tree_prefetch") is False,
              f"{integrator}: tree_prefetch false ({s.get('tree_prefetch')})")
        if integrator == "mlt":
            check(0 < s["mlt"]["acceptance_rate"] < 1 and s["mlt"]["mutations"] > 0,
                  f"mlt statistics in the stats file ({s.get('mlt')})")

    # The total-length cap: subpath caps N and N - 1, stated in the statistics; it replaces
    # --eye-vertices and --light-vertices, so giving both is an error.
    for integrator in ("pt", "bdpt", "cbdpt", "mlt"):
        r = subprocess.run([cbdpt, "render", scene, "--integrator", integrator, "--max-vertices",
                            "4", "--spp", "2", "--width", "8", "--height", "8", "-o", exr,
                            "--stats", stats, "-q"] +
                           (["--chains", "4", "--bootstrap", "256"] if integrator == "mlt" else []),
                           capture_output=True, text=True)
        check(r.returncode == 0, f"{integrator} --max-vertices 4 renders ({r.stderr})")
        s = json.load(open(stats))
        check((s["max_vertices"], s["eye_vertices"], s["light_vertices"]) == (4, 4, 3),
              f"{integrator} --max-vertices 4: N=4, Ne=4, Nl=3 in the statistics ({s})")
    r = subprocess.run([cbdpt, "render", scene, "--max-vertices", "4", "--eye-vertices", "3",
                        "-o", exr], capture_output=True, text=True)
    check(r.returncode != 0 and "excludes" in r.stderr,
          f"--max-vertices with --eye-vertices is refused ({r.returncode}: {r.stderr})")
    r = subprocess.run([cbdpt, "render", scene, "--max-vertices", "1", "-o", exr],
                       capture_output=True, text=True)
    check(r.returncode != 0 and "--max-vertices 1 is out of range" in r.stderr,
          f"--max-vertices 1 is refused ({r.returncode}: {r.stderr})")

    # Ctrl-C mid-render: the estimates done are written, exit code 130.
    os.remove(exr)
    p = subprocess.Popen([cbdpt, "render", scene, "--spp", "100000", "--width", "32", "--height",
                          "32", "-o", exr, "--png", png, "--stats", stats],
                         stderr=subprocess.PIPE, text=True)
    # Wait until a few estimates are done (the progress bar prints a line per 10% when stderr
    # is not a terminal, so poll the clock instead, generously for a cold kernel cache).
    time.sleep(8)
    p.send_signal(signal.SIGINT)
    _, err = p.communicate(timeout=120)
    check(p.returncode == 130, f"interrupted render exits 130 (got {p.returncode}: {err})")
    check(os.path.exists(exr) and os.path.exists(png), "interrupted render wrote EXR and PNG")
    s = json.load(open(stats))
    check(s["interrupted"] and 0 < s["estimates"] < 100000,
          f"interrupted render kept its estimates ({s['estimates']})")

    # Resume: a render continued from its saved state equals an uninterrupted one bit for bit.
    def render(out, spp, *extra):
        return subprocess.run([cbdpt, "render", scene, "--spp", str(spp), "--width", "24",
                               "--height", "24", "-o", out, "--png", png, "--stats", stats, "-q"]
                              + list(extra), capture_output=True, text=True)

    full, part = os.path.join(tmp, "full.exr"), os.path.join(tmp, "part.exr")
    render(full, 6)
    render(part, 3, "--keep-state")
    check(os.path.exists(part + ".state"), "--keep-state writes the state sidecar")
    r = render(part, 6, "--resume")
    check(r.returncode == 0 and same_pixels(full, part),
          f"3 + 3 resumed estimates equal 6 uninterrupted ones bit for bit ({r.stderr})")
    s = json.load(open(stats))
    check(s["estimates"] == 6 and s["estimates_rendered"] == 3 and
          abs(s["seconds_per_estimate"] * 2 + s["first_estimate_seconds"] - s["render_seconds"])
          <= 1e-9 * s["render_seconds"] + 1e-12,
          f"a resumed render times only the estimates it rendered ({s})")
    check(not os.path.exists(part + ".state"), "a finished render removes its state")
    # SIGTERM mid-render, then --resume to a total beyond the estimates done.
    p = subprocess.Popen([cbdpt, "render", scene, "--spp", "1000000", "--width", "24", "--height",
                          "24", "-o", part, "--png", png, "--stats", stats, "-q"],
                         stderr=subprocess.PIPE, text=True)
    time.sleep(6)
    p.send_signal(signal.SIGTERM)
    _, err = p.communicate(timeout=120)
    done = json.load(open(stats))["estimates"]
    check(p.returncode == 130 and os.path.exists(part + ".state") and done > 0,
          f"SIGTERM writes the image and the state ({p.returncode}, {done} estimates: {err})")
    total = done + 3
    render(full, total)
    r = render(part, total, "--resume")
    check(r.returncode == 0 and same_pixels(full, part),
          f"interrupted at {done} and resumed to {total} equals an uninterrupted render ({r.stderr})")
    render(part, 3, "--keep-state")
    r = render(part, 6, "--resume", "--seed", "9")
    check(r.returncode != 0 and "different render" in r.stderr,
          f"resuming with other settings is refused ({r.stderr.strip()})")
    r = render(os.path.join(tmp, "never.exr"), 6, "--resume")
    check(r.returncode != 0 and "no saved state" in r.stderr, f"resume without state ({r.stderr.strip()})")

    # Bad requests: clear messages, non-zero exit.
    bad = os.path.join(tmp, "bad.pbrt")
    with open(bad, "w") as f:
        f.write("WorldBegin\nShape \"curve\"\n")
    r = subprocess.run([cbdpt, "render", bad], capture_output=True, text=True)
    check(r.returncode != 0 and "bad.pbrt:2:" in r.stderr,
          f"unknown shape names file and line ({r.stderr.strip()})")
    r = subprocess.run([cbdpt, "render", scene, "--width", "32768", "--height", "32768"],
                       capture_output=True, text=True)
    check(r.returncode != 0 and "resolution" in r.stderr, f"absurd resolution refused ({r.stderr.strip()})")
    r = subprocess.run([cbdpt, "render", scene, "--spp", "0"], capture_output=True, text=True)
    check(r.returncode != 0 and "--spp" in r.stderr, f"zero estimates refused ({r.stderr.strip()})")
    r = subprocess.run([cbdpt, "render", scene, "--eye-vertices", "1"], capture_output=True, text=True)
    check(r.returncode != 0 and "eye-vertices" in r.stderr, f"eye cap 1 refused ({r.stderr.strip()})")
    r = subprocess.run([cbdpt, "render", os.path.join(tmp, "missing.pbrt")], capture_output=True, text=True)
    check(r.returncode != 0 and "missing.pbrt: cannot read the scene file: no such file" in r.stderr,
          f"missing file named, with the reason ({r.stderr.strip()})")
    r = subprocess.run([cbdpt, "render", tmp], capture_output=True, text=True)
    check(r.returncode != 0 and "it is a folder, not a file" in r.stderr,
          f"a folder given as the scene is refused, with the reason ({r.stderr.strip()})")
    # A real device out-of-memory: PoCL's CPU device shrunk to 1 GiB of global memory
    # (POCL_MEMORY_LIMIT, in GiB; its largest allocation becomes 256 MiB). A 4800 x 4800 image
    # needs 264 MiB per RGB float buffer; 10^6 MLT chains of 236 primary samples need 900 MiB.
    # Both are refused before rendering, naming the buffer and its size.
    limited = dict(os.environ, POCL_MEMORY_LIMIT="1")
    for name, args, buffer in (
            ("image", ["--width", "4800", "--height", "4800", "--spp", "1"],
             "path-tracing image (width x height RGB) needs 263.7 MiB"),
            ("mlt chains", ["--integrator", "mlt", "--chains", "1000000", "--eye-vertices", "16",
                            "--light-vertices", "16", "--width", "16", "--height", "16", "--spp", "1"],
             "MLT chain states (chains x primary samples) needs 930.8 MiB")):
        r = subprocess.run([cbdpt, "render", scene, "-o", os.path.join(tmp, "oom.exr"), "-q"] + args,
                           capture_output=True, text=True, env=limited)
        err = r.stderr.strip()
        check(r.returncode != 0 and buffer in err and "256.0 MiB" in err
              and "--width/--height" in err and "--eye-vertices" in err,
              f"out of device memory ({name}) names the buffer, its size, the limit and what to "
              f"reduce ({r.returncode}: {err})")
        check(not os.path.exists(os.path.join(tmp, "oom.exr")), f"out of memory ({name}) writes no image")

    r = subprocess.run([cbdpt, "info"], capture_output=True, text=True)
    check(r.returncode == 0 and "0:0" in r.stdout, f"info lists devices ({r.stdout.strip()})")
    r = subprocess.run([cbdpt, "info", scene], capture_output=True, text=True)
    check(r.returncode == 0 and "triangles" in r.stdout and "spectral-16" in r.stdout and
          re.search(r"leaf packs, [0-9.e+-]+ MB", r.stdout),
          f"info describes the scene, the tree's size too ({r.stdout.strip()})")
    box = os.path.join(root, "scenes", "pbrt-v4", "box-spectral.pbrt")
    r = subprocess.run([cbdpt, "info", box], capture_output=True, text=True)
    check("4 (2 area-light primitives, 1 point lights, 1 spot, 0 distant, 0 infinite)" in r.stdout,
          f"info counts the spot light apart from the point light ({r.stdout.strip()})")
    lens = os.path.join(root, "scenes", "pbrt-v4", "thin-lens.pbrt")
    r = subprocess.run([cbdpt, "info", lens], capture_output=True, text=True)
    check("fov 40, thin lens of radius 0.12, in focus at 3.3" in r.stdout and "thin-lens" in r.stdout,
          f"info describes the thin lens ({r.stdout.strip()})")
    sinc = os.path.join(root, "scenes", "pbrt-v4", "pixel-filter-sinc.pbrt")
    r = subprocess.run([cbdpt, "info", sinc], capture_output=True, text=True)
    check("pixel filter     sinc (Lanczos), radius 4 x 4, tau 3" in r.stdout,
          f"info names the pixel filter and its parameters ({r.stdout.strip()})")
    clamp = os.path.join(root, "scenes", "pbrt-v4", "sample-clamp.pbrt")
    r = subprocess.run([cbdpt, "info", clamp], capture_output=True, text=True)
    check("192x192, sensor cie1931, imaging ratio 1, each sample clamped to sensor RGB 0.3 "
          "(maxcomponentvalue)" in r.stdout
          and "sample-clamp" in r.stdout and "biases the image" in r.stderr,
          f"info shows the film's sample clamp, and its note ({r.stdout.strip()} {r.stderr.strip()})")

    # A camera sensor: its name, its white balance (6500 K unless the file says) and ratio.
    camera = os.path.join(tmp, "camera.pbrt")
    with open(lens) as f:
        text = f.read()
    with open(camera, "w") as f:
        f.write(re.sub(r'Film "rgb"', 'Film "rgb" "string sensor" "sony_ilce_9" "float iso" 200',
                       text, count=1))
    r = subprocess.run([cbdpt, "info", camera], capture_output=True, text=True)
    check("sensor sony_ilce_9 white-balanced at 6500 K, imaging ratio 2" in r.stdout
          and "spectral-16" in r.stdout,
          f"info names the camera sensor, rendered spectrally ({r.stdout.strip()} {r.stderr.strip()})")

    # --max-component-value replaces the file's clamp (inf: none), and is part of the render's
    # identity: the same value renders the file's bits, combine and --resume refuse a mix.
    def clamped(out, *extra, seed="1"):
        return subprocess.run([cbdpt, "render", clamp, "--spp", "2", "--width", "16", "--height",
                               "16", "--seed", seed, "-q", "-o", out] + list(extra),
                              capture_output=True, text=True)
    as_file, same, unclamped = (os.path.join(tmp, n) for n in ("f.exr", "s.exr", "u.exr"))
    results = [clamped(as_file), clamped(same, "--max-component-value", "0.3"),
               clamped(unclamped, "--max-component-value", "inf", "--keep-state", "--stats",
                       stats)]
    check(all(x.returncode == 0 for x in results), f"clamp overrides render ({results[-1].stderr})")
    check(same_pixels(as_file, same), "--max-component-value 0.3 renders the file's 0.3 bit for bit")
    mean_file, mean_free = cr.read_exr(as_file).mean(), cr.read_exr(unclamped).mean()
    check(mean_free > 1.02 * mean_file,
          f"without the clamp the image is brighter ({mean_free} vs {mean_file})")
    attributes = cr.read_exr_attributes(unclamped)
    check(attributes.get("cbdpt_max_component_value") == "inf"
          and "cbdpt_max_component_value" not in cr.read_exr_attributes(as_file),
          f"the override is recorded in the EXR header ({attributes})")
    check(json.load(open(stats)).get("max_component_value") == "inf",
          "and in the statistics")
    other = os.path.join(tmp, "o.exr")
    clamped(other, "--max-component-value", "inf", seed="2")
    r = subprocess.run([cbdpt, "combine", as_file, other, "-o", os.path.join(tmp, "c2.exr")],
                       capture_output=True, text=True)
    check(r.returncode != 0 and "sample clamp" in r.stderr,
          f"combine refuses renders of two clamps ({r.returncode}: {r.stderr.strip()})")
    r = subprocess.run([cbdpt, "render", clamp, "--spp", "4", "--width", "16", "--height", "16",
                        "--seed", "1", "-q", "-o", unclamped, "--resume"],
                       capture_output=True, text=True)
    check(r.returncode != 0 and "max_component_value" in r.stderr,
          f"--resume without the override is refused ({r.returncode}: {r.stderr.strip()})")
    for bad in ("0", "-1", "abc", "nan"):
        r = clamped(other, "--max-component-value", bad)
        check(r.returncode != 0 and f"--max-component-value {bad}" in r.stderr,
              f"--max-component-value {bad} is refused by name ({r.returncode}: {r.stderr.strip()})")

# Command-line habits (pbrt-v4's names where it has them) and bad input.
def run(*args, env=None):
    return subprocess.run([cbdpt, *args], capture_output=True, text=True, env=env,
                          errors="backslashreplace")


def printable(text):
    return all(c in "\t\n" or " " <= c <= "~" for c in text)


with tempfile.TemporaryDirectory() as tmp:
    out = os.path.join(tmp, "o.exr")
    stats = os.path.join(tmp, "o.json")
    small = ["--width", "16", "--height", "16", "-q"]

    # Every out-of-range number and every unknown name is refused before rendering, naming the
    # option; nothing is written.
    for args in (["--width", "-5"], ["--width", "0"], ["--height", "0"], ["--spp", "-1"],
                 ["--time", "-1"], ["--time", "nan"], ["--eye-vertices", "0"],
                 ["--light-vertices", "0"], ["--rr-vertex", "-1"], ["--chains", "-5"],
                 ["--bootstrap", "-1"], ["--large-step", "2"], ["--large-step", "nan"],
                 ["--mutation-size", "0"], ["--tile", "0"], ["--tile", "64"],
                 ["--coherence-tile", "0"], ["--seed", "-1"], ["--seed", "4294967296"],
                 ["--nthreads", "0"], ["--target-stderr", "0"], ["--target-stderr", "inf"],
                 ["--checkpoint-every", "-1"], ["--cropwindow", "0", "1.5", "0", "1"],
                 ["--cropwindow", "0", "1", "0"], ["--integrator", "foo"],
                 ["--weights", "foo"], ["--channels", "foo"], ["--width", "12x"],
                 ["--png", os.path.join(tmp, "preview.jpg")]):
        r = run("render", scene, "-o", out, *args)
        check(r.returncode in (1, 2) and args[0] in r.stderr and not os.path.exists(out),
              f"render {' '.join(args)} is refused naming the option ({r.returncode}: "
              f"{r.stderr.strip()})")
    # Exit status: 2 for a command line CLI11 refuses, 1 for a failure while running, 0 for --help.
    for args, status in ((["render", scene, "--width", "0"], 2), (["render", scene, "--frob"], 2),
                         ([], 2), (["render"], 2), (["render", "--help"], 0),
                         (["render", os.path.join(tmp, "none.pbrt"), "-o", out], 1)):
        r = run(*args)
        check(r.returncode == status,
              f"cbdpt {' '.join(args)} exits {status} ({r.returncode}: {r.stderr.strip()[:200]})")
    # An output path that starts with '-' is an option that took a file name's place
    # (`--stats -q`): refused before rendering, naming it, with nothing written.
    r = subprocess.run([cbdpt, "render", scene, "-o", out, "--spp", "1", "--width", "16",
                        "--height", "16", "--stats", "-q"], capture_output=True, text=True,
                       cwd=tmp)
    check(r.returncode != 0 and "--stats" in r.stderr and "./-q" in r.stderr
          and not os.path.exists(os.path.join(tmp, "-q")) and not os.path.exists(out),
          f"--stats -q is refused ({r.returncode}: {r.stderr.strip()})")
    r = run("render", scene, "-o", out, "--integrator", "foo")
    check("pt" in r.stderr and "cbdpt" in r.stderr and "mlt" in r.stderr,
          f"an unknown integrator lists the known ones ({r.stderr.strip()})")
    r = run("compare", out, out, "--diff-scale", "0")
    check(r.returncode != 0 and "--diff-scale" in r.stderr, f"compare --diff-scale 0 ({r.stderr})")
    r = run("compare", out, out, "--diff-png", "-x")
    check(r.returncode != 0 and "--diff-png" in r.stderr, f"compare --diff-png -x ({r.stderr})")
    # A NaN is counted, named, drawn black in the map and fails the comparison; the other pixels
    # keep the map's colours.
    r = run("render", scene, "-o", out, "--spp", "1", *small)
    check(r.returncode == 0, f"a 16x16 render to compare ({r.stderr})")
    good = cr.read_exr(out)
    bad = good.copy()
    bad[0, 0, 1] = float("nan")
    nan_exr, diff_png = os.path.join(tmp, "nan.exr"), os.path.join(tmp, "nan-diff.png")
    cr.write_exr(nan_exr, {"": bad})
    r = run("compare", nan_exr, out, "--json", "--diff-png", diff_png)
    j = json.loads(r.stdout) if r.stdout.startswith("{") else {}
    check(r.returncode == 1 and "1 of 768 values not finite" in r.stderr and nan_exr in r.stderr
          and j.get("image_nonfinite_values") == 1 and j.get("reference_nonfinite_values") == 0,
          f"compare counts a NaN and exits 1 ({r.returncode}: {r.stderr.strip()}, {j})")
    from PIL import Image
    pixels = np.asarray(Image.open(diff_png).convert("RGB"))
    check(pixels[0, 0].tolist() == [0, 0, 0] and pixels[0, 1].tolist() == [255, 255, 255],
          f"the NaN pixel is black, an exact one white ({pixels[0, :2].tolist()})")
    r = run("compare", out, out)
    check(r.returncode == 0 and r.stderr == "", f"finite images compare with exit 0 ({r.stderr})")

    # --outfile is -o; --help shows defaults and examples; --version names version, revision
    # and platform.
    r = run("render", scene, "--outfile", out, "--spp", "1", *small)
    check(r.returncode == 0 and os.path.exists(out), f"--outfile writes the image ({r.stderr})")
    r = run("render", "--help")
    check(r.returncode == 0 and "Examples:" in r.stdout and "=16" in r.stdout
          and "=power" in r.stdout and "--outfile" in r.stdout,
          f"render --help shows defaults and examples ({r.stdout})")
    r = run("--version")
    check(r.returncode == 0 and r.stdout.startswith("cbdpt ") and "(git " in r.stdout
          and "OpenCL platform: " in r.stdout, f"--version ({r.stdout.strip()} {r.stderr})")
    # The revision is the checkout's at build time (scripts/git_revision.cmake), not at
    # configure time: the commit it names has the code of this checkout's HEAD (later commits
    # may have changed docs or unit logs only), unless the build says "-dirty".
    named = re.search(r"\(git ([0-9a-f]+)(-dirty)?\)", r.stdout)
    inside_git = subprocess.run(["git", "-C", root, "rev-parse", "HEAD"],
                                capture_output=True).returncode == 0
    if inside_git and named and not named.group(2):
        same = subprocess.run(["git", "-C", root, "diff", "--quiet", named.group(1), "HEAD", "--",
                               "CMakeLists.txt", "src", "kernels"], capture_output=True)
        check(same.returncode == 0,
              f"--version's revision {named.group(1)} has HEAD's code ({r.stdout.strip()})")

    # Devices: the default is PoCL's CPU device; --device and info --device choose one.
    r = run("info", "--device", "0:0")
    check(r.returncode == 0 and "* 0:0" in r.stdout and "--device 0:0" in r.stdout,
          f"info --device marks the device ({r.stdout.strip()})")
    r = run("info")
    check(r.returncode == 0 and "default: PoCL's CPU device" in r.stdout,
          f"info names the default device ({r.stdout.strip()})")
    for device in ("7:0", "0:9", "x"):
        r = run("info", "--device", device)
        check(r.returncode != 0 and device in r.stderr and "0:0" in r.stderr,
              f"info --device {device} is refused, listing the devices ({r.stderr.strip()})")
    r = run("render", scene, "-o", out, "--device", "gpu", *small)
    check(r.returncode != 0 and "no OpenCL device matches 'gpu'" in r.stderr,
          f"--device gpu without a GPU ({r.stderr.strip()})")
    r = run("render", scene, "-o", out, "--device", "cpu", "--spp", "1", "--stats", stats, *small)
    check(r.returncode == 0 and json.load(open(stats))["device"] in run("info").stdout,
          f"--device cpu renders on a device info lists ({r.stderr})")

    # --nthreads limits PoCL's worker threads: the device reports them as its compute units, and
    # with one thread BDPT's atomic splats add in one order, so two renders agree bit for bit.
    r = run("info", "--nthreads", "1")
    check(r.returncode == 0 and "* 0:0" in r.stdout and "| 1 compute units" in r.stdout,
          f"info --nthreads 1 ({r.stdout.strip()})")
    images = []
    for i in range(2):
        images.append(os.path.join(tmp, f"t{i}.exr"))
        r = run("render", scene, "-o", images[-1], "--integrator", "bdpt", "--spp", "2",
                "--nthreads", "1", "--stats", stats, *small)
        check(r.returncode == 0 and json.load(open(stats))["device_compute_units"] == 1,
              f"render --nthreads 1 runs on one compute unit ({r.stderr})")
    check(same_pixels(images[0], images[1]), "two one-thread BDPT renders are identical")

    # --quick as pbrt-v4: a quarter of the resolution each way, one estimate (MLT: / 16).
    r = run("render", scene, "-o", out, "--quick", "--stats", stats, "-q")
    s = json.load(open(stats))
    check(r.returncode == 0 and (s["width"], s["height"], s["estimates"]) == (128, 128, 1),
          f"--quick renders 128x128 with 1 estimate ({r.stderr} {s})")
    r = run("render", scene, "-o", out, "--quick", "--integrator", "mlt", "--spp", "64",
            "--stats", stats, "-q")
    s = json.load(open(stats))
    check(r.returncode == 0 and s["estimates"] == 4 and s["mlt"]["bootstrap_samples"] == 4096,
          f"--quick with mlt: 64 / 16 estimates, 65536 / 16 bootstrap samples ({s})")

    # --target-stderr stops at the first estimate whose mean standard error is below it.
    r = run("render", scene, "-o", out, "--target-stderr", "0.05", "--spp", "1000", "--stats",
            stats, *small[:4])
    s = json.load(open(stats))
    check(r.returncode == 0 and s["reached_target_stderr"] and 2 <= s["estimates"] < 1000
          and s["mean_standard_error"] < 0.05 * 1.0001 and "--target-stderr" in r.stderr,
          f"--target-stderr 0.05 ({r.stderr.strip()} {s})")

    # --cropwindow as pbrt: fractions x0 x1 y0 y1 of the film, pixels ceil(W x0)..ceil(W x1);
    # the image is the crop. Its pixels estimate the same values as the same pixels of the full
    # film: region means agree within 5 standard errors (the renders are independent).
    full, crop = os.path.join(tmp, "full.exr"), os.path.join(tmp, "crop.exr")
    for integrator in ("pt", "bdpt"):
        common = ["--integrator", integrator, "--eye-vertices", "5", "--spp", "32", "--width",
                  "64", "--height", "64", "-q"]
        r1 = run("render", scene, "-o", full, *common)
        r2 = run("render", scene, "-o", crop, "--seed", "5", "--cropwindow", "0.1", "0.6", "0.5",
                 "1", "--stats", stats, *common)
        check(r1.returncode == 0 and r2.returncode == 0, f"crop renders ({r1.stderr}{r2.stderr})")
        s = json.load(open(stats))
        image, error = cr.read_exr(crop), cr.read_exr(crop, "stderr")
        check((s["width"], s["height"], s["pixel_bounds"]) == (32, 32, [7, 39, 32, 64])
              and image.shape == (32, 32, 3), f"crop size and bounds ({s}, {image.shape})")
        whole, whole_error = cr.read_exr(full), cr.read_exr(full, "stderr")
        part, part_error = whole[32:64, 7:39], whole_error[32:64, 7:39]
        for name, rows, cols in (("left", slice(0, 32), slice(0, 16)),
                                 ("right", slice(0, 32), slice(16, 32))):
            a, b = image[rows, cols].mean(axis=(0, 1)), part[rows, cols].mean(axis=(0, 1))
            n = image[rows, cols].shape[0] * image[rows, cols].shape[1]
            se = np.sqrt((error[rows, cols] ** 2).sum(axis=(0, 1))
                         + (part_error[rows, cols] ** 2).sum(axis=(0, 1))) / n
            check(bool(np.all(np.abs(a - b) < 5 * se)) and float(a.mean()) > 0.01,
                  f"{integrator} crop {name} half matches the full film's pixels ({a} vs {b}, "
                  f"standard error {se})")
    # The file's Film "cropwindow" is the default crop; at another --width/--height, the same
    # fractions of the new film.
    windowed = os.path.join(tmp, "windowed.pbrt")
    with open(windowed, "w") as f:
        f.write('Film "rgb" "integer xresolution" 64 "integer yresolution" 64 '
                '"float cropwindow" [0.1 0.6 0.5 1]\nWorldBegin\nLightSource "point"\n'
                'Shape "sphere" "float radius" 0.5\n')
    for size, bounds in ((["-q"], [7, 39, 32, 64]),
                         (["--width", "32", "--height", "32", "-q"], [4, 20, 16, 32])):
        r = run("render", windowed, "-o", os.path.join(tmp, "w.exr"), "--spp", "1",
                "--stats", stats, *size)
        s = json.load(open(stats)) if r.returncode == 0 else {}
        check(r.returncode == 0 and s.get("pixel_bounds") == bounds,
              f"the file's crop window {size}: {s.get('pixel_bounds')} ({r.stderr.strip()})")
    # compare refuses two crops of the same size over different film pixels.
    other = os.path.join(tmp, "crop2.exr")
    r = run("render", scene, "-o", other, "--cropwindow", "0.4", "0.9", "0.5", "1", *common)
    r2 = run("compare", crop, other)
    check(r.returncode == 0 and r2.returncode != 0 and "different film pixels" in r2.stderr
          and "7 39 32 64" in r2.stderr, f"compare refuses other crops ({r2.stderr.strip()})")
    r2 = run("compare", crop, crop)
    check(r2.returncode == 0, f"compare takes a crop against itself ({r2.stderr.strip()})")

    # Kernel diagnosis (docs/gpu.md): extra build options reach the compiler and the build log is
    # printed; CBDPT_KERNEL_DIR replaces an embedded kernel file by the folder's copy.
    env = dict(os.environ, CBDPT_KERNEL_OPTIONS="-DCB_DIAGNOSIS_PROBE=1", CBDPT_KERNEL_LOG="1")
    r = run("render", scene, "-o", out, *small, env=env)
    check(r.returncode == 0 and "OpenCL build log of pt.cl" in r.stderr
          and "-DCB_DIAGNOSIS_PROBE=1" in r.stderr,
          f"CBDPT_KERNEL_OPTIONS and CBDPT_KERNEL_LOG ({r.stderr.strip()[:300]})")
    kernel_dir = os.path.join(tmp, "kernels")
    os.makedirs(kernel_dir, exist_ok=True)
    with open(os.path.join(kernel_dir, "pt.cl"), "w") as f:
        f.write('#error "pt.cl from CBDPT_KERNEL_DIR"\n')
    r = run("render", scene, "-o", out, *small, env=dict(os.environ, CBDPT_KERNEL_DIR=kernel_dir))
    check(r.returncode != 0 and "pt.cl from CBDPT_KERNEL_DIR" in r.stderr,
          f"CBDPT_KERNEL_DIR replaces pt.cl ({r.stderr.strip()[:300]})")
    # A device that writes a light-tracing splat outside the image is refused by name, not
    # followed past the image's end.
    with open(os.path.join(root, "kernels", "bdpt.cl")) as f:
        bdpt = f.read()
    splat = "splatRaster[2 * slot + 0] = rx;"
    check(splat in bdpt, "bdpt.cl writes its splat points as this test expects")
    with open(os.path.join(kernel_dir, "bdpt.cl"), "w") as f:
        f.write(bdpt.replace(splat, "splatRaster[2 * slot + 0] = (float)camera->width + 5.0f;"))
    r = run("render", scene, "-o", out, "--integrator", "bdpt", "--spp", "1", *small,
            env=dict(os.environ, CBDPT_KERNEL_DIR=kernel_dir))
    check(r.returncode != 0 and "outside the 16 x 16 image's pixel filters" in r.stderr,
          f"a splat outside the image is refused ({r.stderr.strip()[:300]})")

    # A file that is not a scene is named for what it is, and no message prints raw bytes.
    r = run("info", out)
    check(r.returncode != 0 and "is an OpenEXR image, not a pbrt scene" in r.stderr
          and printable(r.stderr), f"info IMAGE.exr says what it is ({r.stderr.strip()})")
    r = run("render", os.path.join(tmp, "o.png"), *small)
    check(r.returncode != 0 and "image, not a pbrt scene" in r.stderr and printable(r.stderr),
          f"render IMAGE says what it is ({r.stderr.strip()})")
    garbage = os.path.join(tmp, "garbage.pbrt")
    with open(garbage, "wb") as f:
        f.write(b"WorldBegin\nSha\x1b[2J\xff\xfepe \"sphere\"\n")
    r = run("render", garbage, *small)
    check(r.returncode != 0 and "garbage.pbrt:2:1" in r.stderr and "\\x1b" in r.stderr
          and printable(r.stderr), f"stray bytes are escaped in messages ({r.stderr.strip()})")

    # Options that used to be accepted and then misread, ignored or refused late.
    sixteen = ["--width", "16", "--height", "16"]
    full_ref, crop_ref = os.path.join(tmp, "ref16.exr"), os.path.join(tmp, "ref8.exr")
    crop = ["--cropwindow", "0", "0.5", "0", "0.5"]
    run("render", scene, *sixteen, "--spp", "4", "-q", "-o", full_ref)
    run("render", scene, *sixteen, *crop, "--spp", "4", "-q", "-o", crop_ref)
    log = os.path.join(tmp, "crop.csv")
    r = run("render", scene, *sixteen, *crop, "--spp", "2", "-q", "-o", out, "--reference",
            crop_ref, "--log", log)
    check(r.returncode == 0 and os.path.exists(log),
          f"--cropwindow measures against a reference of the crop's size ({r.stderr.strip()})")
    r = run("render", scene, *sixteen, *crop, "--spp", "2", "-q", "-o", out, "--reference",
            full_ref)
    check(r.returncode == 1 and "is 16x16 but the image is 8x8" in r.stderr,
          f"--cropwindow refuses a reference of the film's size ({r.stderr.strip()})")
    r = run("render", scene, *small, "--integrator", "pt", "--strategy", "2,3", "-o", out)
    check(r.returncode == 1 and "pt does not take it" in r.stderr,
          f"pt refuses --strategy ({r.stderr.strip()})")
    stats = os.path.join(tmp, "tiny.json")
    r = run("render", scene, *small, "--time", "0.000001", "-q", "-o", out, "--stats", stats)
    check(r.returncode == 0 and json.load(open(stats))["estimates"] == 1,
          f"a time budget shorter than one estimate still renders one ({r.stderr.strip()})")
    r = run("render", scene, *small, "--spp", str(2 ** 32 + 1), "-o", out)
    check(r.returncode == 2 and "--spp" in r.stderr,
          f"--spp past 2^32 is a command-line error ({r.returncode}: {r.stderr.strip()})")
    maxdepth = os.path.join(root, "scenes", "pbrt-v4", "cornell-box.pbrt")
    r = run("render", maxdepth, *sixteen, "--spp", "1", "--integrator", "bdpt", "--max-vertices",
            "0", "-q", "-o", out, "--stats", stats)
    s = json.load(open(stats)) if r.returncode == 0 else {}
    check(s.get("max_vertices") == 0,
          f"--max-vertices 0 turns off the scene's maxdepth cap ({r.stderr.strip()} {s})")
    for args, what in ((["--split-budget", "1", scene, "--width", "-5"], "--width"),
                       (["a.exr", "b.exr", "--how", "bogus"], "unknown combination 'bogus'"),
                       (["--split-budget", "-1", scene], "--split-budget")):
        r = run("combine", *args, "-o", out)
        check(r.returncode == 2 and what in r.stderr,
              f"combine {' '.join(args)}: a command-line error ({r.returncode}: {r.stderr})")

finish()
