#!/usr/bin/env python3
"""cbdpt-bench --quick runs and writes well-formed JSON with every section. No
timing assertions: only structure, positive finite timings, and that our traversal and Embree
(when built in) agree on the rays.

Usage: test_bench.py PATH/TO/cbdpt-bench"""
import json
import math
import os
import subprocess
import sys
import tempfile

import stanford_models

bench = sys.argv[1]
failures = []

# The quick run traces the bunny and renders the dragon scene. Without the models the test is
# skipped ("cbdpt-skip:", SKIP_REGULAR_EXPRESSION in tests/tests.cmake), except in CI.
stanford_models.skip_without_models()


def check(condition, message):
    if not condition:
        failures.append(message)
        print("FAIL:", message)


def positive(x):
    return isinstance(x, (int, float)) and math.isfinite(x) and x > 0


with tempfile.TemporaryDirectory() as tmp:
    out = os.path.join(tmp, "bench.json")
    r = subprocess.run([bench, "--quick", "--json", out], capture_output=True, text=True,
                       timeout=600)
    check(r.returncode == 0, f"cbdpt-bench --quick exits 0 (got {r.returncode}: {r.stderr})")
    check("== traverse" in r.stdout and "== render" in r.stdout, "tables printed")
    data = json.load(open(out))
    for section in ("machine", "traverse", "build", "render", "scaling", "accumulate"):
        check(section in data, f"section '{section}' present")

    rows = data.get("traverse", [])
    check(len(rows) >= 8, f"traverse has rows for 2 meshes x 4 ray sets ({len(rows)})")
    kinds = {(row["rays"], row["query"]) for row in rows}
    for k in [("primary", "closest-hit"), ("incoherent", "closest-hit"), ("shadow", "any-hit")]:
        check(k in kinds, f"traverse covers {k}")
    for row in rows:
        check(positive(row["ours_mrays_per_s"]), f"positive throughput {row}")
        check(0.0 <= row["hit_fraction"] <= 1.0, f"hit fraction in [0,1] {row}")
        if data["machine"].get("embree"):
            check(positive(row["embree_mrays_per_s"]) and positive(row["ratio"]),
                  f"Embree timed {row}")
            check(row["agreement"] >= 0.9999, f"ours and Embree agree on >= 99.99% {row}")
        check(row.get("bvh_settings", "").startswith("SAH block "),
              f"the BVH's settings are recorded {row}")
    for k in [("bounce1", "closest-hit"), ("bounce2", "closest-hit"), ("coh-shadow", "any-hit")]:
        check(k in kinds, f"traverse covers one estimate's coherent rays {k}")
    for row in rows:
        if row["rays"] in ("bounce1", "bounce2"):
            check(0.0 < row.get("active_fraction", 0.0) <= 1.0,
                  f"bounce rays: some paths still active {row}")
    if data["machine"].get("embree"):
        # Embree's packet interface beside rtcIntersect1, on the same rays (same ours).
        calls = {(row["mesh"], row["rays"]): row["embree_call"] for row in rows}
        for mesh in {row["mesh"] for row in rows}:
            for case, call in [("primary", "rtcIntersect1"), ("primary/8", "rtcIntersect8"),
                               ("primary/16", "rtcIntersect16"), ("bounce2/8", "rtcIntersect8"),
                               ("coh-shadow/16", "rtcOccluded16")]:
                check(calls.get((mesh, case)) == call, f"{mesh} {case} compared with {call}")
    prim = [row for row in rows if row["rays"] == "primary"]
    check(all(0.05 < row["hit_fraction"] < 0.95 for row in prim),
          "primary rays see both the mesh and the background")

    build = data.get("build", {})
    check(len(build.get("bvh", [])) >= 2 and all(positive(b["seconds"]) for b in build["bvh"]),
          "BVH build times")
    check(all(positive(b.get("wide_seconds")) for b in build.get("bvh", [])),
          "the renderers' wide BVH build (both candidate settings) timed")
    for b in build.get("bvh", []):
        # The packs hold each triangle's three vertices (36 bytes); Embree holds at least the
        # index buffer (12 bytes a triangle) besides its BVH.
        check(b.get("wide_pack_bytes", 0) >= 36 * b["triangles"]
              and b.get("wide_node_bytes", 0) > 0, f"the wide BVH's bytes counted {b}")
        if "embree_seconds" in b:
            check(b.get("embree_mesh_buffer_bytes", 0) > 12 * b["triangles"]
                  and b.get("embree_bytes", 0) > b["embree_mesh_buffer_bytes"],
                  f"Embree's bytes counted, its BVH besides the mesh's buffers {b}")
    progs = build.get("program", [])
    check(len(progs) >= 1, "program build timed")
    for p in progs:
        check(positive(p["cold_seconds"]) and positive(p["warm_seconds"]),
              f"cold and warm program builds succeeded {p}")

    render = data.get("render", [])
    methods = {(row["scene"], row["method"]) for row in render if not row.get("failed")}
    check(("cornell-box", "pt") in methods and ("cornell-box", "cpt") in methods,
          f"render times PT and CPT on the Cornell box ({methods})")
    # An integrator that is still being written may crash in its child process; that row is
    # marked failed rather than failing the benchmark. PT and CPT must always be timed.
    for row in render:
        if row.get("failed"):
            print("note: render failed for", row)
            continue
        check(positive(row["seconds_per_estimate"]) and positive(row["paths_per_second"]),
              f"render timing {row}")

    sc = data.get("scaling", {})
    for key in ("triangles", "resolution", "estimates"):
        check(len(sc.get(key, [])) >= 2, f"scaling.{key} has points")
    check(0.0 <= sc.get("estimates_fit", {}).get("r2", -1) <= 1.0, "estimates fit R^2")

    acc = data.get("accumulate", [])
    check({row["halves"] for row in acc} == {False, True}, "accumulate with and without halves")
    for row in acc:
        check(positive(row["cpu_seconds_per_estimate"]) and positive(row["cpu_ns_per_value"]),
              f"accumulation timing {row}")

print(f"{'FAILED' if failures else 'passed'}: {len(failures)} failure(s)")
sys.exit(1 if failures else 0)
