"""Shared pieces of scripts/make-reference, scripts/experiment, scripts/report and
scripts/bias-check: the thesis's per-scene settings, locating the cbdpt binary, reading
checkpoint logs, and EXR input/output through the OpenEXR bindings."""
import csv
import functools
import hashlib
import math
import os
import platform
import re
import shutil
import subprocess
import sys

sys.path.insert(0, os.path.dirname(os.path.abspath(__file__)))
import python_env  # noqa: E402  (the scripts' pinned environment, .venv/)

import numpy as np  # noqa: E402

ROOT = os.path.dirname(os.path.dirname(os.path.abspath(__file__)))
REFERENCES = os.path.join(ROOT, "scenes", "references")
MODEL_PATH = os.path.join(ROOT, "models")  # scripts/get-models's output, if CBDPT_MODEL_PATH is unset

# The thesis's settings per scene (its chapter 4): path-tracing vertex cap, the bidirectional
# (Ne, Nl) configurations, which methods it timed, and its estimate counts. "pt_vertices" equals
# Ne + Nl of the first bidirectional configuration. PT with N vertices and BDPT/CBDPT/MLT with
# the total-length cap N compute the same image; under the per-subpath caps Ne + Nl the
# bidirectional methods miss the paths that need a connection at a delta vertex (docs/bdpt.md),
# so they are measured against references of their own integral (reference_path's `method`).
SCENES = {
    "cornell-box": dict(pt_vertices=8, bidir=[(4, 4)], methods=["pt", "bdpt", "cbdpt", "cpt"],
                        estimates=[5, 25, 100]),
    "dragon": dict(pt_vertices=4, bidir=[(2, 2)], methods=["pt", "bdpt", "cbdpt", "cpt"],
                   estimates=[100], delta_lobes=True),  # the mix material's mirror lobe
    "buddha": dict(pt_vertices=4, bidir=[(2, 2)], methods=["pt", "bdpt", "cbdpt", "cpt"],
                   estimates=[100]),
    "bunny": dict(pt_vertices=4, bidir=[(2, 2)], methods=["pt", "bdpt", "cbdpt", "cpt"],
                  estimates=[100]),
    "grade": dict(pt_vertices=8, bidir=[(4, 4), (2, 2)], methods=["bdpt", "cbdpt", "mlt"],
                  estimates=[100]),
    "gaiola": dict(pt_vertices=4, bidir=[(2, 2)], methods=["bdpt", "cbdpt"], estimates=[100]),
    "luminaria": dict(pt_vertices=4, bidir=[(2, 2)], methods=["bdpt", "cbdpt"],
                      estimates=[100]),
}
ALL_METHODS = ["pt", "cpt", "bdpt", "cbdpt", "mlt"]

# The thesis's timings, tables 4.1-4.9 (seconds; Core 2 Duo E4600, LuxRender).
THESIS_TIMES = [  # (table, scene, Ne+Nl, estimates, {method: [seconds of each run]})
    ("4.1", "cornell-box", "4+4", 5, dict(pt=[55], bdpt=[96], cbdpt=[72], cpt=[48])),
    ("4.2", "cornell-box", "4+4", 25, dict(pt=[245], bdpt=[420], cbdpt=[290], cpt=[202])),
    ("4.3", "cornell-box", "4+4", 100,
     dict(pt=[945], bdpt=[1622], cbdpt=[1100, 1098], cpt=[812])),
    ("4.4", "dragon", "2+2", 100, dict(pt=[744], bdpt=[638], cbdpt=[462], cpt=[563])),
    ("4.5", "buddha", "2+2", 100, dict(pt=[708], bdpt=[624], cbdpt=[450], cpt=[545])),
    ("4.6", "bunny", "2+2", 100, dict(pt=[721], bdpt=[625], cbdpt=[449], cpt=[550])),
    ("4.7", "grade", "4+4", 100, dict(bdpt=[1342], cbdpt=[1006])),
    ("4.7", "grade", "2+2", 100, dict(bdpt=[716], cbdpt=[507], mlt=[674])),
    ("4.8", "gaiola", "2+2", 100, dict(bdpt=[1012], cbdpt=[755, 750])),
    ("4.9", "luminaria", "2+2", 100, dict(bdpt=[775], cbdpt=[664])),
]
# The thesis's timing runs repeated per (scene, method): CBDPT twice in tables 4.3 and 4.8.
THESIS_REPEATS = {("cornell-box", "cbdpt"): 2, ("gaiola", "cbdpt"): 2}


