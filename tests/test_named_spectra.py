#!/usr/bin/env python3
"""scripts/named-spectra on a small database of the refractiveindex.info layout: it writes each
metal's eta and k from 360-830 nm plus one sample beyond each end, in nanometres, in the order
of its table, and each glass's index at 587.6 nm, Sellmeier coefficients and range; --check tells
the written file from a changed one; --against-pbrt reports 0 for data equal to pbrt-v4's tables
and more for others, metals and glasses; a missing dataset, wavelengths that do not increase, a
dataset short of 360-830 nm, a formula dataset for a metal and a glass without its formula are
refused with the file (and line) named."""
import os
import re
import subprocess
import sys
import tempfile
from pathlib import Path

root = sys.argv[1]
sys.path.insert(0, os.path.dirname(os.path.abspath(__file__)))
sys.path.insert(0, os.path.join(root, "scripts"))
import python_env  # noqa: F401,E402  (re-executes under .venv/bin/python: PyYAML)

from checks import check, finish, load_script  # noqa: E402

script = os.path.join(root, "scripts", "named-spectra")
generator = load_script(script, "named_spectra")


def dataset(rows):
    body = "\n".join(f"        {um} {n} {k}" for um, n, k in rows)
    return ("# test data\nREFERENCES: |\n    A. Author. <i>A Journal</i> 1 (2000)\nDATA:\n"
            f"  - type: tabulated nk\n    data: |\n{body}\n")


def make_database(folder, override=None):
    rows = [(0.2, 1.0, 2.0), (0.35, 1.1, 2.1), (0.5, 1.2, 2.2), (0.8, 1.3, 2.3), (0.85, 1.4, 2.4),
            (1.0, 1.5, 2.5)]
    for stem, relative in generator.DATASETS:
        path = Path(folder) / "database" / "data" / relative
        path.parent.mkdir(parents=True, exist_ok=True)
        path.write_text(dataset(rows), encoding="utf-8")
    for i, (name, relative) in enumerate(generator.GLASSES):
        path = Path(folder) / "database" / "data" / relative
        path.parent.mkdir(parents=True, exist_ok=True)
        # n^2 = 1 + 0.25: the index sqrt(1.25) at every wavelength.
        path.write_text("DATA:\n  - type: formula 2\n    wavelength_range: 0.3 2.5\n"
                        "    coefficients: 0.25 0 0.01 0 0.02 0 100\n"
                        f"PROPERTIES:\n    nd: 1.5{i + 1}\n    Vd: 64\n", encoding="utf-8")
    if override:
        relative, text = override
        (Path(folder) / "database" / "data" / relative).write_text(text, encoding="utf-8")


def run(*args):
    return subprocess.run([sys.executable, script, *args], capture_output=True, text=True,
                          timeout=120)


