#!/usr/bin/env python3
"""End-to-end test of error against time: checkpoints, logs (CSV and JSON), the
reference metrics, `cbdpt compare`, and the scripts/experiment --quick -> scripts/report
pipeline, on tiny Cornell box renders.

Usage: test_checkpoints.py PATH/TO/cbdpt REPO_ROOT"""
import json
import math
import os
import re
import shutil
import subprocess
import sys
import tempfile

cbdpt, root = os.path.abspath(sys.argv[1]), os.path.abspath(sys.argv[2])
scene = os.path.join(root, "scenes", "cornell-box.pbrt")
sys.path.insert(0, os.path.join(root, "scripts"))
import cbdpt_results as cr  # noqa: E402
import numpy as np  # noqa: E402
from checks import check, finish, load_script  # noqa: E402

COLUMNS = ["estimates", "seconds", "rmse", "rel_mse", "mae", "mean_stderr", "rms_stderr",
           "image_mean", "checkpoint_seconds", "cpu_seconds"]


def render(*args):
    r = subprocess.run([cbdpt, "render", scene, "-q"] + [str(a) for a in args],
                       capture_output=True, text=True)
    return r


with tempfile.TemporaryDirectory() as tmp:
    P = lambda name: os.path.join(tmp, name)  # noqa: E731
    size = ["--width", "32", "--height", "32"]

    # A small reference: PT, 2048 estimates, its own seed.
    r = render(*size, "--spp", 2048, "--seed", 99, "-o", P("ref.exr"), "--png", P("ref.png"))
    check(r.returncode == 0, f"reference renders ({r.stderr})")
    floor = cr.read_exr(P("ref.exr"), "stderr")
    floor_rms = float(((floor.astype(float)) ** 2).mean() ** 0.5)

    # Checkpoints against the reference, CSV log and checkpoint images.
    r = render(*size, "--checkpoints", "1,2,4,8,16", "--reference", P("ref.exr"), "--log",
               P("log.csv"), "--checkpoint-images", P("ck"), "-o", P("a.exr"), "--png",
               P("a.png"), "--stats", P("a.json"), "--seed", 5)
    check(r.returncode == 0, f"checkpoint render exits 0 ({r.stderr})")
    header, rows = cr.read_log(P("log.csv"))
    with open(P("log.csv")) as f:
        column_line = [l for l in f if not l.startswith("#")][0].strip().split(",")
    check(column_line == COLUMNS, f"log columns {column_line}")
    check(list(rows["estimates"]) == [1, 2, 4, 8, 16], f"one row per checkpoint {rows['estimates']}")
    for key in ("scene_load_seconds", "kernel_build_seconds", "warmup_seconds"):
        check(key in header and float(header[key]) >= 0, f"header logs {key} ({header.get(key)})")
    check(float(header["rel_mse_epsilon"]) == 0.01, "header states the relative-MSE epsilon")
    check(abs(float(header["reference_rms_stderr"]) - floor_rms) < 1e-6 * max(1, floor_rms) + 1e-9,
          f"header logs the reference's noise floor {header['reference_rms_stderr']} vs {floor_rms}")
    t = rows["seconds"]
    check(all(b > a for a, b in zip(t, t[1:])) and t[0] > 0, f"render time increases {t}")
    for key in ("rmse", "rel_mse", "mae", "image_mean"):
        check(all(math.isfinite(v) and v >= 0 for v in rows[key]), f"{key} finite {rows[key]}")
    check(math.isnan(rows["mean_stderr"][0]), "no standard error from one estimate")
    check(all(math.isfinite(v) and v > 0 for v in rows["mean_stderr"][1:]),
          f"standard error finite from 2 estimates {rows['mean_stderr']}")
    # RMSE of the mean of n i.i.d. estimates falls as 1/sqrt(n): from 1 to 16 estimates by 4x,
    # plus the reference's small noise. Requiring only a 1.6x drop leaves room for heavy tails.
    rmse = rows["rmse"]
    check(rmse[-1] < rmse[0] / 1.6, f"RMSE falls with estimates: {rmse[0]:.4g} -> {rmse[-1]:.4g}")
    check(rows["rel_mse"][-1] < rows["rel_mse"][0], "relative MSE falls with estimates")
    check(rows["mean_stderr"][-1] < rows["mean_stderr"][1], "standard error falls with estimates")
    # Unbiased PT: the noise-corrected RMSE should match the self-reported RMS standard error
    # within a generous factor (both are noisy estimates of the same quantity at 16 estimates).
    corrected = math.sqrt(max(rmse[-1] ** 2 - floor_rms ** 2, 0))
    check(rows["rms_stderr"][-1] / 2.5 < corrected < rows["rms_stderr"][-1] * 2.5,
          f"RMSE {corrected:.4g} agrees with the standard error {rows['rms_stderr'][-1]:.4g}")
    images = sorted(os.listdir(P("ck")))
    check(images == [f"a-{n:08d}.exr" for n in (1, 2, 4, 8, 16)], f"checkpoint images {images}")
    stats = json.load(open(P("a.json")))
    check(abs(stats["rmse"] - rmse[-1]) <= 1e-6 * rmse[-1], "stats carry the final RMSE")
    check(stats["render_seconds"] >= t[-1] * 0.999, "stats render time covers the checkpoints")

    # `compare` agrees with the log's last row, draws a difference PNG, refuses size mismatches.
    r = subprocess.run([cbdpt, "compare", P("a.exr"), P("ref.exr"), "--json", "--diff-png",
                        P("d.png")], capture_output=True, text=True)
    check(r.returncode == 0, f"compare exits 0 ({r.stderr})")
    c = json.loads(r.stdout)
    for key in ("rmse", "rel_mse", "mae"):
        check(abs(c[key] - rows[key][-1]) <= 1e-6 * rows[key][-1], f"compare {key} = log {key}")
    check(abs(c["mean_stderr"] - rows["mean_stderr"][-1]) <= 1e-5 * rows["mean_stderr"][-1],
          "compare reads the stderr layer")
    with open(P("d.png"), "rb") as f:
        check(f.read(8) == b"\x89PNG\r\n\x1a\n", "difference PNG written")
    r = subprocess.run([cbdpt, "compare", P("a.exr"), P("a.exr")], capture_output=True, text=True)
    check(r.returncode == 0 and "rmse            0\n" in r.stdout, f"self-compare is zero ({r.stdout})")
    render("--width", 16, "--height", 8, "--spp", 1, "-o", P("small.exr"), "--png", P("s.png"))
    r = subprocess.run([cbdpt, "compare", P("small.exr"), P("ref.exr")], capture_output=True, text=True)
    check(r.returncode != 0 and "small.exr is 16x8" in r.stderr and
          "the reference " + P("ref.exr") + " is 32x32" in r.stderr,
          f"size mismatch names both files and sizes ({r.stderr.strip()})")
    r = render("--width", 16, "--height", 16, "--reference", P("ref.exr"), "--checkpoints", "1,2")
    check(r.returncode != 0 and "32x32" in r.stderr and "16x16" in r.stderr,
          f"render refuses a reference of another size ({r.stderr.strip()})")

    # JSON log, no reference: the log is still written, reference metrics are null.
    r = render(*size, "--checkpoints", "1,3", "--log", P("log.json"), "-o", P("b.exr"), "--png",
               P("b.png"))
    check(r.returncode == 0, f"render without reference exits 0 ({r.stderr})")
    j = json.load(open(P("log.json")))
    check(j["columns"] == COLUMNS and [row["estimates"] for row in j["checkpoints"]] == [1, 3],
          f"JSON log rows {j.get('checkpoints')}")
    check(all(row["rmse"] is None for row in j["checkpoints"]), "no reference: RMSE is null")
    check(j["checkpoints"][1]["mean_stderr"] > 0, "no reference: standard error still logged")

    # Checkpoints by time, with a time budget: rows at least every 0.3 s, the last at the budget.
    r = render(*size, "--time", 1.0, "--checkpoint-every", 0.3, "--reference", P("ref.exr"),
               "--log", P("time.csv"), "-o", P("c.exr"), "--png", P("c.png"))
    check(r.returncode == 0, f"timed render exits 0 ({r.stderr})")
    _, trows = cr.read_log(P("time.csv"))
    ts = trows["seconds"]
    check(len(ts) >= 4 and all(ts[i] >= 0.3 * (i + 1) for i in range(len(ts) - 1)) and ts[-1] >= 1.0,
          f"time checkpoints at multiples of 0.3 s and the budget: {list(ts)}")

    # Bad requests.
    r = render(*size, "--checkpoints", "4,2")
    check(r.returncode != 0 and "increasing" in r.stderr, f"decreasing list refused ({r.stderr.strip()})")
    r = render(*size, "--log", P("x.txt"))
    check(r.returncode != 0 and ".csv or .json" in r.stderr, f"bad log name refused ({r.stderr.strip()})")

    # The pipeline: scripts/experiment --quick in units, then scripts/report. PT and CBDPT only
    # (BDPT and CPT share the machinery), the two methods the combination units combine, so
    # that it stays a few minutes on a loaded machine.
    units, images = P("units"), P("images")
    experiment = [sys.executable, os.path.join(root, "scripts", "experiment"), "--quick",
                  "--cbdpt", cbdpt, "--units", units, "--images", images, "--methods", "pt",
                  "cbdpt"]
    # --configs keeps only the configurations named.
    r = subprocess.run(experiment + ["--list", "--configs", "n8"], capture_output=True, text=True)
    listed = [line.split()[1] for line in r.stdout.splitlines() if line.startswith("  ")]
    check(r.returncode == 0 and listed and all("/n8/" in uid for uid in listed),
          f"--configs n8 lists only n8 units ({listed})")
    # What a killed attempt of a unit left: its periodic state (no image shows it, so cbdpt would
    # refuse to start over it) and a checkpoint image of its own. A unit starts from scratch.
    stale = os.path.join(images, "cornell-box", "n8", "pt", "time-seed1")
    os.makedirs(stale)
    shutil.copy(P("ref.exr"), os.path.join(stale, "time-seed1-99999999.exr"))
    with open(stale + ".exr.state", "wb") as f:
        f.write(b"left by a killed attempt")
    r = subprocess.run(experiment + ["--seeds", "1"], capture_output=True, text=True)
    check(r.returncode == 0, f"experiment --quick exits 0 ({r.stdout[-500:]} {r.stderr[-500:]})")
    check(not os.path.exists(stale + ".exr.state"), "a killed attempt's state is gone")
    records = {}
    for dirpath, _, files in os.walk(units):
        for name in files:
            if name.endswith(".json"):
                rec = json.load(open(os.path.join(dirpath, name)))
                records[rec["id"]] = rec
    combine_ids = {f"cornell-box/{config}/combine/{name}-seed1" for config in ("4+4", "n8")
                   for name in ("pt-cbdpt-share0.25", "pt-cbdpt-share0.5", "cbdpt-x4")}
    check({"cornell-box/n8/pt/time-seed1", "cornell-box/4+4/cbdpt/time-seed1",
           "cornell-box/n8/cbdpt/thesis-seed1"} | combine_ids <= set(records),
          f"units written ({sorted(records)})")
    pt_unit = records.get("cornell-box/n8/pt/time-seed1", {})
    check("99999999" not in pt_unit.get("flip", {}) and
          pt_unit.get("spectrum", {}).get("estimates") != 99999999,
          f"a killed attempt's checkpoint image is not in the unit's record ({pt_unit.get('flip')})")
    for uid, rec in records.items():
        check(rec["status"] == "done" and rec["machine"]["cores"] >= 1 and
              len(rec["load_before"]) == 3 and rec["process_cpu_seconds"] > 0,
              f"{uid}: done, with machine, load and CPU seconds ({rec})")
        # The speed probe: an estimate of a 128x128 PT render takes milliseconds of wall and CPU
        # time. No ratio of the two is asserted: on a loaded machine the render waits for a core,
        # and the CPU seconds include the first estimate's kernel compilation.
        probe = rec["speed_probe"]
        check(1e-5 < probe["seconds_per_estimate"] < 1.0 and
              0 < probe["cpu_seconds_per_estimate"] < 1.0,
              f"{uid}: the speed probe's wall and CPU seconds per estimate ({probe})")
        _, lrows = cr.read_log(os.path.join(units, uid + ".csv"))
        check(len(lrows["estimates"]) >= 3, f"{uid}: log has checkpoint rows")
        if rec["kind"] == "time":
            check(all(math.isfinite(v) for v in lrows["rmse"]), f"{uid}: finite RMSE rows")
            check(abs(lrows["seconds"][-1] - 2.0) < 0.5, f"{uid}: ends at the 2 s budget")
            check(len(rec.get("flip", {})) >= 3 and len(rec["spectrum"]["power"]) >= 4,
                  f"{uid}: FLIP per checkpoint and the error spectrum recorded")
        if rec["kind"] == "combine":
            # Every input and every combination measured, at the split budget's CPU seconds.
            hows = (["0-pt", "1-cbdpt", "mean", "inverse-variance", "inverse-variance-naive",
                     "guided"] if rec["share"] is not None else
                    [f"{i}-cbdpt" for i in range(4)] + ["median", "reject", "mean"])
            images = rec.get("images", {})
            check(sorted(images) == sorted(hows) and list(lrows["image"]) == list(images),
                  f"{uid}: one CSV row per image ({sorted(images)})")
            for how, m in images.items():
                check(all(math.isfinite(m[k]) and m[k] >= 0 for k in ("rmse", "rel_mse", "flip"))
                      and math.isfinite(m["bias"]) and len(m["spectrum"]["power"]) >= 4,
                      f"{uid} {how}: finite RMSE, relative MSE, FLIP, bias and spectrum ({m})")
            parts = [m["cpu_seconds"] for how, m in images.items() if how[0].isdigit()]
            check(all(p > 0 for p in parts) and
                  abs(images[hows[-1]]["cpu_seconds"] - sum(parts)) < 1e-6 * sum(parts) + 1e-9,
                  f"{uid}: a combination costs its inputs' CPU seconds ({parts})")
            check(rec["budget"] == 0.5 and abs(sum(m["seconds"] for how, m in images.items()
                                                   if how[0].isdigit()) - 0.5) < 0.25,
                  f"{uid}: the inputs share the 0.5 s split budget")
    # Units already done are skipped: a second run with one more seed runs only the new ones.
    before = {uid: rec["started"] for uid, rec in records.items()}
    r = subprocess.run(experiment + ["--seeds", "1", "2", "--kinds", "time", "--no-probe"],
                       capture_output=True, text=True)
    check(r.returncode == 0 and "[1/" in r.stdout, f"second experiment run ({r.stdout[-800:]})")
    ran = [line for line in r.stdout.splitlines() if line.startswith("experiment: [")]
    check(all("seed2" in line for line in ran) and len(ran) == 3,
          f"only the seed-2 units ran the second time ({ran})")
    for line in ran:
        uid = line.split()[-1]
        rec = json.load(open(os.path.join(units, uid + ".json")))
        check(rec["speed_probe"] is None, f"{uid}: --no-probe records no probe")
    for uid, started in before.items():
        rec = json.load(open(os.path.join(units, uid + ".json")))
        check(rec["started"] == started, f"{uid} was not run again")
    # --same-revision redoes the units another revision ran, and only those.
    moved = "cornell-box/n8/pt/time-seed1"
    path = os.path.join(units, moved + ".json")
    rec = json.load(open(path))
    json.dump(dict(rec, revision="0000000"), open(path, "w"))
    listing = experiment + ["--seeds", "1", "2", "--kinds", "time", "--list"]
    todo = {}
    for extra in ([], ["--same-revision"]):
        r = subprocess.run(listing + extra, capture_output=True, text=True)
        todo[bool(extra)] = [line.split()[1] for line in r.stdout.splitlines()
                             if line.startswith("  todo")]
    check(todo == {False: [], True: [moved]},
          f"--same-revision lists only the unit of another revision as to do ({todo})")
    # ... and the units another CPU model ran: equal-time curves must share a machine.
    other = "cornell-box/n8/pt/time-seed2"
    other_path = os.path.join(units, other + ".json")
    other_rec = json.load(open(other_path))
    json.dump(dict(rec, machine=dict(rec["machine"], cpu="another CPU")), open(path, "w"))
    json.dump(dict(other_rec, machine=dict(other_rec["machine"], cpu="another CPU")),
              open(other_path, "w"))
    for extra in ([], ["--same-revision"]):
        r = subprocess.run(listing + extra, capture_output=True, text=True)
        todo[bool(extra)] = [line.split()[1] for line in r.stdout.splitlines()
                             if line.startswith("  todo")]
    check(todo == {False: [], True: [moved, other]},
          f"--same-revision lists the units another CPU ran as to do ({todo})")
    json.dump(other_rec, open(other_path, "w"))
    json.dump(rec, open(path, "w"))
    # A unit interrupted mid-render (here its render kills the experiment) leaves the unit's log
    # and record as they were: the render logs to a part file, which replaces the log only
    # when the unit is done.
    killer = P("cbdpt-killed-mid-unit")
    with open(killer, "w") as f:
        f.write('#!/bin/sh\n[ "$1" = --version ] && { echo "cbdpt 0.1 (git 0000000)"; exit 0; }\n'
                f'case " $* " in *" --log "*) ;; *) exec "{os.path.abspath(cbdpt)}" "$@" ;; esac\n'
                'for a; do [ "$prev" = --log ] && echo partial > "$a"; prev=$a; done\n'
                'kill -9 $PPID; sleep 1; exit 1\n')
    os.chmod(killer, 0o755)
    log = os.path.join(units, moved + ".csv")
    kept = (open(log).read(), open(path).read())
    r = subprocess.run([sys.executable, os.path.join(root, "scripts", "experiment"), "--quick",
                        "--cbdpt", killer, "--units", units, "--methods", "pt", "--seeds", "1",
                        "--kinds", "time", "--configs", "n8", "--same-revision"],
                       capture_output=True, text=True)
    check(r.returncode != 0 and "[1/" in r.stdout and (open(log).read(), open(path).read()) == kept,
          f"an interrupted unit leaves its log and record as they were ({r.returncode} "
          f"{r.stdout[-300:]} {r.stderr[-300:]})")
    # A grown reference: the units measured against it are to do again, the others are not,
    # and --reference-errors measures the new file's error (its SHA-256 recorded).
    reference = os.path.join(os.path.dirname(units), "images", "reference-pt-n8.exr")
    errors_json = os.path.join(units, "cornell-box", "n8", "pt", "reference-error.json")
    original = open(reference, "rb").read()
    cr.write_exr(reference, {"": cr.read_exr(reference) * 1.001,
                             "stderr": cr.read_exr(reference, "stderr")})
    r = subprocess.run(listing, capture_output=True, text=True)
    todo = [line.split()[1] for line in r.stdout.splitlines() if line.startswith("  todo")]
    check(todo == ["cornell-box/n8/pt/time-seed1", "cornell-box/n8/pt/time-seed2"],
          f"a changed reference makes its units, and only those, to do ({todo})")
    for content in (None, original):
        if content:
            open(reference, "wb").write(content)
        r = subprocess.run(experiment + ["--seeds", "1", "2", "--reference-errors"],
                           capture_output=True, text=True)
        m = json.load(open(errors_json)) if os.path.exists(errors_json) else {}
        check(r.returncode == 0 and "[1/" not in r.stdout and
              m.get("reference_sha256") == cr.file_sha256(reference),
              f"--reference-errors measures the reference as it is, running no unit ({m})")
    # The report lists a unit measured against another version of its reference.
    stale = os.path.join(units, "cornell-box", "n8", "cbdpt", "time-seed2.json")
    json.dump(dict(json.load(open(stale)), reference_sha256="0" * 64), open(stale, "w"))
    # With two seeds done, the reference's own error is measured from them, per method.
    path = os.path.join(units, "cornell-box", "n8", "pt", "reference-error.json")
    m = json.load(open(path)) if os.path.exists(path) else {}
    check(m.get("runs") == 2 and sorted(m.get("seeds", [])) == [1, 2] and
          math.isfinite(m.get("reference_mse", math.nan)) and m.get("runs_mse", 0) > 0,
          f"reference error measured from the PT seeds ({m})")
    # A measurement of the same reference from more runs (earlier sittings' images gone) is kept.
    json.dump(dict(m, runs=3, seeds=[1, 2, 3], reference_mse=1.0), open(path, "w"))
    r = subprocess.run(experiment + ["--seeds", "1", "2", "--reference-errors"],
                       capture_output=True, text=True)
    kept = json.load(open(path))
    check(r.returncode == 0 and kept["runs"] == 3 and kept["reference_mse"] == 1.0 and
          "kept the RMS error measured from 3 pt runs" in r.stdout,
          f"a measurement from more runs is not replaced by one from fewer ({r.stdout[-400:]})")
    json.dump(m, open(path, "w"))
    # The report aggregates what exists and lists what is missing (seeds 3 and 4 here).
    doc = P("results.md")
    r = subprocess.run([sys.executable, os.path.join(root, "scripts", "report"), "--units", units,
                        "--doc", doc, "--figures", P("fig"), "--scenes", "cornell-box",
                        "--verdict-cpu-seconds", "0.2"], capture_output=True, text=True)
    check(r.returncode == 0, f"report exits 0 ({r.stderr[-800:]})")
    text = open(doc).read() if os.path.exists(doc) else ""
    for needle in ("cornell-box/n8/pt/time-seed3", "cornell-box/4+4/cbdpt/time-seed4",
                   "power spectrum", "timing tables", "| 0.2 | RMSE |", "per-subpath caps",
                   "total-length cap N = 8", "## Combining pattern-prone and noisy renders",
                   "### The goal", "Not measured yet: units missing",
                   "cornell-box/4+4/combine/pt-cbdpt-share0.75-seed1",
                   "### PT's share of the split budget", "measured from 2 PT seeds",
                   "earlier version of their reference (1;", "cornell-box/n8/cbdpt/time-seed2"):
        check(needle in text, f"report has '{needle}'")
    # Every figure the doc shows is a PNG in --figures: error against time, the error spectrum
    # and the combined images' spectra, for each configuration (4+4 and n8).
    shown = re.findall(r"!\[[^]]*\]\(([^)]+)\)", text)
    kinds = sorted({os.path.basename(f).rsplit("-", 1)[0] for f in shown})

    def is_png(path):
        return os.path.isfile(path) and open(path, "rb").read(8) == b"\x89PNG\r\n\x1a\n"
    check(len(shown) == 6 and kinds == ["combine-spectrum-cornell-box", "error-time-cornell-box",
                                        "spectrum-cornell-box"] and
          all(is_png(os.path.join(tmp, f)) for f in shown),
          f"report draws and shows its figures ({shown})")
    # The speed probe: its spread over the units that ran it, and per unit a time or, for the
    # units run with --no-probe, a dash.
    probe_line = re.search(r"Speed probe \(.*?\): ([0-9.]+)-([0-9.]+) CPU ms per estimate over "
                           r"(\d+) units", text)
    check(probe_line is not None and 0 < float(probe_line[1]) <= float(probe_line[2]),
          f"report gives the speed probe's spread ({probe_line and probe_line[0]})")
    seed2_row = re.search(r"\| cornell-box/n8/pt/time-seed2 \| [^|]+ \| [^|]+ \| (\S+) \|", text)
    check(seed2_row is not None and seed2_row[1] == "—",
          f"a unit run with --no-probe has no probe time ({seed2_row and seed2_row[0]})")
    # The combination tables hold numbers: median [min–max] cells for the single methods at the
    # combined images' CPU seconds, each combination and each share; the goal is evaluated.
    rows = {}
    for line in text.splitlines():
        cells = [c.strip() for c in line.strip("|").split("|")]
        if line.startswith("| ") and len(cells) == 8:
            rows[(cells[0], cells[1])] = cells[2:]

    def numbers(cells):
        try:
            return [float(c.split(" [")[0]) for c in cells]
        except ValueError:
            return None
    for key in [("PT alone", "—"), ("CBDPT alone", "—"), ("guided", "0.5"), ("mean", "0.5"),
                ("inverse-variance", "0.25"), ("CBDPT x4: median", "—"), ("CBDPT x4: reject", "—")]:
        values = numbers(rows.get(key, ["x"]))
        check(values is not None and all(math.isfinite(v) for v in values) and
              all(v > 0 for v in values[:4]),
              f"combination table row {key} has numbers ({rows.get(key)})")
    check("| guided (share 0.5) | " in text and "of 1 |" in text,
          "the goal is checked per combination")