def find_cbdpt(explicit=None):
    """The cbdpt binary: --cbdpt, $CBDPT, build/cbdpt, or any build*/cbdpt (newest)."""
    for candidate in (explicit, os.environ.get("CBDPT")):
        if candidate:
            return candidate
    default = os.path.join(ROOT, "build", "cbdpt")
    if os.path.exists(default):
        return default
    found = [os.path.join(ROOT, d, "cbdpt") for d in os.listdir(ROOT) if d.startswith("build")]
    found = [f for f in found if os.path.exists(f)]
    if not found:
        raise SystemExit("cbdpt binary not found: build it (scripts/build) or pass --cbdpt")
    return max(found, key=os.path.getmtime)


@functools.lru_cache(maxsize=None)  # scripts/experiment asks once per unit of its plan
def machine():
    """The CPU model, its widest vector instructions (a virtual machine's model name can be the
    same for CPUs with and without AVX-512, whose kernels PoCL compiles differently, and
    Dr.Jit's wavefronts are as wide as the vectors), cores and host name."""
    model, flags = "?", set()
    try:
        for line in open("/proc/cpuinfo"):
            if line.startswith("model name") and model == "?":
                model = line.split(":", 1)[1].strip()
            elif line.startswith("flags") and not flags:
                flags = set(line.split(":", 1)[1].split())
    except OSError:
        pass
    isa = "AVX-512" if "avx512f" in flags else "AVX2" if "avx2" in flags else "SSE"
    return dict(cpu=model, vector_isa=isa, cores=os.cpu_count(), host=platform.node())


def git_revision(cbdpt):
    """The revision the cbdpt binary was built from (its --version), which is what the numbers
    describe, with "-dirty" when it was built from a modified tree (so that such a build never
    passes for the clean one under --same-revision); the checkout's own revision when the binary
    does not say."""
    r = subprocess.run([cbdpt, "--version"], capture_output=True, text=True)
    match = re.search(r"\(git ([0-9a-f]+(?:-dirty)?)", r.stdout)
    if match:
        return match.group(1)
    r = subprocess.run(["git", "-C", ROOT, "describe", "--always", "--dirty"],
                       capture_output=True, text=True)
    return r.stdout.strip() or "?"


def environment():
    env = dict(os.environ)
    if os.path.isdir(MODEL_PATH):
        env["CBDPT_MODEL_PATH"] = env.get("CBDPT_MODEL_PATH", MODEL_PATH)
    return env


def available_integrators(cbdpt):
    """Integrators this build accepts: a render request with an unknown name fails while the
    options are checked, before any scene is built, so each probe costs milliseconds."""
    scene = os.path.join(ROOT, "scenes", "cornell-box.pbrt")
    out = []
    for name in ALL_METHODS:
        r = subprocess.run([cbdpt, "render", scene, "--integrator", name, "--spp", "1", "--width",
                            "1", "--height", "1", "-o", os.devnull + ".exr", "-q"],
                           capture_output=True, text=True, env=environment())
        if "unknown integrator" not in r.stderr:
            out.append(name)
    return out


# Rough seconds per estimate at 256x256 on the 2-core development machine (a quarter of the
# 512x512 times in README.md), only for scripts/experiment's time estimate.
SECONDS_PER_ESTIMATE = dict(pt=0.03, cpt=0.025, bdpt=0.08, cbdpt=0.04, mlt=0.1)


def configurations(scene):
    """A scene's vertex configurations: the thesis's per-subpath caps "Ne+Nl" (bidirectional
    methods) and the total-length cap "nN" with N = Ne + Nl (every method)."""
    out = []
    for ne, nl in SCENES[scene]["bidir"]:
        out += [f"{ne}+{nl}", f"n{ne + nl}"]
    return out


def method_runs_config(scene, method, config):
    """PT and CPT have one cap, the total; the thesis ran MLT on the grille only."""
    if method in ("pt", "cpt"):
        return config.startswith("n") and int(config[1:]) == SCENES[scene]["pt_vertices"]
    return method in SCENES[scene]["methods"] or method in ("bdpt", "cbdpt")


def config_args(method, config):
    if config.startswith("n"):
        return ["--max-vertices", config[1:]]
    ne, nl = config.split("+")
    return ["--eye-vertices", ne, "--light-vertices", nl]