with tempfile.TemporaryDirectory() as tmp:
    db = os.path.join(tmp, "db")
    make_database(db)
    out = os.path.join(tmp, "named.cpp")
    r = run("--database", db, "--out", out)
    check(r.returncode == 0, f"writes the table ({r.returncode}: {r.stderr})")
    text = Path(out).read_text() if os.path.exists(out) else ""
    # 0.35 um is the last sample at or below 360 nm, 0.85 um the first at or above 830 nm.
    check("constexpr double kAuEta[] = {\n    350.0, 1.1, 500.0, 1.2, 800.0, 1.3, 850.0, 1.4,\n};"
          in text, f"gold's eta in nm over 350-850 nm:\n{text[:600]}")
    check("constexpr double kAuK[] = {\n    350.0, 2.1, 500.0, 2.2, 800.0, 2.3, 850.0, 2.4,\n};"
          in text, "gold's k")
    names = re.findall(r'\{"(metal-[A-Za-z]+-(?:eta|k))", k', text)
    check(names == [f"{stem}-{part}" for stem, _ in generator.DATASETS for part in ("eta", "k")],
          f"every name in the table's order: {names}")
    check("A. Author. A Journal 1 (2000)" in text, "the reference, without its HTML")
    check('{"glass-BAF10", 1.51, "SCHOTT N-BAF10",\n'
          '         {0.25, 0.0, 0.01, 0.0, 0.02, 0.0, 100.0},\n         300.0, 2500.0},' in text
          and '{"glass-BK7", 1.52, "SCHOTT N-BK7",' in text,
          f"each glass's nd, catalogue name, Sellmeier coefficients and range:\n{text[-900:]}")
    r = run("--database", db, "--out", out, "--check")
    check(r.returncode == 0 and "matches" in r.stdout, f"--check: unchanged ({r.stdout})")
    Path(out).write_text(text.replace("1.3", "1.31"))
    r = run("--database", db, "--out", out, "--check")
    check(r.returncode == 1 and "differs" in r.stdout, f"--check: changed ({r.stdout})")

    # --against-pbrt: the same data as pbrt-v4's tables differ by 0; copper's k one higher does not.
    source = Path(tmp) / "pbrt" / "src" / "pbrt" / "util"
    source.mkdir(parents=True)
    tables = []
    for stem, _ in generator.DATASETS:
        metal = stem.split("-", 1)[1]
        tables.append(f"const Float {metal}_eta[] = {{200, 1.0, 350, 1.1, 500, 1.2, 800, 1.3, "
                      "850, 1.4, 1000, 1.5};")
        k_shift = 1 if metal == "Cu" else 0
        tables.append(f"const Float {metal}_k[] = {{" + ", ".join(
            f"{nm}, {k + k_shift}" for nm, k in [(200, 2.0), (350, 2.1), (500, 2.2), (800, 2.3),
                                                  (850, 2.4), (1000, 2.5)]) + "};")
    # The glasses: pbrt-v4's tables (F5, F10, F11 named SF5, SF10, SF11 there) hold sqrt(1.25)
    # but BK7's, 1.2.
    for name, _ in generator.GLASSES:
        stem = name.split("-", 1)[1]
        table = "Glass" + ("S" + stem if stem in ("F5", "F10", "F11") else stem) + "_eta"
        value = 1.2 if stem == "BK7" else 1.25 ** 0.5
        tables.append(f"const Float {table}[] = {{300, {value}, 900, {value}}};")
    (source / "spectrum.cpp").write_text("\n".join(tables) + "\n")
    r = run("--database", db, "--against-pbrt", os.path.join(tmp, "pbrt"))
    rows = dict(line.split()[0:3:2] for line in r.stdout.splitlines()[1:]
                if not line.startswith("glass "))
    check(r.returncode == 0 and rows.get("metal-Au") == "0.0000"
          and float(rows.get("metal-Cu", 0)) > 0.01
          and rows.get("glass-F11") == "0.00000" and float(rows.get("glass-BK7", 0)) > 0.08,
          f"--against-pbrt: 0 where the data agree, more where not ({r.stdout}{r.stderr})")

    gold = "main/Au/nk/Olmon-ts.yml"
    refusals = [
        (None, "no database/data/ folder"),
        ((gold, dataset([(0.3, 1, 1), (0.3, 1, 1), (0.9, 1, 1)])), "Olmon-ts.yml:8: wavelengths must "
         "increase"),
        ((gold, dataset([(0.4, 1, 1), (0.9, 1, 1)])), "must cover 360-830 nm"),
        ((gold, dataset([(0.3, 1, -1), (0.9, 1, 1)])), "Olmon-ts.yml:7: wavelength must be > 0"),
        ((gold, "DATA:\n  - type: formula 2\n    coefficients: 1 2\n"), "found: formula 2"),
        (("specs/schott/optical/SF5.yml", "DATA:\n  - type: formula 2\n    wavelength_range: "
          "0.3 2.5\n    coefficients: 0 1 0 0 0 0 0\nPROPERTIES:\n    Vd: 32\n"),
         "SF5.yml: expected PROPERTIES nd"),
        (("specs/schott/optical/SF5.yml", "DATA:\n  - type: tabulated n\n    data: 0.5 1.6\n"
          "PROPERTIES:\n    nd: 1.6\n"), "SF5.yml: expected one 'formula 2' DATA block, found: "
         "tabulated n"),
        (("specs/schott/optical/SF5.yml", "DATA:\n  - type: formula 2\n    wavelength_range: "
          "0.3 2.5\n    coefficients: 0 1 0\nPROPERTIES:\n    nd: 1.6\n"),
         "SF5.yml: expected 7 Sellmeier coefficients and a range, got 3"),
    ]
    for i, (override, message) in enumerate(refusals):
        folder = os.path.join(tmp, f"bad{i}")
        if override:
            make_database(folder, override)
        r = run("--database", folder, "--out", os.path.join(tmp, "bad.cpp"))
        check(r.returncode == 2 and message in r.stderr, f"refused: {message!r} ({r.returncode}: "
              f"{r.stderr})")
    make_database(os.path.join(tmp, "missing"))
    os.remove(os.path.join(tmp, "missing", "database", "data", "main", "Cu", "nk", "Hagemann.yml"))
    r = run("--database", os.path.join(tmp, "missing"), "--out", os.path.join(tmp, "bad.cpp"))
    check(r.returncode == 2 and "Hagemann.yml: cannot read" in r.stderr,
          f"a missing dataset is named ({r.stderr})")

finish()
