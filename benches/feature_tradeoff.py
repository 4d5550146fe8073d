#!/usr/bin/env python3
"""What keeping the sharp creases costs in angles on the scans, and what
dropping them costs in distance.

For spot, fertility, the Duck, igea and the bunny, remeshes at the bench
defaults (L = 0.75 % of the diagonal, 10 iterations, feature angle 45)
once as is and once with `--no-features`, and measures both outputs with
the shared bench's quality.py (50,000 samples per side): the smallest
angle, the two-sided Hausdorff distance (per mille of the diagonal) and
the share of the input's crease samples within 0.1·L of an output edge.

    python3 benches/feature_tradeoff.py target/dist/isoremesh [../shared/meshes]
"""
import os
import subprocess
import sys
import tempfile

BENCH = os.environ.get(
    "ISOREMESH_SHARED_BENCH", os.path.join(os.path.dirname(__file__), "..", "..", "shared", "bench")
)
sys.path.insert(0, BENCH)
import quality  # noqa: E402
from meshload import bbox_diag, load_mesh  # noqa: E402

SCANS = ["spot.obj", "fertility.off", "gltf/Duck.glb", "igea.ply", "stanford-bunny.obj"]


def measure(binary, path, out, L, extra):
    subprocess.run([binary, "remesh", path, out, "--target-edge-length", repr(L),
                    "--iterations", "10", "--feature-angle", "45", *extra], check=True)
    q = quality.evaluate(path, out, L, 45.0, 50_000, selfint=False)
    f = q.get("features") or {}
    return (q["angles"]["min_deg"], 1000 * q["fidelity"]["hausdorff"],
            f.get("frac_within_0.1L", 1.0))


def main():
    binary = sys.argv[1]
    root = sys.argv[2] if len(sys.argv) > 2 else os.path.join(BENCH, "..", "meshes")
    print("| mesh | smallest angle, kept / no features | Hausdorff ‰, kept / no features "
          "| creases within 0.1·L, kept / no features |")
    print("|---|---|---|---|")
    with tempfile.TemporaryDirectory() as tmp:
        out = os.path.join(tmp, "out.obj")
        for mesh in SCANS:
            path = os.path.join(root, mesh)
            V, _ = load_mesh(path)
            L = 0.0075 * bbox_diag(V)
            kept = measure(binary, path, out, L, [])
            dropped = measure(binary, path, out, L, ["--no-features"])
            print(f"| {os.path.basename(mesh)} | {kept[0]:.2f} / {dropped[0]:.2f} "
                  f"| {kept[1]:.2f} / {dropped[1]:.2f} | {kept[2]:.3f} / {dropped[2]:.3f} |")


if __name__ == "__main__":
    main()
