"""Shared pieces of scripts/make-reference, scripts/experiment and scripts/report: the
thesis's per-scene settings (docs/scenes.md), locating the cbdpt binary, reading checkpoint logs,
and a small reader for the EXR files cbdpt writes (so the scripts need only numpy)."""
import csv
import math
import os
import shutil
import struct
import subprocess
import zlib

import numpy as np

ROOT = os.path.dirname(os.path.dirname(os.path.abspath(__file__)))
REFERENCES = os.path.join(ROOT, "scenes", "references")
MODEL_PATH = os.path.join(ROOT, "models")  # scripts/get-models's output, if CBDPT_MODEL_PATH is unset

# The thesis's settings per scene (docs/scenes.md, thesis chapter 4): path-tracing vertex cap, the
# bidirectional (Ne, Nl) configurations, which methods it timed, and its estimate counts.
# "pt_vertices" equals Ne + Nl of the first bidirectional configuration, so every method of a
# configuration renders the same path-length-limited transport and one reference serves all.
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


# --- EXR reading (OpenEXR 2 scan-line files, NONE/ZIPS/ZIP compression, HALF/FLOAT) ---------

def _read_attributes(data, pos):
    attrs = {}
    while data[pos] != 0:
        end = data.index(b"\0", pos)
        name = data[pos:end].decode()
        pos = end + 1
        end = data.index(b"\0", pos)
        kind = data[pos:end].decode()
        pos = end + 1
        (size,) = struct.unpack_from("<i", data, pos)
        pos += 4
        attrs[name] = (kind, data[pos:pos + size])
        pos += size
    return attrs, pos + 1


def _channels(blob):
    out, pos = [], 0
    while blob[pos] != 0:
        end = blob.index(b"\0", pos)
        name = blob[pos:end].decode()
        pixel_type, _, xs, ys = struct.unpack_from("<iB3xii", blob, end + 1)
        if xs != 1 or ys != 1:
            raise ValueError("subsampled EXR channels are not supported")
        out.append((name, pixel_type))
        pos = end + 1 + 16
    return out


def read_exr(path, layer=""):
    """Float32 array HxWx3 of channels R,G,B (layer '' ) or LAYER.R/G/B (e.g. 'stderr')."""
    with open(path, "rb") as f:
        data = f.read()
    if struct.unpack_from("<I", data, 0)[0] != 20000630:
        raise ValueError(f"{path} is not an OpenEXR file")
    if data[5] & 0x1E:
        raise ValueError(f"{path}: only single-part scan-line EXR files are supported")
    attrs, pos = _read_attributes(data, 8)
    xmin, ymin, xmax, ymax = struct.unpack("<iiii", attrs["dataWindow"][1])
    width, height = xmax - xmin + 1, ymax - ymin + 1
    compression = attrs["compression"][1][0]
    lines_per_block = {0: 1, 2: 1, 3: 16}.get(compression)
    if lines_per_block is None:
        raise ValueError(f"{path}: EXR compression {compression} not supported (NONE/ZIPS/ZIP)")
    channels = sorted(_channels(attrs["channels"][1]))  # EXR stores channels sorted by name
    blocks = (height + lines_per_block - 1) // lines_per_block
    offsets = struct.unpack_from(f"<{blocks}Q", data, pos)
    planes = {name: np.zeros((height, width), np.float32) for name, _ in channels}
    for offset in offsets:
        y, size = struct.unpack_from("<ii", data, offset)
        raw = data[offset + 8:offset + 8 + size]
        rows = min(lines_per_block, ymax + 1 - y)
        expected = sum((2 if t == 1 else 4) * width * rows for _, t in channels)
        if compression != 0 and size < expected:
            # Undo zlib, then the byte interleave and the delta predictor (OpenEXR's ZIP).
            packed = np.frombuffer(zlib.decompress(raw), np.uint8).astype(np.int32)
            packed = (np.cumsum(packed) - 128 * np.arange(packed.size)) % 256
            packed = packed.astype(np.uint8)
            half = (packed.size + 1) // 2
            raw_bytes = np.empty(packed.size, np.uint8)
            raw_bytes[0::2] = packed[:half]
            raw_bytes[1::2] = packed[half:]
            raw = raw_bytes.tobytes()
        p = 0
        for r in range(rows):
            for name, t in channels:
                n = (2 if t == 1 else 4) * width
                dtype = {0: "<u4", 1: "<f2", 2: "<f4"}[t]
                planes[name][y - ymin + r] = np.frombuffer(raw, dtype, width, p).astype(np.float32)
                p += n
    prefix = layer + "." if layer else ""
    try:
        return np.stack([planes[prefix + c] for c in "RGB"], axis=-1)
    except KeyError:
        raise ValueError(f"{path} has no channels {prefix}R,G,B") from None


def need_matplotlib():
    try:
        import matplotlib
        matplotlib.use("Agg")
        import matplotlib.pyplot as plt
        return plt
    except ImportError:
        raise SystemExit("scripts/report needs matplotlib: pip install matplotlib "
                         "(or apt-get install python3-matplotlib)") from None


def has(program):
    return shutil.which(program) is not None
