#!/usr/bin/env python3
"""Checks of the reconstructed meshes and of the thesis scene files.

- scripts/make-meshes --check: the committed PLYs are what the script builds, byte for byte;
- every mesh is closed (0 boundary edges: all three are expected closed, the cage as two
  closed parts), 2-manifold, consistently wound (no directed edge used twice) and outward
  (each connected part has a positive signed volume), with no degenerate or duplicate faces
  and no unused vertices;
- the face and vertex counts equal the ones documented in docs/scenes.md;
- every scenes/*.pbrt references only files that exist (plymesh, Include) or the three
  Stanford models, and every object it places (with its Translate/Scale/Rotate) and every
  point light lies inside the Cornell box.

Plain python3 + numpy; exit status 0 when everything passes. Prints "N passed, M failed".
"""

import math
import os
import re
import subprocess
import sys
from collections import Counter

sys.path.insert(0, os.path.join(os.path.dirname(os.path.dirname(os.path.abspath(__file__))), "scripts"))
import python_env  # noqa: E402,F401  (the scripts' pinned .venv/)

import numpy as np  # noqa: E402

import stanford_models

ROOT = os.environ.get("CBDPT_SOURCE_DIR") or os.path.dirname(os.path.dirname(
    os.path.abspath(__file__)))
MESHES = ["grade", "gaiola", "luminaria"]
STANFORD = {"bunny.ply", "dragon.ply", "buddha.ply"}
# Inside of the Cornell box (tables A.3-A.7), with 1 mm of slack for the slanted red wall.
BOX_LO = np.array([0.0, 0.0, 0.0]) - 1e-3
BOX_HI = np.array([0.556, 0.5488, 0.5592]) + 1e-3

results = {"passed": 0, "failed": 0}


def check(name, ok, detail=""):
    if ok:
        results["passed"] += 1
        print(f"PASS {name}")
    else:
        results["failed"] += 1
        print(f"FAIL {name}: {detail}")


# ---------------------------------------------------------------------------------- PLY

def read_ply(path):
    """Minimal reader for the format of this project's meshes (binary LE, float xyz,
    uchar-int lists; ascii also accepted)."""
    data = open(path, "rb").read()
    end = data.index(b"end_header\n") + len(b"end_header\n")
    header = data[:end].decode("ascii").splitlines()
    fmt = header[1].split()[1]
    nv = int(next(l.split()[2] for l in header if l.startswith("element vertex")))
    nf = int(next(l.split()[2] for l in header if l.startswith("element face")))
    vprops = [l for l in header if l.startswith("property") and "list" not in l]
    if fmt == "ascii":
        rows = data[end:].decode("ascii").split("\n")
        positions = np.array([[float(x) for x in r.split()[:3]] for r in rows[:nv]])
        tris = np.array([[int(x) for x in r.split()[1:4]] for r in rows[nv:nv + nf]])
        return positions, tris
    if fmt != "binary_little_endian" or len(vprops) != 3:
        raise ValueError(f"{path}: unsupported PLY layout")
    positions = np.frombuffer(data, dtype="<f4", count=3 * nv, offset=end).reshape(nv, 3)
    faces = np.frombuffer(data, dtype=[("n", "u1"), ("i", "<i4", (3,))], count=nf,
                          offset=end + 12 * nv)
    if np.any(faces["n"] != 3):
        raise ValueError(f"{path}: non-triangle face")
    if end + 12 * nv + 13 * nf != len(data):
        raise ValueError(f"{path}: trailing or missing bytes")
    return positions.astype(np.float64), faces["i"].astype(np.int64)


def face_components(tris):
    parent = list(range(len(tris)))

    def find(a):
        while parent[a] != a:
            parent[a] = parent[parent[a]]
            a = parent[a]
        return a

    owner = {}
    for f, t in enumerate(tris.tolist()):
        for k in range(3):
            e = tuple(sorted((t[k], t[(k + 1) % 3])))
            if e in owner:
                parent[find(f)] = find(owner[e])
            else:
                owner[e] = f
    return np.array([find(f) for f in range(len(tris))])


def signed_volume(p, tris):
    a, b, c = (p[tris[:, k]] for k in range(3))
    return float(np.sum(np.einsum("ij,ij->i", a, np.cross(b, c)))) / 6.0


def documented_counts():
    """Rows '| `name.ply` | thesis F | thesis V | our F | our V | parts | closed |'."""
    text = open(os.path.join(ROOT, "docs", "scenes.md"), encoding="utf-8").read()
    counts = {}
    for m in re.finditer(r"^\| `(\w+)\.ply` \|([^\n]*)$", text, re.M):
        cells = [c.strip().replace(",", "") for c in m.group(2).split("|")]
        counts[m.group(1)] = {"faces": int(cells[2]), "vertices": int(cells[3]),
                              "parts": int(cells[4])}
    return counts


