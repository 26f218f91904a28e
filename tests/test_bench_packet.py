#!/usr/bin/env python3
"""The packet traversals of cbdpt-bench, work-group-wide (`--traversal packet`, a prototype,
src/bench/kernels/bench_bvh_packet.h) and 8 or 16 rays per work-item (`--traversal ray8`,
`ray16`, kernels/cb_bvh_ray_packet.h, CPT's and CBDPT's packets), find the same hits as the
renderers' single-ray traversal (`--traversal wide`) and as Embree, on every ray set of the
traverse section: coherent ones (primary, one estimate's bounces and shadow rays) and
incoherent ones, closest and any hit, on the bunny alone and standing in a room (walls behind
and beside it: bounces start inside). Every ray's answer is compared with Embree's (agreement
1 = all rays; a closest hit counts as agreeing when it is the same triangle or one at the same
distance, a shared edge), and the number of hits with the wide traversal's on the same rays.

Usage: test_bench_packet.py PATH/TO/cbdpt-bench"""
import argparse
import json
import os
import subprocess
import tempfile

import stanford_models
from checks import check, finish

parser = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
parser.add_argument("bench", help="the cbdpt-bench executable")
args = parser.parse_args()

stanford_models.skip_without_models()

CASES = ["primary", "bounce1", "bounce2", "coh-shadow", "shadow", "incoherent"]
with tempfile.TemporaryDirectory() as tmp:
    out = os.path.join(tmp, "bench.json")
    # 4104 rays: the images are 64x64 (primaryRays rounds to tiles), the incoherent set is not a
    # multiple of the work-group size or of 64, so padding work-items and the ray packets'
    # padded last packet are exercised too.
    r = subprocess.run([args.bench, "--sections", "traverse", "--traversal",
                        "wide,packet,ray8,ray16",
                        "--meshes", "bunny,bunny-room", "--rays", "4104", "--repeats", "1",
                        "--cases", ",".join(CASES), "--json", out],
                       capture_output=True, text=True, timeout=900)
    check(r.returncode == 0, f"cbdpt-bench exits 0 (got {r.returncode}: {r.stderr})")
    data = json.load(open(out)) if r.returncode == 0 else {}

rows = data.get("traverse", [])
embree = data.get("machine", {}).get("embree", False)
by_key = {(row["mesh"], row["order"], row["rays"]): row for row in rows}
for mesh in ("bunny", "bunny-room"):
    for variant in ("packet", "ray8", "ray16"):
        for case in CASES:
            packet = by_key.get((mesh, variant, case))
            wide = by_key.get((mesh, "wide", case))
            check(packet is not None and wide is not None,
                  f"{mesh} {case}: {variant} and wide traversals ran")
            if packet is None or wide is None:
                continue
            check(packet["count"] == wide["count"] and
                  packet["hit_fraction"] == wide["hit_fraction"],
                  f"{mesh} {case}: {variant} and wide hit the same number of rays "
                  f"({packet['hit_fraction']} vs {wide['hit_fraction']})")
            if embree:
                check(packet["agreement"] == 1.0,
                      f"{mesh} {case}: {variant} traversal agrees with Embree on every ray "
                      f"({packet['agreement']})")
# The tree prefetch (CB_TREE_PREFETCH), forced on for a tree that fits the cache (the renderers
# would not prefetch it), in the packets and in the wide traversal: the same answers, and the
# run says it prefetched.
with tempfile.TemporaryDirectory() as tmp:
    out = os.path.join(tmp, "bench.json")
    r = subprocess.run([args.bench, "--sections", "traverse", "--traversal", "wide,ray16",
                        "--prefetch", "on", "--meshes", "bunny", "--rays", "4104",
                        "--repeats", "1", "--cases", ",".join(CASES), "--json", out],
                       capture_output=True, text=True, timeout=900)
    check(r.returncode == 0, f"cbdpt-bench --prefetch on exits 0 (got {r.returncode}: {r.stderr})")
    check(r.stdout.count("; prefetch") == 2, "cbdpt-bench --prefetch on says both prefetch")
    prefetched = json.load(open(out)).get("traverse", []) if r.returncode == 0 else []
for variant in ("wide", "ray16"):
    for case in CASES:
        row = next((x for x in prefetched if x["order"] == variant and x["rays"] == case), None)
        wide = by_key.get(("bunny", "wide", case))
        check(row is not None and wide is not None, f"bunny {case}: {variant} with prefetch ran")
        if row is None or wide is None:
            continue
        check(row["hit_fraction"] == wide["hit_fraction"],
              f"bunny {case}: {variant} with prefetch hits as many rays as wide without "
              f"({row['hit_fraction']} vs {wide['hit_fraction']})")
        if embree:
            check(row["agreement"] == 1.0,
                  f"bunny {case}: {variant} with prefetch agrees with Embree ({row['agreement']})")

if not embree:
    print("note: cbdpt-bench built without Embree: compared with the wide traversal only")
finish()
