//! Edge classification (dihedral angle, boundary, label border,
//! non-manifold) over an edge table built once per mesh, and the walk that
//! turns the feature graph into lines between corners.

use glam::DVec3;
use rayon::prelude::*;

use super::*;
use crate::topology::{Csr, EdgeTable};
use crate::trimesh::TriMesh;

/// Traces feature lines through the feature graph, recording for every edge
/// its (line, segment) and for every line vertex its kind and index.
pub(crate) struct LineWalker<'a> {
    pub(crate) edges: &'a [[u32; 2]],
    pub(crate) adj_offset: &'a [u32],
    pub(crate) adj: &'a [[u32; 2]],
    pub(crate) kind: &'a mut [VertexKind],
    pub(crate) edge_segment: &'a mut [[u32; 2]],
    pub(crate) line_index: &'a mut [u32],
}

impl LineWalker<'_> {
    /// Follows feature edges from `start` through `first_edge` until a corner
    /// or back at `start`; returns the vertex ids of line `id`.
    pub(crate) fn walk(&mut self, start: u32, first_edge: u32, id: u32) -> Vec<u32> {
        let mut verts = vec![start];
        let (mut v, mut e) = (start, first_edge);
        loop {
            let [a, b] = self.edges[e as usize];
            let next = if a == v { b } else { a };
            self.edge_segment[e as usize] = [id, verts.len() as u32 - 1];
            verts.push(next);
            if self.kind[next as usize] == VertexKind::Corner || next == start {
                break;
            }
            // Every non-corner feature vertex has exactly two feature edges.
            let row = &self.adj[self.adj_offset[next as usize] as usize
                ..self.adj_offset[next as usize + 1] as usize];
            let other = if row[0][1] == e { row[1][1] } else { row[0][1] };
            self.kind[next as usize] = VertexKind::Line(id);
            self.line_index[next as usize] = verts.len() as u32 - 1;
            v = next;
            e = other;
        }
        if self.kind[start as usize] != VertexKind::Corner {
            self.kind[start as usize] = VertexKind::Line(id);
            self.line_index[start as usize] = 0;
        }
        verts
    }
}

/// Feature adjacency of `edges` over `nv` vertices in compressed rows:
/// row `v` is `adj[offset[v]..offset[v + 1]]`, (neighbour, edge id) pairs
/// sorted by neighbour.
pub(crate) fn feature_adjacency(nv: usize, edges: &[[u32; 2]]) -> (Vec<u32>, Vec<[u32; 2]>) {
    let mut rows = Csr::from_pairs(nv, || {
        edges
            .iter()
            .enumerate()
            .flat_map(|(e, &[a, b])| [(a, [b, e as u32]), (b, [a, e as u32])])
    });
    rows.sort_rows();
    rows.into_parts()
}

/// Dihedral angle of the edge shared by half-edges `h0`, `h1`, degrees; 0
/// when a face is degenerate. When both faces run the edge the same way (an
/// orientation flip) one normal is reversed so that a flat but flipped pair
/// does not read as a 180° crease.
pub(crate) fn dihedral_deg(mesh: &TriMesh, normals: &[DVec3], h0: u32, h1: u32) -> f64 {
    let (f0, f1) = ((h0 / 3) as usize, (h1 / 3) as usize);
    let (n0, mut n1) = (normals[f0], normals[f1]);
    if n0 == DVec3::ZERO || n1 == DVec3::ZERO {
        return 0.0;
    }
    let from = |h: u32| mesh.triangles[(h / 3) as usize][(h % 3) as usize];
    if from(h0) == from(h1) {
        n1 = -n1;
    }
    n0.dot(n1).clamp(-1.0, 1.0).acos().to_degrees()
}

pub(crate) fn classify_edges(
    mesh: &TriMesh,
    preserve_features: bool,
    feature_angle_deg: f64,
    seams: &[[u32; 2]],
) -> (Vec<[u32; 2]>, Vec<EdgeFlags>) {
    let table = EdgeTable::new(&mesh.triangles, mesh.positions.len());
    let mut seam_keys: Vec<u64> = seams
        .iter()
        .map(|&[a, b]| crate::topology::edge_key(a, b))
        .collect();
    seam_keys.sort_unstable();
    let normals: Vec<DVec3> = if preserve_features {
        mesh.triangles
            .par_iter()
            .map(|t| {
                if t.iter().all(|&v| (v as usize) < mesh.positions.len()) {
                    face_normal(mesh.corner_positions(t))
                } else {
                    DVec3::ZERO
                }
            })
            .collect()
    } else {
        Vec::new()
    };
    let mut edges = Vec::new();
    let mut flags = Vec::new();
    table.for_each(|a, b, hs| {
        let mut fl = EdgeFlags::default();
        match hs.len() {
            1 => fl |= EdgeFlags::BOUNDARY,
            2 => {
                if preserve_features
                    && dihedral_deg(mesh, &normals, hs[0].1, hs[1].1) > feature_angle_deg
                {
                    fl |= EdgeFlags::SHARP;
                }
            }
            _ => fl |= EdgeFlags::NON_MANIFOLD,
        }
        let label0 = mesh.face_label((hs[0].1 / 3) as usize);
        if hs[1..]
            .iter()
            .any(|h| mesh.face_label((h.1 / 3) as usize) != label0)
        {
            fl |= EdgeFlags::LABEL_BORDER;
        }
        if !seam_keys.is_empty()
            && seam_keys
                .binary_search(&crate::topology::edge_key(a, b))
                .is_ok()
        {
            fl |= EdgeFlags::SEAM;
        }
        if !fl.is_empty() {
            edges.push([a, b]);
            flags.push(fl);
        }
    });
    (edges, flags)
}