def test_meshes():
    proc = subprocess.run([sys.executable, os.path.join(ROOT, "scripts", "make-meshes"),
                           "--check", "--quiet"], capture_output=True, text=True)
    check("make-meshes --check reproduces the committed PLYs byte for byte",
          proc.returncode == 0, proc.stderr.strip() or proc.stdout.strip())
    try:
        docs = documented_counts()
    except OSError as e:
        docs = {}
        check("docs/scenes.md readable", False, str(e))
    for name in MESHES:
        path = os.path.join(ROOT, "scenes", "meshes", name + ".ply")
        try:
            p, t = read_ply(path)
        except (OSError, ValueError) as e:
            check(f"{name}: readable", False, str(e))
            continue
        directed = Counter()
        for tri in t.tolist():
            for k in range(3):
                directed[(tri[k], tri[(k + 1) % 3])] += 1
        undirected = Counter()
        for (a, b), c in directed.items():
            undirected[(min(a, b), max(a, b))] += c
        boundary = sum(1 for c in undirected.values() if c == 1)
        check(f"{name}: closed (0 boundary edges)", boundary == 0, f"{boundary} boundary edges")
        nonmanifold = sum(1 for c in undirected.values() if c > 2)
        check(f"{name}: 2-manifold edges", nonmanifold == 0, f"{nonmanifold} edges with >2 faces")
        twice = sum(1 for c in directed.values() if c > 1)
        check(f"{name}: consistent winding (no directed edge twice)", twice == 0,
              f"{twice} directed edges used more than once")
        comp = face_components(t)
        vols = [signed_volume(p, t[comp == c]) for c in np.unique(comp)]
        check(f"{name}: every part outward (positive signed volume)", min(vols) > 0.0,
              f"part volumes {vols}")
        area2 = np.linalg.norm(np.cross(p[t[:, 1]] - p[t[:, 0]], p[t[:, 2]] - p[t[:, 0]]), axis=1)
        check(f"{name}: no degenerate faces", float(area2.min()) > 1e-10,
              f"smallest doubled area {area2.min()}")
        dup = len(t) - len({tuple(sorted(x)) for x in t.tolist()})
        check(f"{name}: no duplicate faces", dup == 0, f"{dup} duplicates")
        unused = len(p) - len(np.unique(t))
        check(f"{name}: no unused vertices", unused == 0, f"{unused} unused")
        doc = docs.get(name)
        check(f"{name}: counts match docs/scenes.md", doc is not None and
              (doc["faces"], doc["vertices"], doc["parts"]) == (len(t), len(p), len(vols)),
              f"docs {doc}, file faces {len(t)} vertices {len(p)} parts {len(vols)}")


# --------------------------------------------------------------------------- scene files

# Strings first, so a '#' inside quotes is not taken for a comment.
TOKEN = re.compile(r'"[^"]*"|#[^\n]*|\[|\]|[^\s\[\]"#]+')


def tokens(text):
    return [t for t in TOKEN.findall(text) if not t.startswith("#")]


def directives(toks):
    """[(name, [argument tokens])]: a directive is a bare word starting with a capital."""
    out = []
    for tok in toks:
        if tok[0].isalpha() and tok[0].isupper():
            out.append((tok, []))
        elif out:
            out[-1][1].append(tok)
    return out


def params(args):
    """pbrt parameter list -> {name: [values]} ("type name" followed by value or [...])."""
    result, i = {}, 0
    while i < len(args):
        tok = args[i]
        if tok.startswith('"') and len(tok.strip('"').split()) == 2:
            name = tok.strip('"').split()[1]
            if args[i + 1] == "[":
                j = args.index("]", i + 1)
                result[name] = [a.strip('"') for a in args[i + 2:j]]
                i = j + 1
            else:
                result[name] = [args[i + 1].strip('"')]
                i += 2
        else:
            i += 1
    return result


def rotation(deg, axis):
    a = np.array(axis, dtype=float)
    a /= np.linalg.norm(a)
    c, s = math.cos(math.radians(deg)), math.sin(math.radians(deg))
    k = np.array([[0, -a[2], a[1]], [a[2], 0, -a[0]], [-a[1], a[0], 0]])
    m = np.eye(4)
    m[:3, :3] = c * np.eye(3) + s * k + (1 - c) * np.outer(a, a)  # pbrt's Rotate
    return m


