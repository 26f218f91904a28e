#!/usr/bin/env python3
"""scripts/gpu-bundle (docs/gpu.md): the bundle holds both binaries, every shared library they
load outside the C and C++ runtimes, the ICD file naming NVIDIA's driver and env.sh; sourced,
env.sh makes the binaries load the bundle's libraries (here with PoCL's ICD: ICD=DIR)."""
import os
import subprocess
import sys
import tempfile

cbdpt, root = sys.argv[1], sys.argv[2]
sys.path.insert(0, os.path.dirname(os.path.abspath(__file__)))
from checks import check, finish  # noqa: E402

RUNTIMES = ("libc.so", "libm.so", "libstdc++.so", "libgcc_s.so", "ld-linux", "linux-vdso")

with tempfile.TemporaryDirectory() as tmp:
    out = os.path.join(tmp, "bundle")
    env = {k: v for k, v in os.environ.items() if k != "CBDPT_MODEL_PATH"}
    r = subprocess.run([os.path.join(root, "scripts", "gpu-bundle"), "--build",
                        os.path.dirname(os.path.abspath(cbdpt)), out],
                       capture_output=True, text=True, env=env)
    check(r.returncode == 0, f"gpu-bundle exits 0 ({r.stderr[-400:]})")
    for name in ("cbdpt", "cbdpt_tests", "env.sh"):
        check(os.path.isfile(os.path.join(out, name)), f"the bundle holds {name}")
    check(open(os.path.join(out, "icd", "nvidia.icd")).read().strip() == "libnvidia-opencl.so.1",
          "the ICD file names NVIDIA's OpenCL driver")
    check(not os.path.exists(os.path.join(out, "models")), "no models without CBDPT_MODEL_PATH")
    # Sourced with PoCL's vendors folder, env.sh resolves every library from the bundle except
    # the runtimes, and cbdpt lists its devices.
    icd = "/etc/OpenCL/vendors"
    script = (f'ICD={icd}; . "{out}/env.sh" && ldd "{out}/cbdpt" && '
              f'"{out}/cbdpt" info && echo "vendors=$OCL_ICD_VENDORS"')
    r = subprocess.run(["bash", "-c", script], capture_output=True, text=True, env=env)
    check(r.returncode == 0, f"cbdpt info under env.sh ({r.stderr[-400:]})")
    libs = [line.split() for line in r.stdout.splitlines() if "=>" in line]
    outside = [parts[0] for parts in libs if not parts[2].startswith(os.path.join(out, "lib"))
               and not parts[0].startswith(RUNTIMES)]
    check(libs and not outside, f"every library but the runtimes from the bundle ({outside})")
    check(f"vendors={icd}" in r.stdout and "selected" in r.stdout,
          "ICD=DIR replaces the bundle's ICD folder and a device is listed")

finish()