def reference_path(scene, config, method="pt"):
    """The reference of the integral that `method` computes under `config`: PT with N vertices
    (SCENE-vN.exr) for PT and CPT; a long BDPT run with the same caps (SCENE-bdpt-4p4.exr,
    SCENE-bdpt-n8.exr) for BDPT, CBDPT and MLT, whose integral differs from PT's under the
    per-subpath caps (paths needing a connection at a delta vertex are missed) and, with a point
    light and a mirror, also under the total cap (light tracing samples the point light's
    caustics, which PT cannot; docs/bdpt.md). Scenes without delta lobes (all but the
    dragon) have no such paths, so there every method shares PT's reference: fewer large files
    in the repository."""
    if method in ("pt", "cpt") or not SCENES[scene].get("delta_lobes"):
        total = config[1:] if config.startswith("n") else sum(map(int, config.split("+")))
        return os.path.join(REFERENCES, f"{scene}-v{total}.exr")
    return os.path.join(REFERENCES, f"{scene}-bdpt-{config.replace('+', 'p')}.exr")


@functools.lru_cache(maxsize=None)
def _sha256(path, size, mtime_ns):
    digest = hashlib.sha256()
    with open(path, "rb") as f:
        for block in iter(lambda: f.read(1 << 20), b""):
            digest.update(block)
    return digest.hexdigest()


def file_sha256(path):
    """Hex SHA-256 of a file's bytes, None when it does not exist. Time and combine units record
    their reference's, so that a unit measured against a reference since grown (whose own error,
    the curves' floor, was larger) counts as not done and runs again."""
    try:
        st = os.stat(path)
    except OSError:
        return None
    return _sha256(os.path.abspath(path), st.st_size, st.st_mtime_ns)


# The combination study (docs/combine.md, `cbdpt combine`): per scene, under one of two caps,
# PT and CBDPT share one time budget (`--split-budget`; PT's share from the caps' shares) and
# their two renders are combined every pairwise way; COMBINE_ROBUST_RUNS CBDPT runs share the
# budget and are combined robustly. "subpath": the thesis's caps Ne+Nl; "total": the total
# path-length cap N = Ne + Nl (`--max-vertices`), under which CBDPT computes PT's integral and
# has no (2,2)-only fireflies (docs/bdpt.md). Share 0.75 was never the best under "subpath".
COMBINE_CAPS = ["subpath", "total"]
COMBINE_SHARES = {"subpath": [0.25, 0.5, 0.75], "total": [0.25, 0.5]}
COMBINE_DEFAULT_SHARE = 0.5  # `cbdpt combine --split-budget` without --shares: equal shares
COMBINE_PAIR = ["mean", "inverse-variance", "inverse-variance-naive", "guided"]
COMBINE_ROBUST = ["median", "reject", "mean"]
COMBINE_ROBUST_RUNS = 4


def combine_config(scene, caps="subpath"):
    """The configuration of a scene's combination units: its first per-subpath configuration
    Ne+Nl ("subpath"; `--split-budget` gives PT Ne + Nl vertices, so both compute paths of that
    length) or the total cap nN with N = Ne + Nl ("total")."""
    ne, nl = SCENES[scene]["bidir"][0]
    return f"{ne}+{nl}" if caps == "subpath" else f"n{ne + nl}"


def combine_caps_of(config):
    return "total" if config.startswith("n") else "subpath"


def combine_unit_ids(scene, seeds, shares=None, caps="subpath"):
    """The ids of a scene's combination units: one per seed and PT share, one robust per seed."""
    config = combine_config(scene, caps)
    out = []
    for seed in seeds:
        out += [f"{scene}/{config}/combine/pt-cbdpt-share{s:g}-seed{seed}"
                for s in (COMBINE_SHARES[caps] if shares is None else shares)]
        out.append(f"{scene}/{config}/combine/cbdpt-x{COMBINE_ROBUST_RUNS}-seed{seed}")
    return out