def find_model(name, scene_dir):
    dirs = [scene_dir] + [d for d in os.environ.get("CBDPT_MODEL_PATH", "").split(os.pathsep) if d]
    for d in dirs:
        if os.path.isfile(os.path.join(d, name)):
            return os.path.join(d, name)
    return None


def walk_scene(path, on_shape, on_light, on_include, ctm=None):
    scene_dir = os.path.dirname(path)
    ctm = np.eye(4) if ctm is None else ctm
    stack = []
    for name, args in directives(tokens(open(path, encoding="utf-8").read())):
        nums = [float(a) for a in args if re.fullmatch(r"[-+0-9.eE]+", a)]
        if name == "WorldBegin":
            ctm = np.eye(4)
        elif name == "AttributeBegin":
            stack.append(ctm.copy())
        elif name == "AttributeEnd":
            ctm = stack.pop()
        elif name == "Translate":
            m = np.eye(4)
            m[:3, 3] = nums
            ctm = ctm @ m
        elif name == "Scale":
            ctm = ctm @ np.diag(nums + [1.0])
        elif name == "Rotate":
            ctm = ctm @ rotation(nums[0], nums[1:4])
        elif name == "Shape":
            on_shape(args[0].strip('"'), params(args[1:]), ctm, scene_dir)
        elif name == "LightSource":
            on_light(args[0].strip('"'), params(args[1:]), ctm)
        elif name in ("Include", "Import"):
            inc = os.path.join(scene_dir, args[0].strip('"'))
            if on_include(inc):
                walk_scene(inc, on_shape, on_light, on_include, ctm)


def test_scenes():
    scenes = sorted(f for f in os.listdir(os.path.join(ROOT, "scenes")) if f.endswith(".pbrt"))
    check("scenes/ holds the seven thesis scenes",
          {"cornell-box.pbrt", "dragon.pbrt", "buddha.pbrt", "bunny.pbrt", "grade.pbrt",
           "gaiola.pbrt", "luminaria.pbrt"} <= set(scenes), f"found {scenes}")
    for scene in scenes:
        path = os.path.join(ROOT, "scenes", scene)
        problems, outside = [], []

        def on_include(inc):
            if not os.path.isfile(inc):
                problems.append(f"Include {inc} missing")
                return False
            return True

        def on_shape(kind, prm, ctm, scene_dir):
            if kind == "plymesh":
                fname = prm.get("filename", [""])[0]
                local = os.path.join(scene_dir, fname)
                if os.path.isfile(local):
                    model = local
                elif fname in STANFORD:
                    model = find_model(fname, scene_dir)
                else:
                    problems.append(f"plymesh {fname} does not exist")
                    return
                if model is None:
                    # CI always has the models: there a missing one fails.
                    if stanford_models.required():
                        check(f"{scene}: {fname} found", False, stanford_models.missing_message())
                    else:
                        print(f"note: {scene}: {fname} not found, its placement is not checked: "
                              + stanford_models.missing_message())
                    return
                p = read_ply(model)[0]
            elif kind == "trianglemesh":
                p = np.array([float(x) for x in prm["P"]]).reshape(-1, 3)
            elif kind == "sphere":
                r = float(prm.get("radius", ["1"])[0])
                p = np.array([[sx * r, sy * r, sz * r] for sx in (-1, 1) for sy in (-1, 1)
                              for sz in (-1, 1)])
            else:
                return
            w = p @ ctm[:3, :3].T + ctm[:3, 3]
            lo, hi = w.min(0), w.max(0)
            if np.any(lo < BOX_LO) or np.any(hi > BOX_HI):
                outside.append(f"{kind} {prm.get('filename', [''])[0]} spans "
                               f"{np.round(lo, 4)}-{np.round(hi, 4)}")

        def on_light(kind, prm, ctm):
            if kind == "point":
                frm = np.array([float(x) for x in prm.get("from", ["0", "0", "0"])])
                w = ctm[:3, :3] @ frm + ctm[:3, 3]
                if np.any(w < BOX_LO) or np.any(w > BOX_HI):
                    outside.append(f"point light at {np.round(w, 4)}")

        try:
            walk_scene(path, on_shape, on_light, on_include)
        except (OSError, ValueError, KeyError, IndexError) as e:
            problems.append(f"could not read: {e!r}")
        check(f"{scene}: references only existing files or Stanford models", not problems,
              "; ".join(problems))
        check(f"{scene}: objects and point lights inside the Cornell box", not outside,
              "; ".join(outside))


if __name__ == "__main__":
    test_meshes()
    test_scenes()
    print(f"{results['passed']} passed, {results['failed']} failed")
    sys.exit(1 if results["failed"] else 0)
