#!/usr/bin/env python3
"""End-to-end tests of renders that scale and survive: shards (--estimates) merged with
`cbdpt merge` equal one render bit for bit (PT, CPT, BDPT, CBDPT); a render killed with SIGKILL
resumes from its periodic state and ends where an uninterrupted one ends; outputs are checked
before rendering and a failed final write keeps the state; bad states and bad requests are
refused with clear messages and leave files on disk untouched. With --mpi MPIRUN, the same
estimates rendered by 2 MPI ranks equal the single-process render.

Usage: test_scale.py PATH/TO/cbdpt REPO_ROOT [--mpi MPIRUN]"""
import argparse
import json
import os
import random
import re
import shutil
import signal
import subprocess
import sys
import tempfile
import time

parser = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
parser.add_argument("cbdpt")
parser.add_argument("root")
parser.add_argument("--mpi", help="mpirun command: run only the MPI checks")
args = parser.parse_args()
cbdpt = os.path.abspath(args.cbdpt)
scene = os.path.join(args.root, "scenes", "cornell-box.pbrt")
sys.path.insert(0, os.path.join(args.root, "scripts"))
import cbdpt_results as cr  # noqa: E402
from checks import check, finish  # noqa: E402
SIZE = ["--width", "16", "--height", "12"]
METHODS = {"pt": ["--eye-vertices", "4"], "cpt": ["--eye-vertices", "4", "--coherence-tile", "2"],
           "bdpt": ["--eye-vertices", "3", "--light-vertices", "3"],
           "cbdpt": ["--eye-vertices", "3", "--light-vertices", "3"]}


def run(*a, prefix=(), **kw):
    return subprocess.run(list(prefix) + [cbdpt] + [str(x) for x in a], capture_output=True,
                          text=True, **kw)


def render(out, *a, method="pt", prefix=(), **kw):
    return run("render", scene, "-q", *SIZE, "--integrator", method, *METHODS[method], "-o", out,
               *a, prefix=prefix, **kw)


def data(path):
    with open(path, "rb") as f:
        return f.read()


def pixels(path):
    """Every layer's bytes (the headers differ: they record each run's render time)."""
    return [cr.read_exr(path, layer).tobytes()
            for layer in ("", "stderr", "half0", "half0.stderr", "half1", "half1.stderr")]


def fnv_words(data):
    """The state's checksum (src/image/render_state.cpp): FNV-1a over little-endian 64-bit
    words, the tail zero-padded, then the length."""
    prime, mask, h = 0x100000001b3, (1 << 64) - 1, 0xcbf29ce484222325
    padded = data + bytes(-len(data) % 8) if len(data) % 8 else data + bytes(8)
    for i in range(0, len(padded), 8):
        h = ((h ^ int.from_bytes(padded[i:i + 8], "little")) * prime) & mask
    return ((h ^ len(data)) * prime) & mask


def drop_halves(path):
    """Rewrites a render state as an earlier build wrote it: the full sums only."""
    raw = data(path)
    magic = b"cbdpt render state\n"
    at = len(magic) + 4
    header_len = int.from_bytes(raw[at:at + 8], "little")
    header = json.loads(raw[at + 8:at + 8 + header_len])
    assert header["halves"], path
    header["halves"] = False
    text = json.dumps(header, separators=(",", ":")).encode()
    body = raw[at + 8 + header_len:]
    values = int.from_bytes(body[:8], "little")
    full = body[:8 + values * 7 * 8]
    out = raw[:len(magic) + 4] + len(text).to_bytes(8, "little") + text + full
    with open(path, "wb") as f:
        f.write(out + fnv_words(out).to_bytes(8, "little"))


