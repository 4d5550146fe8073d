#!/usr/bin/env python3
"""Remesh every shared quality mesh under a sweep of options and check each
output's validity from the binary's own statistics.

For every mesh and option set, runs
    BIN remesh INPUT OUT OPTIONS --stats STATS.json
and prints one line: faces, Euler characteristic and boundary loops of the
input and the output, the smallest angle, and whether the output is
manifold, consistently oriented, free of degenerate faces and keeps the
input's topology. Exits non-zero if any run fails or any output breaks
one of these.

    python3 benches/option_sweep.py target/dist/isoremesh [../shared/meshes]
"""
import json
import os
import subprocess
import sys
import tempfile

MESHES = [
    "camelhead.off", "cube.obj", "fandisk.obj", "fertility.off", "gltf/Duck.glb",
    "igea.ply", "spot.obj", "stanford-bunny.obj", "gltf/BoxTextured/BoxTextured.gltf",
]
OPTION_SETS = [
    ["--target-edge-ratio", "0.002", "--iterations", "3"],
    ["--target-edge-ratio", "0.05"],
    ["--target-edge-ratio", "0.2"],
    ["--adaptive"],
    ["--no-features", "--target-edge-ratio", "0.01"],
    ["--target-faces", "500"],
    ["--feature-angle", "20", "--min-crease-length", "0"],
    ["--relaxation-steps", "3", "--target-edge-ratio", "0.02"],
]


def main():
    binary = sys.argv[1]
    root = sys.argv[2] if len(sys.argv) > 2 else os.path.join(
        os.path.dirname(__file__), "..", "..", "shared", "meshes")
    bad = 0
    with tempfile.TemporaryDirectory() as tmp:
        out, stats = os.path.join(tmp, "out.obj"), os.path.join(tmp, "stats.json")
        for mesh in MESHES:
            for opts in OPTION_SETS:
                cmd = [binary, "remesh", os.path.join(root, mesh), out, *opts, "--stats", stats]
                run = subprocess.run(cmd, capture_output=True, text=True)
                label = f"{mesh[:24]:24} {' '.join(opts):45}"
                if run.returncode != 0:
                    print(f"{label} FAILED: {run.stderr.strip()}")
                    bad += 1
                    continue
                s = json.load(open(stats))
                i, o = s["input"], s["output"]
                ok = (o["manifold"] and o["consistently_oriented"] and o["degenerate_faces"] == 0
                      and o["non_manifold_edges"] == 0
                      and o["euler_characteristic"] == i["euler_characteristic"]
                      and o["boundary_loops"] == i["boundary_loops"])
                bad += not ok
                print(f"{label} F {o['faces']:7} chi {i['euler_characteristic']}->"
                      f"{o['euler_characteristic']} loops {i['boundary_loops']}->"
                      f"{o['boundary_loops']} min angle {o['angles']['min_deg']:5.1f} "
                      f"{'valid' if ok else 'INVALID'}")
    print(f"{len(MESHES) * len(OPTION_SETS) - bad} of {len(MESHES) * len(OPTION_SETS)} runs valid")
    sys.exit(1 if bad else 0)


if __name__ == "__main__":
    main()
