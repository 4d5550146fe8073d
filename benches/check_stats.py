#!/usr/bin/env python3
"""Check `isoremesh stats` against the shared bench's quality.py.

For each (input, output) pair, runs
    isoremesh stats OUTPUT --reference INPUT --target-edge-length L --json
and quality.py INPUT OUTPUT --L L, then prints every figure both report and
their relative difference. Counts must agree exactly, every other figure to
within --rtol (default 1e-3). Exit status 1 if any does not.

Usage (from the project root; the shared bench is read from
$ISOREMESH_SHARED_BENCH, by default ../shared/bench beside the repository):
    python3 benches/check_stats.py --bin target/release/isoremesh \
        --pair IN OUT [--pair IN OUT ...] [--L-rel 0.0075]
"""
import argparse
import json
import os
import subprocess
import sys

HERE = os.path.dirname(os.path.abspath(__file__))
BENCH = os.environ.get("ISOREMESH_SHARED_BENCH", os.path.join(HERE, "..", "..", "shared", "bench"))
sys.path.insert(0, BENCH)
from meshload import bbox_diag, load_mesh  # noqa: E402


def figures(ours, q):
    """(name, ours, quality.py, is_count) for every shared figure."""
    t = q["topology_out"]
    e, el = q["edges"], ours["edge_length"]
    L = el["target"]
    v, ov = q["valence"], ours["valence"]
    rows = [
        ("vertices", ours["vertices"], t["V"], True),
        ("faces", ours["faces"], t["F"], True),
        ("edges", ours["edges"], t["E"], True),
        ("boundary_edges", ours["boundary_edges"], t["boundary_edges"], True),
        ("boundary_loops", ours["boundary_loops"], t["boundary_loops"], True),
        ("components", ours["components"], t["components"], True),
        ("euler_characteristic", ours["euler_characteristic"], t["euler"], True),
        ("degenerate_faces", ours["degenerate_faces"], t["degenerate_faces"], True),
        ("interior_vertices", ov["interior_vertices"], v["interior_vertices"], True),
        ("boundary_vertices", ov["boundary_vertices"], v["boundary_vertices"], True),
        ("edge mean/L", el["mean"] / L, e["mean_over_L"], False),
        ("edge std/L", el["std"] / L, e["std_over_L"], False),
        ("edge min/L", el["min"] / L, e["min_over_L"], False),
        ("edge max/L", el["max"] / L, e["max_over_L"], False),
        ("within_band", el["within_band"], e["frac_in_band"], False),
        ("min angle", ours["angles"]["min_deg"], q["angles"]["min_deg"], False),
        ("below_30", ours["angles"]["below_30_fraction"], q["angles"]["frac_min_below_30"], False),
        ("mean min angle", ours["angles"]["mean_min_deg"], q["angles"]["mean_min_deg"], False),
        ("q min", ours["triangle_quality"]["min"], q["tri_quality"]["min"], False),
        ("q mean", ours["triangle_quality"]["mean"], q["tri_quality"]["mean"], False),
        ("regular_fraction", ov["regular_fraction"], v["frac_interior_6"], False),
        ("interior |v-6|", ov["interior_mean_abs_deviation"], v["mean_abs_dev_interior"], False),
        ("boundary |v-4|", ov["boundary_mean_abs_deviation"], v["mean_abs_dev_boundary"], False),
    ]
    d, f = ours.get("distance"), q["fidelity"]
    if d is not None:
        rows += [
            ("hausdorff/diag", d["hausdorff_relative"], f["hausdorff"], False),
            ("mean/diag", d["mean_relative"], f["mean"], False),
            ("rms/diag", d["rms_relative"], f["rms"], False),
        ]
    return rows


def main():
    ap = argparse.ArgumentParser()
    ap.add_argument("--bin", default="target/release/isoremesh")
    ap.add_argument("--pair", nargs=2, action="append", required=True, metavar=("IN", "OUT"))
    ap.add_argument("--L-rel", type=float, default=0.0075)
    ap.add_argument("--samples", type=int, default=200_000)
    ap.add_argument("--rtol", type=float, default=1e-3)
    ap.add_argument("--atol", type=float, default=1e-12,
                    help="differences below this count as equal (distances of a mesh to itself are rounding noise)")
    a = ap.parse_args()
    worst, bad = 0.0, 0
    for inp, out in a.pair:
        Vi, _ = load_mesh(inp)
        L = a.L_rel * bbox_diag(Vi)
        ours = json.loads(subprocess.run(
            [a.bin, "stats", out, "--reference", inp, "--target-edge-length", repr(L),
             "--samples", str(a.samples), "--json"],
            check=True, capture_output=True, text=True).stdout)
        q = json.loads(subprocess.run(
            [sys.executable, os.path.join(BENCH, "quality.py"), inp, out, "--L", repr(L),
             "--samples", str(a.samples), "--no-selfint"],
            check=True, capture_output=True, text=True).stdout)
        print(f"## {os.path.basename(out)} against {os.path.basename(inp)}")
        for name, x, y, is_count in figures(ours, q):
            if x is None or y is None:
                ok = x is None and y is None
                rel = 0.0
            elif is_count:
                ok, rel = x == y, 0.0 if x == y else float("inf")
            else:
                scale = max(abs(x), abs(y))
                rel = abs(x - y) / scale if scale > a.atol else 0.0
                ok = rel <= a.rtol
            worst = max(worst, rel)
            bad += not ok
            print(f"  {'ok ' if ok else 'BAD'} {name:22s} ours {x!r:>24} quality.py {y!r:>24} rel {rel:.2e}")
    print(f"largest relative difference {worst:.3e}; {bad} figure(s) outside tolerance")
    sys.exit(1 if bad else 0)


if __name__ == "__main__":
    main()