with tempfile.TemporaryDirectory() as tmp:
    P = lambda name: os.path.join(tmp, name)  # noqa: E731

    if args.mpi:
        # 2 ranks share the estimates; rank 0 writes the image of all of them.
        mpirun = args.mpi.split()
        for method in ("pt", "cbdpt"):
            r = render(P(f"one-{method}.exr"), "--spp", 7, method=method)
            check(r.returncode == 0, f"{method} single-process render ({r.stderr})")
            r = render(P(f"mpi-{method}.exr"), "--spp", 7, "--stats", P("mpi.json"),
                       "--keep-state", method=method, prefix=mpirun + ["-n", "2"])
            check(r.returncode == 0, f"{method} with 2 MPI ranks exits 0 ({r.stderr})")
            stats = json.load(open(P("mpi.json")))
            check(stats["processes"] == 2 and stats["estimates"] == 7 and
                  stats["estimate_ranges"] == "0:7",
                  f"{method}: 2 processes rendered estimates 0:7 ({stats})")
            # The last checkpoint's reduction is the image: finishing does not reduce again.
            check(stats["reductions"] == 1,
                  f"{method}: one reduction of the sums to rank 0 ({stats['reductions']})")
            check(pixels(P(f"mpi-{method}.exr")) == pixels(P(f"one-{method}.exr")),
                  f"{method}: 2 MPI ranks give the single-process image bit for bit")
        # A shard under MPI, merged with a single-process shard: the whole render.
        r = render(P("s1.exr"), "--estimates", "0:3", "--keep-state")
        r2 = render(P("s2.exr"), "--estimates", "3:7", "--keep-state", prefix=mpirun + ["-n", "2"])
        r3 = run("merge", P("s1.exr.state"), P("s2.exr.state"), "-o", P("s12.exr"), "-q")
        check(r.returncode == 0 and r2.returncode == 0 and r3.returncode == 0 and
              pixels(P("s12.exr")) == pixels(P("one-pt.exr")),
              f"an MPI shard merges with a single-process one ({r2.stderr} {r3.stderr})")
        # --resume under MPI: rank 0 reads the state, the ranks share the estimates left.
        r = render(P("res.exr"), "--spp", 4, "--keep-state")
        r2 = render(P("res.exr"), "--spp", 7, "--resume", prefix=mpirun + ["-n", "2"])
        check(r2.returncode == 0 and pixels(P("res.exr")) == pixels(P("one-pt.exr")),
              f"4 estimates resumed to 7 by 2 ranks equal the single-process render ({r2.stderr})")
        # A state without halves (an earlier build's): no rank keeps halves, the sums equal.
        r = render(P("old.exr"), "--spp", 4, "--keep-state")
        drop_halves(P("old.exr.state"))
        layers = ("", "stderr")
        try:
            r2 = render(P("old.exr"), "--spp", 7, "--resume", prefix=mpirun + ["-n", "2"],
                        timeout=120)
            ok = r2.returncode == 0 and (
                [cr.read_exr(P("old.exr"), x).tobytes() for x in layers] ==
                [cr.read_exr(P("one-pt.exr"), x).tobytes() for x in layers])
            detail = f"{r2.returncode}: {r2.stderr.strip()[-300:]}"
        except subprocess.TimeoutExpired:
            ok, detail = False, "still running after 120 s"
        check(ok, f"a state without halves resumed by 2 ranks equals the single-process render "
              f"({detail})")
        # A time budget and checkpoints across ranks: rank 0 decides, every row counts all ranks.
        r = render(P("t.exr"), "--time", 3, "--checkpoint-every", 1, "--log", P("t.csv"),
                   "--stats", P("t.json"), prefix=mpirun + ["-n", "2"])
        stats = json.load(open(P("t.json"))) if os.path.exists(P("t.json")) else {}
        check(r.returncode == 0 and stats.get("estimates", 0) > 0 and
              stats.get("estimate_ranges", "").startswith("0:"),
              f"--time under MPI ends on every rank and writes contiguous estimates ({r.stderr} "
              f"{stats})")
        check(os.path.exists(P("t.csv")), "rank 0 writes the checkpoint log")
        # Periodic saves every second for 6 s: process 0 decides each one for every rank (ranks
        # that timed saves on their own clocks met in different reductions and hung).
        try:
            r = render(P("saves.exr"), "--time", 6, "--save-state-every", 1, "--stats",
                       P("saves.json"), prefix=mpirun + ["-n", "2"], timeout=120)
            stats = json.load(open(P("saves.json"))) if os.path.exists(P("saves.json")) else {}
            ok = r.returncode == 0 and stats.get("estimates", 0) > 0
            detail = f"{r.returncode}: {r.stderr.strip()[-300:]} {stats.get('estimates')}"
        except subprocess.TimeoutExpired:
            ok, detail = False, "still running after 120 s"
        check(ok, f"an MPI render with a periodic save each second ends ({detail})")
        # Ranks that run other renders (another seed: other images summed; other checkpoints:
        # other collective calls) are refused before they render, naming why.
        for what, extra in (("seed", ["--seed", "5"]),
                            ("checkpoints", ["--checkpoints", "2,4", "--log", P("ck.csv")])):
            rank = ["render", scene, "-q", *SIZE, "--spp", "8", "-o", P("mix.exr")]
            command = mpirun + ["-n", "1", cbdpt, *rank, ":", "-n", "1", cbdpt, *rank, *extra]
            try:
                r = subprocess.run(command, capture_output=True, text=True, timeout=120)
                ok = r.returncode != 0 and "1 of 2 MPI ranks run another render" in r.stderr
                detail = f"{r.returncode}: {r.stderr.strip()[-300:]}"
            except subprocess.TimeoutExpired:
                ok, detail = False, "still running after 120 s"
            check(ok and not os.path.exists(P("mix.exr")),
                  f"a rank with another {what} is refused ({detail})")
        finish()

    # Shards merged in any order equal one render of the union, bit for bit, per method.
    for method in METHODS:
        r = render(P("full.exr"), "--spp", 9, "--keep-state", method=method)
        check(r.returncode == 0, f"{method} full render ({r.stderr})")
        cuts = [(0, 2), (2, 3), (3, 9)]
        for a, b in cuts:
            r = render(P(f"s{a}.exr"), "--estimates", f"{a}:{b}", "--keep-state", method=method)
            check(r.returncode == 0, f"{method} shard {a}:{b} ({r.stderr})")
        states = [P(f"s{a}.exr.state") for a, _ in cuts]
        for order in (states, states[::-1]):
            r = run("merge", *order, "-o", P("merged.exr"), "--state", P("merged.state"), "-q")
            check(r.returncode == 0, f"{method} merge ({r.stderr})")
            check(pixels(P("merged.exr")) == pixels(P("full.exr")),
                  f"{method}: shards merged ({'forward' if order == states else 'reversed'}) "
                  f"equal the full render bit for bit")
            check(data(P("merged.state")) == data(P("full.exr.state")),
                  f"{method}: the merged state equals the full render's state")

    # Merge refusals; a failed merge leaves an existing output untouched.
    with open(P("keep.exr"), "wb") as f:
        f.write(b"precious")
    s0, s2 = P("s0.exr.state"), P("s2.exr.state")
    render(P("seed.exr"), "--estimates", "3:5", "--seed", 4, "--keep-state", method="cbdpt")
    render(P("pt.exr"), "--estimates", "9:10", "--keep-state", method="pt")
    for name, states, expect in (
            ("itself", [s0, s0], "merging a state with itself"),
            ("overlap", [s0, P("merged.state")], "overlap"),
            ("other seed", [s2, P("seed.exr.state")], "seed: 0 there, 4 here"),
            ("other method", [s2, P("pt.exr.state")], "integrator: \"cbdpt\" there, \"pt\" here"),
            ("missing", [s0, P("none.state")],
             f"cannot read the render state {P('none.state')}: no such file"),
            ("a folder", [s0, P("")], "it is a folder, not a file")):
        r = run("merge", *states, "-o", P("keep.exr"))
        check(r.returncode != 0 and expect in r.stderr, f"merge {name} refused ({r.stderr.strip()})")
        check(data(P("keep.exr")) == b"precious", f"a refused merge ({name}) overwrites nothing")
    r = run("merge", s0, "-o", P("keep.exr"), "--state", P("keep.exr"))
    check(r.returncode != 0 and "one would overwrite the other" in r.stderr and
          data(P("keep.exr")) == b"precious", f"merge with --state = -o refused ({r.stderr})")

    # Kernels replaced through CBDPT_KERNEL_DIR (or built with CBDPT_KERNEL_OPTIONS) are other
    # kernels: their states do not merge with the embedded kernels' states.
    kernels = P("kernels")
    os.makedirs(kernels)
    with open(os.path.join(args.root, "kernels", "pt.cl")) as f:
        edited = f.read() + "\n/* edited */\n"
    with open(os.path.join(kernels, "pt.cl"), "w") as f:
        f.write(edited)
    for name, variable, value in (("dir", "CBDPT_KERNEL_DIR", kernels),
                                  ("options", "CBDPT_KERNEL_OPTIONS", "-DCB_UNUSED_PROBE=1")):
        r = render(P(f"k{name}.exr"), "--estimates", "9:10", "--keep-state", method="cbdpt",
                   env=dict(os.environ, **{variable: value}))
        r2 = run("merge", s0, P(f"k{name}.exr.state"), "-o", P("keep.exr"))
        check(r.returncode == 0 and r2.returncode != 0 and "kernel_sources" in r2.stderr,
              f"a state of kernels changed by {variable} does not merge ({r.stderr}{r2.stderr})")

    # Corrupted and truncated states through the command line: a clear error, no crash.
    good = data(s0)
    rng = random.Random(5)
    corpus = [good[:n] for n in sorted(rng.sample(range(len(good)), 40))]
    for _ in range(40):
        bad = bytearray(good)
        bad[rng.randrange(len(bad))] ^= 1 << rng.randrange(8)
        corpus.append(bytes(bad))
    corpus.append(b"cbdpt render state v1\n" + good[22:])
    bad_version = bytearray(good)
    bad_version[19] = 9
    corpus.append(bytes(bad_version))
    clean = 0
    for i, bad in enumerate(corpus):
        with open(P("bad.state"), "wb") as f:
            f.write(bad)
        r = run("merge", P("bad.state"), s2, "-o", P("keep.exr"))
        clean += (r.returncode == 1 and "is not a usable render state" in r.stderr and
                  data(P("keep.exr")) == b"precious")
    check(clean == len(corpus), f"{clean} of {len(corpus)} truncated/corrupted states refused "
                                f"cleanly")
    check("format version 9, this cbdpt reads version 3" in r.stderr,
          f"another version is named ({r.stderr.strip()})")

    # Bad requests: clear errors before anything is rendered or written.
    for name, extra, expect in (
            ("empty range", ["--estimates", "4:4"], "is empty"),
            ("reversed range", ["--estimates", "5:2"], "is empty"),
            ("range past --spp", ["--estimates", "0:20", "--spp", "16"], "outside the render"),
            ("malformed range", ["--estimates", "3"], "must be A:B"),
            ("mlt shard", ["--estimates", "0:2", "--integrator", "mlt"], "mlt"),
            ("negative save interval", ["--save-state-every", "-1"], "--save-state-every"),
            ("missing output folder", ["-o", P("no/such/a.exr")], "does not exist"),
            ("missing log folder", ["--log", P("no/such/a.csv")], "the log (--log)"),
            ("missing stats folder", ["--stats", P("no/such/a.json")], "the statistics"),
            ("output is a folder", ["-o", tmp + "/"], "output"),
            ("statistics over the image", ["--stats", P("keep.exr")],
             "the image (-o) and the statistics (--stats) are both"),
            ("mlt --keep-state", ["--integrator", "mlt", "--keep-state"],
             "--keep-state is not supported for mlt"),
    ):
        out = [] if "-o" in extra else ["-o", P("keep.exr")]
        r = run("render", scene, "-q", *SIZE, *out, *extra)
        check(r.returncode != 0 and expect in r.stderr, f"{name} refused ({r.stderr.strip()})")
        check(data(P("keep.exr")) == b"precious", f"{name}: nothing overwritten")

    # SIGKILL: the periodic state survives it; --resume ends bit for bit where an uninterrupted
    # render ends.
    big = ["--width", "48", "--height", "48"]
    kill = P("kill.exr")
    p = subprocess.Popen([cbdpt, "render", scene, "-q", *big, "--spp", "100000", "-o", kill,
                          "--save-state-every", "0.3"], stderr=subprocess.PIPE)
    deadline = time.time() + 120
    while time.time() < deadline and not os.path.exists(kill + ".state"):
        time.sleep(0.2)
    time.sleep(1.0)
    p.send_signal(signal.SIGKILL)
    p.wait()
    check(os.path.exists(kill + ".state") and not os.path.exists(kill),
          "a killed render leaves its periodic state and no image")
    if os.path.exists(kill + ".state"):
        r = run("merge", kill + ".state", "-o", P("saved.exr"), "-q")
        saved = run("merge", kill + ".state", "-o", P("saved.exr"))
        done = int(saved.stderr.split("state: ")[1].split(" ")[0]) if "state: " in saved.stderr else 0
        check(done > 0, f"the periodic state holds estimates ({saved.stderr.strip()})")
        # The killed render's state is the only copy of its work: a new render to the same image
        # without --resume is refused, and so is a total below what the state holds.
        before = data(kill + ".state")
        for extra, expect in (([], "holds estimates that no image shows"),
                              (["--resume"], "is the total with --resume")):
            r = run("render", scene, "-q", *big, "--spp", 1, "-o", kill, *extra)
            check(r.returncode == 1 and expect in r.stderr and data(kill + ".state") == before,
                  f"{' '.join(extra) or 'a new render'} over the killed state is refused and "
                  f"leaves it ({r.stderr.strip()})")
        total = done + 2
        r = run("render", scene, "-q", *big, "--spp", total, "-o", kill, "--resume",
                "--stats", P("kill.json"))
        s = json.load(open(P("kill.json"))) if os.path.exists(P("kill.json")) else {}
        check(r.returncode == 0 and s.get("estimates_rendered") == 2,
              f"--resume continues from the saved state ({r.stderr} {s})")
        r = run("render", scene, "-q", *big, "--spp", total, "-o", P("straight.exr"))
        check(pixels(kill) == pixels(P("straight.exr")),
              f"killed at {done} and resumed to {total} equals an uninterrupted render")
        check(not os.path.exists(kill + ".state"), "the finished render removes its state")

    # A final write that fails although the checks passed (the folder vanished mid-render):
    # the state is kept in a fallback path, named in the message, and merges into the image.
    gone = P("gone")
    os.mkdir(gone)
    env = dict(os.environ, TMPDIR=tmp)
    p = subprocess.Popen([cbdpt, "render", scene, "-q", *big, "--spp", "100000", "--time", "4",
                          "-o", os.path.join(gone, "a.exr"), "--save-state-every", "0"],
                         stderr=subprocess.PIPE, text=True, env=env)
    time.sleep(2)
    shutil.rmtree(gone)
    _, err = p.communicate(timeout=300)
    kept = re.findall(r"are kept in (\S+);", err)
    check(p.returncode == 1 and "are kept in" in err and kept and os.path.exists(kept[0]),
          f"a failed final write keeps the state and says where ({p.returncode}, {kept}: "
          f"{err.strip()})")
    if kept and os.path.exists(kept[0]):
        r = run("merge", kept[0], "-o", P("rescued.exr"), "-q")
        check(r.returncode == 0 and os.path.exists(P("rescued.exr")),
              f"the kept state gives the image ({r.stderr})")

    # A periodic save that fails (its folder vanished) warns and the render goes on; the final
    # write keeps the work as above. For MLT too, whose one state alone gives its image.
    for method, extra in (("pt", ["--save-state-every", "0.3"]),
                          ("mlt", ["--integrator", "mlt", "--bootstrap", "1000"])):
        gone = P(f"gone-{method}")
        os.mkdir(gone)
        p = subprocess.Popen([cbdpt, "render", scene, "-q", *big, "--spp", "100000", "--time", "4",
                              "-o", os.path.join(gone, "a.exr"), *extra],
                             stderr=subprocess.PIPE, text=True, env=env)
        time.sleep(2)
        shutil.rmtree(gone)
        _, err = p.communicate(timeout=300)
        kept = re.findall(r"are kept in (\S+);", err)
        if method == "pt":
            check("the render goes on" in err, f"a failed periodic save is a warning ({err})")
        check(p.returncode == 1 and kept and os.path.exists(kept[0]),
              f"{method}: the work of a render that lost its folder is kept ({err.strip()})")
        if kept and os.path.exists(kept[0]):
            r = run("merge", kept[0], "-o", P(f"rescued-{method}.exr"), "-q")
            check(r.returncode == 0 and os.path.exists(P(f"rescued-{method}.exr")),
                  f"{method}: the kept state gives the image ({r.stderr})")

    # Ctrl-C on MLT: the image of the estimates done and no state, since its Markov chains
    # cannot be resumed; so no advice to --resume either.
    mlt_out = P("mlt.exr")
    p = subprocess.Popen([cbdpt, "render", scene, *big, "--integrator", "mlt", "--spp", "100000",
                          "--bootstrap", "1000", "-o", mlt_out], stderr=subprocess.PIPE, text=True)
    time.sleep(3)
    p.send_signal(signal.SIGINT)
    _, err = p.communicate(timeout=300)
    check(p.returncode == 130 and os.path.exists(mlt_out) and
          not os.path.exists(mlt_out + ".state") and "--resume" not in err,
          f"an interrupted mlt render writes its image and no state ({p.returncode}: {err})")

finish()
