#!/usr/bin/env python3
"""scripts/named-illuminants: the committed table is colour-science's CIE tables (--check, which
also tells a changed file from it); --against-pbrt on a pbrt-v4 source whose tables are the
committed ones but D50, replaced by D65's, prints equal chromaticities where the data agree and
D65's for D50, the 16 bins' film ratios near 1 for smooth spectra and below it for line spectra;
a source without the tables is refused with the table named."""
import os
import subprocess
import sys
import tempfile
from pathlib import Path

root = sys.argv[1]
sys.path.insert(0, os.path.dirname(os.path.abspath(__file__)))
sys.path.insert(0, os.path.join(root, "scripts"))
import python_env  # noqa: F401,E402  (re-executes under .venv/bin/python: colour-science)

from checks import check, finish, load_script  # noqa: E402

script = os.path.join(root, "scripts", "named-illuminants")
generator = load_script(script, "named_illuminants")
committed = Path(root) / "src" / "spectral" / "named_illuminants_data.cpp"


def run(*args):
    return subprocess.run([sys.executable, script, *args], capture_output=True, text=True,
                          timeout=120)


r = run("--check")
check(r.returncode == 0 and "matches" in r.stdout, f"--check: the committed table ({r.stdout})")
tables = dict(generator.parse_generated(committed.read_text(encoding="utf-8")))
check(sorted(tables) == sorted(generator.PBRT_TABLES), f"every pbrt-v4 name: {sorted(tables)}")
check(tables["stdillum-A"][0][0] == 300 and tables["stdillum-F1"][0][0] == 380
      and abs(tables["stdillum-D65"][1][list(tables["stdillum-D65"][0]).index(560)] - 100) < 1e-9,
      "the CIE's ranges and scale (100 at 560 nm)")

with tempfile.TemporaryDirectory() as tmp:
    changed = Path(tmp) / "changed.cpp"
    changed.write_text(committed.read_text(encoding="utf-8").replace("560, 100.0", "560, 100.1",
                                                                      1), encoding="utf-8")
    r = run("--check", "--out", str(changed))
    check(r.returncode == 1 and "differs" in r.stdout, f"--check: a changed table ({r.stdout})")

    source = Path(tmp) / "pbrt" / "src" / "pbrt" / "util"
    source.mkdir(parents=True)
    lines = []
    for name, table in generator.PBRT_TABLES.items():
        nm, values = tables["stdillum-D65" if name == "stdillum-D50" else name]
        pairs = ", ".join(f"{a:g}, {b:.9g}" for a, b in zip(nm, values))
        lines.append(f"const Float {table}[] = {{\n    {pairs}}};")
    (source / "spectrum.cpp").write_text("\n".join(lines) + "\n", encoding="utf-8")
    r = run("--against-pbrt", os.path.join(tmp, "pbrt"))
    rows = {line.split()[0]: line.replace(",", " ").split()[1:]
            for line in r.stdout.splitlines()[1:]}
    check(r.returncode == 0 and len(rows) == 16, f"--against-pbrt: a row per name ({r.stderr})")
    d65, d50, f11 = rows.get("stdillum-D65"), rows.get("stdillum-D50"), rows.get("stdillum-F11")
    check(d65 and d65[0:2] == d65[2:4] == ["0.3127", "0.3290"],
          f"D65: the CIE's chromaticity in both ({d65})")
    check(d50 and d50[0:2] == ["0.3457", "0.3585"] and d50[2:4] == ["0.3127", "0.3290"],
          f"D50: the CIE's beside the source's, D65's here ({d50})")
    check(d65 and all(abs(float(v) - 1) < 0.01 for v in d65[4:]),
          f"a smooth spectrum's film through 16 bins within 1% ({d65})")
    check(f11 and float(f11[4]) < 0.99 and float(f11[5]) < 0.95,
          f"a line spectrum's: darker, less red ({f11})")

    (source / "spectrum.cpp").write_text("const Float CIE_Illum_A[] = {300, 1};\n",
                                         encoding="utf-8")
    r = run("--against-pbrt", os.path.join(tmp, "pbrt"))
    check(r.returncode != 0 and "no table CIE_Illum_D5000" in r.stderr,
          f"a missing table is named ({r.returncode}: {r.stderr})")
finish()
