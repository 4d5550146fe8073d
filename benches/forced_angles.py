#!/usr/bin/env python3
"""The smallest angle a feature-preserving remesh of INPUT cannot avoid.

Sharp edges (dihedral above --angle, as quality.py finds them) and boundary
edges cut the faces around each vertex into sectors. A sector narrower than
30 degrees at a vertex that any output must keep (a corner: a vertex where
the feature graph does not simply continue, degree != 2) forces an output
triangle with an angle no larger than the sector there. This prints the
narrowest sector over all feature vertices, the number of sectors below 30
degrees at corners, and, given quality.py's JSON for an output, that
output's smallest angle and its count of triangles below 30 degrees.

With --output OUT (a remeshed INPUT), it splits OUT's triangles by where
their smallest angle sits: between two of OUT's own sharp or boundary
edges at a vertex (inside a feature sector, which a kept feature line
forces) or anywhere else (which only the remesher decides), and prints the
smallest angle and the count below 20 degrees of each group.

    python3 benches/forced_angles.py ../shared/meshes/gltf/Duck.glb [quality.json] [--output OUT]
"""
import argparse
import json
import os
import sys

import numpy as np

sys.path.insert(0, os.environ.get(
    "ISOREMESH_SHARED_BENCH", os.path.join(os.path.dirname(__file__), "..", "..", "shared", "bench")
))
import quality  # noqa: E402
from meshload import load_mesh  # noqa: E402


def feature_edges(V, F, angle):
    """Sharp (dihedral above `angle`) and boundary edges, as an array and as
    a set of sorted vertex pairs."""
    S = quality.sharp_edges(V, F, angle)
    B = quality.boundary_edges(F)
    E = np.vstack([S, B]) if len(B) else S
    return E, set(map(tuple, np.sort(E, 1).tolist()))


def corner_angles(V, F):
    """The angle, in radians, at each corner of each triangle."""
    P = V[F]
    out = np.zeros(F.shape)
    for i in range(3):
        a = P[:, (i + 1) % 3] - P[:, i]
        b = P[:, (i + 2) % 3] - P[:, i]
        n = np.linalg.norm(a, axis=1) * np.linalg.norm(b, axis=1) + 1e-300
        out[:, i] = np.arccos(np.clip((a * b).sum(1) / n, -1, 1))
    return out


def sectors(V, F, angle):
    E, feature = feature_edges(V, F, angle)
    degree = np.bincount(E.reshape(-1), minlength=len(V))
    corner_angle = corner_angles(V, F)
    around = {}
    for f, t in enumerate(F):
        for k in range(3):
            if degree[t[k]] > 0:
                around.setdefault(int(t[k]), []).append((f, k))
    for v, corners in around.items():
        parent = {f: f for f, _ in corners}

        def find(x):
            while parent[x] != x:
                parent[x] = parent[parent[x]]
                x = parent[x]
            return x

        by_other = {}
        for f, k in corners:
            t = F[f]
            for w in (int(t[(k + 1) % 3]), int(t[(k + 2) % 3])):
                by_other.setdefault(w, []).append(f)
        for w, faces in by_other.items():
            if tuple(sorted((v, w))) in feature:
                continue
            for g in faces[1:]:
                parent[find(g)] = find(faces[0])
        total = {}
        for f, k in corners:
            r = find(f)
            total[r] = total.get(r, 0.0) + corner_angle[f, k]
        yield v, int(degree[v]), list(total.values())


def split_by_sector(V, F, angle):
    """Smallest angle per triangle, and whether it lies between two feature
    (sharp or boundary) edges of the mesh itself."""
    _, feature = feature_edges(V, F, angle)
    ang = np.degrees(corner_angles(V, F))
    k = ang.argmin(1)
    in_sector = np.array([
        tuple(sorted((int(t[j]), int(t[(j + 1) % 3])))) in feature
        and tuple(sorted((int(t[j]), int(t[(j + 2) % 3])))) in feature
        for t, j in zip(F, k)], dtype=bool)
    return ang.min(1), in_sector


def main():
    ap = argparse.ArgumentParser()
    ap.add_argument("input")
    ap.add_argument("quality_json", nargs="?")
    ap.add_argument("--angle", type=float, default=45.0)
    ap.add_argument("--output", help="a remeshed INPUT: split its angles by feature sector")
    a = ap.parse_args()
    V, F = load_mesh(a.input)
    narrowest, at, below30 = np.inf, None, 0
    for v, deg, secs in sectors(V, F, a.angle):
        m = min(secs)
        if m < narrowest:
            narrowest, at = m, (v, deg)
        if deg != 2 and len(secs) >= 2:
            below30 += sum(1 for s in secs if s < np.radians(30))
    line = (f"{os.path.basename(a.input)}: narrowest feature sector {np.degrees(narrowest):.2f} deg "
            f"at vertex {at[0]} (feature degree {at[1]}); sectors below 30 deg at corners: {below30}")
    if a.quality_json:
        r = json.load(open(a.quality_json))
        n30 = round(r["angles"]["frac_min_below_30"] * r["topology_out"]["F"])
        line += f"; output min angle {r['angles']['min_deg']:.2f} deg, {n30} triangles below 30 deg"
    print(line)
    if a.output:
        Vo, Fo = load_mesh(a.output)
        mn, sec = split_by_sector(Vo, Fo, a.angle)
        for name, part in (("in feature sectors", mn[sec]), ("elsewhere", mn[~sec])):
            low = f"{part.min():.2f} deg" if len(part) else "-"
            print(f"  output {name}: {len(part)} triangles, smallest angle {low}, "
                  f"{int((part < 20).sum())} below 20 deg")


if __name__ == "__main__":
    main()