def read_log(path):
    """A checkpoint log (CSV with '# key: value' header lines) -> (header dict, column dict of
    numpy arrays; empty cells become NaN; a column with text, such as an image's name, stays
    an array of strings)."""
    header, lines = {}, []
    with open(path) as f:
        for line in f:
            if line.startswith("#"):
                if ":" in line:
                    key, value = line[1:].split(":", 1)
                    header[key.strip()] = value.strip()
            elif line.strip():
                lines.append(line)
    rows = list(csv.reader(lines))
    names = rows[0]
    columns = {}
    for i, n in enumerate(names):
        cells = [r[i] for r in rows[1:]]
        try:
            columns[n] = np.array([float(c) if c != "" else math.nan for c in cells])
        except ValueError:
            columns[n] = np.array(cells)
    return header, columns


# --- EXR files, through the OpenEXR project's Python bindings (PyPI "OpenEXR") ------------

def _openexr():
    return python_env.require("OpenEXR", "reading and writing EXR files")


def read_exr(path, layer=""):
    """Float32 array HxWx3 of channels R,G,B (layer '') or LAYER.R/G/B (e.g. 'stderr')."""
    OpenEXR = _openexr()
    try:
        with OpenEXR.File(path, separate_channels=True) as f:
            channels = f.channels()
            prefix = layer + "." if layer else ""
            try:
                planes = [channels[prefix + c].pixels for c in "RGB"]
            except KeyError:
                raise ValueError(f"{path} has no channels {prefix}R,G,B "
                                 f"(it has {', '.join(sorted(channels))})") from None
    except RuntimeError as e:  # the bindings' error for unreadable or non-EXR files
        raise ValueError(f"{path}: not a readable OpenEXR file ({e})") from None
    return np.stack([np.asarray(p, np.float32) for p in planes], axis=-1)


def write_exr(path, layers):
    """Writes a ZIP-compressed float EXR: `layers` maps a layer name ('' for the main image) to
    an HxWx3 array, stored as R,G,B or LAYER.R/G/B. Written to a temporary file, then renamed,
    so that an interrupted write never leaves a truncated image."""
    OpenEXR = _openexr()
    channels = {}
    for layer, image in layers.items():
        prefix = layer + "." if layer else ""
        image = np.ascontiguousarray(image, np.float32)
        for i, c in enumerate("RGB"):
            channels[prefix + c] = OpenEXR.Channel(np.ascontiguousarray(image[..., i]))
    header = {"compression": OpenEXR.ZIP_COMPRESSION, "type": OpenEXR.scanlineimage}
    tmp = path + ".tmp.exr"
    with OpenEXR.File(header, channels) as f:
        f.write(tmp)
    os.replace(tmp, path)


def rewrite_exr_half(path, layers=("", "stderr")):
    """Rewrites an EXR keeping only `layers` (R,G,B or LAYER.R/G/B; by default the image and its
    standard error, what a reference is read for) as 16-bit half floats, with its header
    (cbdpt's render record): the references' storage. A half's relative rounding error is at
    most 2^-11 (RMS 2.8e-4), far below a reference's own noise (about 1% of its mean). Written
    to a temporary file, then renamed."""
    OpenEXR = _openexr()
    wanted = {(layer + "." if layer else "") + c for layer in layers for c in "RGB"}
    with OpenEXR.File(path, separate_channels=True) as f:
        header = dict(f.header())
        channels = {name: OpenEXR.Channel(np.ascontiguousarray(c.pixels, np.float16))
                    for name, c in f.channels().items() if name in wanted}
    if len(channels) != len(wanted):
        raise ValueError(f"{path}: expected channels {sorted(wanted)}, found {sorted(channels)}")
    header["compression"] = OpenEXR.ZIP_COMPRESSION
    tmp = path + ".tmp.exr"
    with OpenEXR.File(header, channels) as f:
        f.write(tmp)
    os.replace(tmp, path)


def reference_error(reference, runs):
    """The reference's own mean squared error, measured from K >= 2 independent runs of its
    integral (arrays like `reference`; each run has its own seed, so its own randomisation).

    Independent errors add: MSE(run_k, ref) = e_k^2 + e_ref^2 and MSE(run_j, run_k) = e_j^2 +
    e_k^2, so e_ref^2 = mean_k MSE(run_k, ref) - mean_{j<k} MSE(run_j, run_k) / 2. The reference's
    stderr layer (the spread of its estimates) cannot give this under the Sobol sampler: its
    estimates are correlated, and their spread overstates the error of their mean.
    Returns dict(runs, reference_mse, reference_rms_error, runs_mse), MSE over pixels and
    channels as `cbdpt compare` computes RMSE; reference_mse may come out below 0 by noise."""
    if len(runs) < 2:
        raise ValueError(f"measuring a reference's error needs 2 or more runs, got {len(runs)}")
    ref = np.asarray(reference, float)
    to_ref = [float(np.mean((np.asarray(r, float) - ref) ** 2)) for r in runs]
    pairs = [float(np.mean((np.asarray(runs[j], float) - np.asarray(runs[k], float)) ** 2))
             for j in range(len(runs)) for k in range(j + 1, len(runs))]
    runs_mse = float(np.mean(pairs)) / 2
    ref_mse = float(np.mean(to_ref)) - runs_mse
    return dict(runs=len(runs), reference_mse=ref_mse,
                reference_rms_error=math.sqrt(max(ref_mse, 0.0)), runs_mse=runs_mse)


