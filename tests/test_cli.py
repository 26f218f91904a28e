#!/usr/bin/env python3
"""End-to-end tests of the cbdpt command line: render writes EXR, PNG and statistics; Ctrl-C
mid-render writes the estimates done; bad requests fail with a clear message and exit code.

Usage: test_cli.py PATH/TO/cbdpt REPO_ROOT"""
import json
import os
import signal
import subprocess
import sys
import tempfile
import time

cbdpt, root = sys.argv[1], sys.argv[2]
scene = os.path.join(root, "scenes", "cornell-box.pbrt")
failures = []
passed = 0


def check(condition, message):
    global passed
    if condition:
        passed += 1
    else:
        failures.append(message)
        print("FAIL:", message)


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
    check(not any(n.startswith(".") for n in os.listdir(tmp)), "no temporary files left behind")

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
        if integrator == "mlt":
            check(0 < s["mlt"]["acceptance_rate"] < 1 and s["mlt"]["mutations"] > 0,
                  f"mlt statistics in the stats file ({s.get('mlt')})")

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
    check(r.returncode == 0 and open(full, "rb").read() == open(part, "rb").read(),
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
    check(r.returncode == 0 and open(full, "rb").read() == open(part, "rb").read(),
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
        f.write("WorldBegin\nShape \"disk\"\n")
    r = subprocess.run([cbdpt, "render", bad], capture_output=True, text=True)
    check(r.returncode != 0 and "bad.pbrt:2:" in r.stderr,
          f"unknown shape names file and line ({r.stderr.strip()})")
    r = subprocess.run([cbdpt, "render", scene, "--width", "1000000", "--height", "1000000"],
                       capture_output=True, text=True)
    check(r.returncode != 0 and "resolution" in r.stderr, f"absurd resolution refused ({r.stderr.strip()})")
    r = subprocess.run([cbdpt, "render", scene, "--spp", "0"], capture_output=True, text=True)
    check(r.returncode != 0 and "--spp" in r.stderr, f"zero estimates refused ({r.stderr.strip()})")
    r = subprocess.run([cbdpt, "render", scene, "--eye-vertices", "1"], capture_output=True, text=True)
    check(r.returncode != 0 and "eye-vertices" in r.stderr, f"eye cap 1 refused ({r.stderr.strip()})")
    r = subprocess.run([cbdpt, "render", os.path.join(tmp, "missing.pbrt")], capture_output=True, text=True)
    check(r.returncode != 0 and "missing.pbrt" in r.stderr, f"missing file named ({r.stderr.strip()})")
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
    check(r.returncode == 0 and "triangles" in r.stdout and "spectral-16" in r.stdout,
          f"info describes the scene ({r.stdout.strip()})")

print(f"{passed} passed, {len(failures)} failed")
sys.exit(1 if failures else 0)
