"""Shared pieces of scripts/make-reference, scripts/experiment, scripts/report and
scripts/bias-check: the thesis's per-scene settings, locating the cbdpt binary, reading
checkpoint logs, and EXR input/output through the OpenEXR bindings."""
import csv
import math
import os
import shutil
import subprocess
import sys

sys.path.insert(0, os.path.dirname(os.path.abspath(__file__)))
import python_env  # noqa: E402  (the scripts' pinned environment, .venv/)

import numpy as np  # noqa: E402

ROOT = os.path.dirname(os.path.dirname(os.path.abspath(__file__)))
REFERENCES = os.path.join(ROOT, "scenes", "references")
MODEL_PATH = os.path.join(os.path.dirname(ROOT), "shared", "models")

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
                   estimates=[100]),
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
THESIS_TIMES = [
    ("cornell-box", "4+4", 5, dict(pt=55, bdpt=96, cbdpt=72, cpt=48)),
    ("cornell-box", "4+4", 25, dict(pt=245, bdpt=420, cbdpt=290, cpt=202)),
    ("cornell-box", "4+4", 100, dict(pt=945, bdpt=1622, cbdpt=1100, cpt=812)),
    ("dragon", "2+2", 100, dict(pt=744, bdpt=638, cbdpt=462, cpt=563)),
    ("buddha", "2+2", 100, dict(pt=708, bdpt=624, cbdpt=450, cpt=545)),
    ("bunny", "2+2", 100, dict(pt=721, bdpt=625, cbdpt=449, cpt=550)),
    ("grade", "4+4", 100, dict(bdpt=1342, cbdpt=1006)),
    ("grade", "2+2", 100, dict(bdpt=716, cbdpt=507, mlt=674)),
    ("gaiola", "2+2", 100, dict(bdpt=1012, cbdpt=755)),
    ("luminaria", "2+2", 100, dict(bdpt=775, cbdpt=664)),
]


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


def reference_path(scene, vertices):
    return os.path.join(REFERENCES, f"{scene}-v{vertices}.exr")


def read_log(path):
    """A checkpoint log (CSV with '# key: value' header lines) -> (header dict, column dict of
    numpy arrays; empty cells become NaN)."""
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
    columns = {n: np.array([float(r[i]) if r[i] != "" else math.nan for r in rows[1:]])
               for i, n in enumerate(names)}
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


def need_matplotlib():
    matplotlib = python_env.require("matplotlib", "plotting")
    matplotlib.use("Agg")
    import matplotlib.pyplot as plt
    return plt


def has(program):
    return shutil.which(program) is not None