def read_pfm(path):
    """HxWx3 float64 array of a colour PFM (pbrt-v4's float output), top row first."""
    with open(path, "rb") as f:
        if f.readline().strip() != b"PF":
            raise ValueError(f"{path}: not a colour PFM")
        width, height = map(int, f.readline().split())
        scale = float(f.readline())
        data = np.frombuffer(f.read(), "<f4" if scale < 0 else ">f4")
    return data.reshape(height, width, 3)[::-1].astype(np.float64)


def away_from_emitters(cbdpt, scene, size, margin, folder):
    """True where a pixel is at least `margin` pixels (Chebyshev) from a directly seen emitter:
    the pixels a 2-vertex path tracer finds lit (camera and emitter only)."""
    out = os.path.join(folder, "emitters.exr")
    run_checked([cbdpt, "render", scene, "--integrator", "pt", "--eye-vertices", "2", "--width",
                 str(size[0]), "--height", str(size[1]), "--spp", "4", "--seed", "1", "-o", out,
                 "-q"], env=environment(), stderr=subprocess.PIPE, text=True)
    lit = read_exr(out).astype(np.float64) @ LUMINANCE > 0
    return ~near_pixels(lit, margin)


def near_pixels(mask, margin):
    """The pixels within `margin` (Chebyshev distance) of a True pixel of `mask`; the image's
    edges do not wrap around."""
    h, w = mask.shape
    padded = np.pad(mask, margin, constant_values=False)
    near = np.zeros_like(mask)
    for dy in range(2 * margin + 1):
        for dx in range(2 * margin + 1):
            near |= padded[dy:dy + h, dx:dx + w]
    return near


LUMINANCE = np.array([0.2126, 0.7152, 0.0722])
LOW_FREQUENCY = 0.1  # cycles per pixel: "low" below this


def radial_spectrum(error):
    """Radially averaged power spectrum of a square error image. P = |FFT|^2 / pixels, so white
    noise of variance s^2 is flat at s^2 (Parseval), returned against |f| in cycles/pixel, with
    the fraction of the power below LOW_FREQUENCY."""
    h, w = error.shape
    power = np.abs(np.fft.fft2(error)) ** 2 / (h * w)
    fy = np.fft.fftfreq(h)[:, None]
    fx = np.fft.fftfreq(w)[None, :]
    radius = np.sqrt(fx ** 2 + fy ** 2)
    bins = np.arange(0, 0.5 + 1e-9, 1.0 / max(h, w))
    index = np.digitize(radius, bins) - 1
    freqs, values = [], []
    for i in range(1, len(bins) - 1):
        sel = index == i
        if sel.any():
            freqs.append(radius[sel].mean())
            values.append(power[sel].mean())
    low = power[(radius < LOW_FREQUENCY) & (radius > 0)].sum() / max(power[radius > 0].sum(), 1e-300)
    return np.array(freqs), np.array(values), float(low)


def flip_evaluate(image, reference):
    """HDR-FLIP (NVIDIA's flip-evaluator) of image against reference: (error map, mean,
    parameters). HDR-FLIP expects non-negative linear values, and spectral renders hold small
    negative sRGB values, so both images are clamped at 0 (an image against itself scores 0).
    Raises ImportError without flip-evaluator."""
    import flip_evaluator
    error_map, mean, params = flip_evaluator.evaluate(
        np.ascontiguousarray(np.maximum(reference, 0), np.float32),
        np.ascontiguousarray(np.maximum(image, 0), np.float32), "HDR")
    return error_map, float(mean), params


