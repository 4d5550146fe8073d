#!/usr/bin/env python3
"""Writes the STL and PLY test files with third-party writers (numpy-stl,
plyfile), so that the readers are tested on files isoremesh did not write.

    pip install numpy-stl plyfile   # numpy-stl 4.1.1, plyfile 1.1.5, numpy 2.4
    python3 tests/data/make_foreign.py

Inputs are the OBJ files next to this script; only `v` and `f` statements are
used (first index of each corner, 1-based, polygons fan-triangulated).
"""
import os

import numpy as np
from plyfile import PlyData, PlyElement
from stl import mesh as stl_mesh, Mode

HERE = os.path.dirname(os.path.abspath(__file__))


def load_obj(name):
    verts, faces = [], []
    with open(os.path.join(HERE, name)) as f:
        for line in f:
            w = line.split()
            if not w:
                continue
            if w[0] == "v":
                verts.append([float(x) for x in w[1:4]])
            elif w[0] == "f":
                idx = [int(c.split("/")[0]) - 1 for c in w[1:]]
                for k in range(1, len(idx) - 1):
                    faces.append([idx[0], idx[k], idx[k + 1]])
    return np.array(verts, dtype=np.float64), np.array(faces, dtype=np.int64)


def write_stl(verts, faces, name, mode):
    m = stl_mesh.Mesh(np.zeros(len(faces), dtype=stl_mesh.Mesh.dtype))
    m.vectors[:] = verts[faces].astype(np.float32)
    m.update_normals()
    m.save(os.path.join(HERE, name), mode=mode)


def write_ply(verts, polys, name, coord, index, text=False, byte_order="<"):
    v = np.array([tuple(p) for p in verts], dtype=[("x", coord), ("y", coord), ("z", coord)])
    f = np.empty(len(polys), dtype=[("vertex_indices", "O")])
    f["vertex_indices"] = [np.array(p, dtype=index) for p in polys]
    ply = PlyData(
        [
            PlyElement.describe(v, "vertex"),
            PlyElement.describe(f, "face", val_types={"vertex_indices": index}, len_types={"vertex_indices": "u1"}),
        ],
        text=text,
        byte_order=byte_order,
        comments=["written by plyfile for isoremesh tests"],
    )
    ply.write(os.path.join(HERE, name))


spot_v, spot_f = load_obj("spot.obj")
cube_v, cube_f = load_obj("cube.obj")

# STL: binary spot (5856 triangles), ASCII cube.
write_stl(spot_v, spot_f, "spot_binary.stl", Mode.BINARY)
write_stl(cube_v, cube_f, "cube_ascii.stl", Mode.ASCII)

# PLY: binary little endian spot with float coordinates and uchar/int lists.
write_ply(spot_v, spot_f.tolist(), "spot_binary_le.ply", "f4", "i4")
# The same layout as the shared igea.ply (double coordinates, uchar/int
# lists), on a cube made of quads so that polygon faces are triangulated.
quad_v = np.array(
    [[x, y, z] for x in (-0.5, 0.5) for y in (-0.5, 0.5) for z in (-0.5, 0.5)],
    dtype=np.float64,
)
quads = [[0, 1, 3, 2], [4, 6, 7, 5], [0, 4, 5, 1], [2, 3, 7, 6], [0, 2, 6, 4], [1, 5, 7, 3]]
write_ply(quad_v, quads, "cube_quads_double_le.ply", "f8", "i4")
# Big endian, unsigned int lists.
write_ply(quad_v, quads, "cube_quads_be.ply", "f4", "u4", byte_order=">")
# ASCII.
write_ply(cube_v, cube_f.tolist(), "cube_ascii.ply", "f4", "i4", text=True)