# cr.reference_error recovers a reference's error from independent runs: truth + white noise of
# known sigma. 4 runs of 3x128x128 values: the estimate of sigma_ref^2 has a relative standard
# error of 1.3% (200 seeds tried), so 10% is over 7 standard errors.
rng = np.random.default_rng(5)
truth = rng.uniform(0.1, 1.0, (128, 128, 3))
sigma_ref, sigma_runs = 0.02, [0.03, 0.03, 0.04, 0.05]
m = cr.reference_error(truth + rng.normal(0, sigma_ref, truth.shape),
                       [truth + rng.normal(0, s, truth.shape) for s in sigma_runs])
check(abs(m["reference_mse"] / sigma_ref ** 2 - 1) < 0.1 and m["runs"] == 4,
      f"reference error recovered: {m['reference_rms_error']:.4g} for sigma {sigma_ref}")
check(abs(m["runs_mse"] / np.mean(np.square(sigma_runs)) - 1) < 0.1,
      f"runs' own MSE recovered: {m['runs_mse']:.4g}")
try:
    cr.reference_error(truth, [truth])
    check(False, "one run is refused")
except ValueError as e:
    check("2 or more runs" in str(e), f"one run is refused ({e})")

# Every reference an experiment unit measures against is one scripts/make-reference makes.
experiment = load_script(os.path.join(root, "scripts", "experiment"), "experiment")
make_reference = load_script(os.path.join(root, "scripts", "make-reference"), "make_reference")
needed = {cr.reference_path(u["scene"], *experiment.reference_of(u)[::-1])
          for u in experiment.plan(list(cr.SCENES), cr.ALL_METHODS, [1], ["time", "combine"],
                                   False)}
made = {cr.reference_path(*r) for r in make_reference.planned_references(list(cr.SCENES))}
check(needed == made, f"references needed {sorted(needed - made)} not made, "
      f"made {sorted(made - needed)} not needed")

finish()