def flip_mean(image, reference):
    """Mean HDR-FLIP of image against reference (flip_evaluate); None without flip-evaluator."""
    try:
        return flip_evaluate(image, reference)[1]
    except ImportError:
        return None


def read_exr_attributes(path):
    """The header's string, int and double attributes of an EXR (cbdpt's render record:
    cbdpt_method, cbdpt_seed, cbdpt_render_cpu_seconds, ...) as a dict."""
    OpenEXR = _openexr()
    try:
        # Copied while the file is open: closing it empties the bindings' header dict.
        with OpenEXR.File(path, header_only=True) as f:
            header = dict(f.header())
    except Exception as e:  # the bindings raise plain exceptions for unreadable files
        raise ValueError(f"{path}: not a readable OpenEXR file ({e})") from None
    out = {}
    for name, value in header.items():
        if isinstance(value, bytes):
            out[name] = value.decode()
        elif isinstance(value, (str, int, float)) and not isinstance(value, bool):
            out[name] = value
        elif isinstance(value, np.ndarray) and value.size == 1:  # doubles come as 1-arrays
            out[name] = float(value.reshape(-1)[0])
    return out


def need_matplotlib():
    matplotlib = python_env.require("matplotlib", "plotting")
    matplotlib.use("Agg")
    import matplotlib.pyplot as plt
    return plt


def has(program):
    return shutil.which(program) is not None


# ---------------------------------------------------------------------------------------------
# Error at equal time (scripts/equal-time-pbrt, scripts/compare-mitsuba): K images of one
# unbiased estimator, each with its own seed, give each image its own MSE by leave-one-out.

def leave_one_out_squares(images):
    """Per image and pixel: (x_k - mean of the others)^2 (K-1)/K, an unbiased estimate of that
    image's variance at that pixel (its MSE, for an unbiased estimator). E[(x_k - m_k)^2] =
    s^2 + s^2/(K-1) = s^2 K/(K-1), hence the factor."""
    stack = np.stack(images)
    k = len(images)
    if k < 2:
        raise ValueError(f"leave-one-out needs 2 or more images, got {k}")
    others = (stack.sum(0)[None] - stack) / (k - 1)
    return (stack - others) ** 2 * (k - 1) / k


def leave_one_out_mse(images, mask):
    """Per image: the mean of leave_one_out_squares over the pixels where mask is true."""
    return np.array([float(square[mask].mean()) for square in leave_one_out_squares(images)])


def band(values):
    return dict(median=float(np.median(values)), min=float(np.min(values)),
                max=float(np.max(values)))


def merit_ratio(theirs, ours):
    """Figures of merit MSE x seconds (arrays, one per image): the ratio theirs / ours of the
    medians (> 1: ours has the lower error at equal time) and the range over all pairs."""
    theirs, ours = np.asarray(theirs, float), np.asarray(ours, float)
    pairs = theirs[:, None] / ours[None, :]
    return dict(ratio_median=float(np.median(theirs) / np.median(ours)),
                ratio_min=float(pairs.min()), ratio_max=float(pairs.max()))


# ---------------------------------------------------------------------------------------------
# Refusals of the comparison scripts: a usage error (exit 2) names the path, a failed child
# ends the script with its command and exit status instead of a traceback.

def check_inputs(parser, scenes=(), programs=()):
    """parser.error (usage, exit 2) for a scene that is not a file or a program that is not an
    executable file, naming it and the option it came from."""
    for scene in scenes:
        if not os.path.isfile(scene):
            parser.error(f"scene '{scene}': no such file")
    for option, program in programs:
        if program is None:
            continue
        path = shutil.which(program) if os.sep not in program else program
        if not path or not os.path.isfile(path) or not os.access(path, os.X_OK):
            parser.error(f"{option} '{program}': not an executable program")


def run_checked(command, **kwargs):
    """subprocess.run(command, **kwargs); when the child fails, SystemExit naming the command,
    its exit status and the end of its error output (when captured)."""
    r = subprocess.run(command, **kwargs)
    if r.returncode != 0:
        detail = ""
        if isinstance(r.stderr, (str, bytes)) and r.stderr:
            err = r.stderr.decode(errors="replace") if isinstance(r.stderr, bytes) else r.stderr
            detail = "\n" + err.strip()[-2000:]
        raise SystemExit(f"{os.path.basename(sys.argv[0])}: failed (exit status "
                         f"{r.returncode}): {' '.join(map(str, command))}{detail}")
    return r
