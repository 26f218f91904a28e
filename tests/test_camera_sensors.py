#!/usr/bin/env python3
"""scripts/camera-sensors: PhysLight files holding the committed cameras' tables regenerate the
committed file exactly, its ColorChecker and daylight tables coming from colour-science (so the
committed data is the generator's); a file with a missing wavelength and a folder without
camera files are refused with the file named."""
import json
import os
import re
import subprocess
import sys
import tempfile
from pathlib import Path

root = sys.argv[1]
sys.path.insert(0, os.path.dirname(os.path.abspath(__file__)))
sys.path.insert(0, os.path.join(root, "scripts"))
import python_env  # noqa: F401,E402  (re-executes under .venv/bin/python: colour-science)

from checks import check, finish  # noqa: E402

script = os.path.join(root, "scripts", "camera-sensors")
committed = Path(root) / "src" / "spectral" / "camera_sensors_data.cpp"
text = committed.read_text(encoding="utf-8")
cameras = re.findall(r"// (\w+): \(nm, R, G, B\) from (\S+)\nconstexpr double \w+\[\] = \{(.*?)\};",
                     text, re.S)
check(len(cameras) == 18 and any(c[0] == "canon_eos_100d" for c in cameras)
      and any(c[0] == "nikon_d850" for c in cameras), f"18 cameras ({[c[0] for c in cameras]})")


def run(*args):
    return subprocess.run([sys.executable, script, *args], capture_output=True, text=True,
                          timeout=120)


def write_camera(folder, filename, numbers):
    rows = [numbers[i:i + 4] for i in range(0, len(numbers), 4)]
    main = {str(int(float(r[0]))): [float(v) for v in r[1:]] for r in rows}
    data = {"header": {"license": "Apache-2.0"},
            "spectral_data": {"index": {"main": ["R", "G", "B"]}, "data": {"main": main}}}
    (folder / filename).write_text(json.dumps(data), encoding="utf-8")


with tempfile.TemporaryDirectory() as tmp:
    folder = Path(tmp) / "data"
    folder.mkdir()
    for name, filename, body in cameras:
        write_camera(folder, filename, re.findall(r"[-+0-9.eE]+", body))
    out = Path(tmp) / "out.cpp"
    r = run("--physlight", tmp, "--out", str(out))
    check(r.returncode == 0 and out.read_text(encoding="utf-8") == text,
          f"the committed file from its cameras and colour-science's tables ({r.stderr})")
    r = run("--physlight", tmp, "--check")
    check(r.returncode == 0 and "matches" in r.stdout, f"--check ({r.stdout} {r.stderr})")
    first = sorted(folder.iterdir())[0]
    data = json.loads(first.read_text(encoding="utf-8"))
    del data["spectral_data"]["data"]["main"]["550"]
    first.write_text(json.dumps(data), encoding="utf-8")
    r = run("--physlight", tmp, "--out", str(out))
    check(r.returncode != 0 and first.name in r.stderr and "every 10 nm" in r.stderr,
          f"a missing wavelength is refused, naming the file ({r.stderr})")
    r = run("--physlight", os.path.join(tmp, "nowhere"), "--out", str(out))
    check(r.returncode != 0 and "no *_380_720_10.json" in r.stderr,
          f"a folder without cameras is refused ({r.stderr})")
finish()
