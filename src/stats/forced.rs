//! Forced edges: output edges whose length the input dictates, counted apart
//! from the free ones, so that the band says how well the remesher did where
//! it had a choice. An edge is forced when it belongs to
//!
//! - a small part kept as it came (its edges are the input's), or
//! - a feature line (crease, boundary, material border or seam, between two
//!   corners, or a closed loop) whose length ℓ no whole number of edges in
//!   the band can cover: no n (at least 3 for a closed loop) with ℓ/n in
//!   [4/5·t, 4/3·t], t the line's mean target. Lines shorter than 4/5·t,
//!   and those between 4/3·t and 8/5·t, are such lines.
//!
//! Corners of the output's lines are found as the feature detection finds
//! them on the input: feature valence other than 2, or a turn sharper than
//! the corner angle.

use serde::{Deserialize, Serialize};

use crate::mesh::{EdgeId, Handle, Mesh, VertexId, EDGE_FEATURE, EDGE_FROZEN};
use crate::sizing::{COLLAPSE_FACTOR, SPLIT_FACTOR};

/// The band split into forced and free edges.
#[derive(Clone, Copy, Debug, Default, PartialEq, Serialize, Deserialize)]
pub struct BandSplit {
    /// Edges whose length the input forces (see the module docs).
    pub forced_edges: u64,
    /// Fraction of the forced edges in the band.
    pub forced_within_band: f64,
    /// Edges the remesher chose freely.
    pub free_edges: u64,
    /// Fraction of the free edges in the band: the figure a remesher
    /// answers for.
    pub free_within_band: f64,
}

/// The forced and free band of `mesh` (a remesh output) against the
/// target length `t(v)` at each vertex, with corners at turns sharper than
/// `corner_angle_deg`.
pub fn band_split(mesh: &Mesh, t: impl Fn(VertexId) -> f64, corner_angle_deg: f64) -> BandSplit {
    let ne = mesh.edge_capacity();
    let nv = mesh.vertex_capacity();
    let mut forced = vec![false; ne];
    // Feature valence and the feature edges at each vertex.
    let mut feature_at: Vec<Vec<EdgeId>> = vec![Vec::new(); nv];
    for e in mesh.edges() {
        if mesh.edge_has_flag(e, EDGE_FROZEN) {
            forced[e.idx()] = true;
        } else if mesh.edge_has_flag(e, EDGE_FEATURE) {
            for v in mesh.edge_vertices(e) {
                feature_at[v.idx()].push(e);
            }
        }
    }
    let cos_corner = corner_angle_deg.to_radians().cos();
    let is_corner = |v: VertexId| -> bool {
        let at = &feature_at[v.idx()];
        if at.len() != 2 {
            return !at.is_empty();
        }
        let p = mesh.position(v);
        let other = |e: EdgeId| {
            let [a, b] = mesh.edge_vertices(e);
            mesh.position(if a == v { b } else { a })
        };
        let (d_in, d_out) = (p - other(at[0]), other(at[1]) - p);
        let l = d_in.length() * d_out.length();
        l > 0.0 && d_in.dot(d_out) < cos_corner * l
    };
    let mut seen = vec![false; ne];
    let walk_line = |start: VertexId, first: EdgeId, seen: &mut [bool]| -> (Vec<EdgeId>, bool) {
        // Follows the line from `start` along `first` until a corner, or
        // back to `start` (a closed loop).
        let mut edges = vec![first];
        seen[first.idx()] = true;
        let [a, b] = mesh.edge_vertices(first);
        let mut v = if a == start { b } else { a };
        loop {
            if v == start {
                return (edges, true);
            }
            if is_corner(v) {
                return (edges, false);
            }
            let Some(&next) = feature_at[v.idx()].iter().find(|e| !seen[e.idx()]) else {
                return (edges, false);
            };
            seen[next.idx()] = true;
            edges.push(next);
            let [a, b] = mesh.edge_vertices(next);
            v = if a == v { b } else { a };
        }
    };
    let judge = |edges: &[EdgeId], closed: bool, forced: &mut [bool]| {
        let (mut len, mut tsum) = (0.0, 0.0);
        for &e in edges {
            let [a, b] = mesh.edge_vertices(e);
            len += mesh.edge_length(e);
            tsum += 0.5 * (t(a) + t(b));
        }
        let tl = tsum / edges.len() as f64;
        let min_n = if closed { 3.0 } else { 1.0 };
        // The band of n edges covers [n·4/5·t, n·4/3·t]; the smallest n
        // whose upper end reaches ℓ is the only candidate to check.
        let n = (len / (SPLIT_FACTOR * tl)).ceil().max(min_n);
        let fits = len / n >= COLLAPSE_FACTOR * tl;
        if !fits {
            for &e in edges {
                forced[e.idx()] = true;
            }
        }
    };
    // Open lines, from each corner.
    for v in mesh.vertices() {
        if !is_corner(v) {
            continue;
        }
        for &e in &feature_at[v.idx()] {
            if !seen[e.idx()] {
                let (edges, closed) = walk_line(v, e, &mut seen);
                judge(&edges, closed, &mut forced);
            }
        }
    }
    // Closed loops without a corner.
    for v in mesh.vertices() {
        for &e in &feature_at[v.idx()] {
            if !seen[e.idx()] {
                let (edges, closed) = walk_line(v, e, &mut seen);
                judge(&edges, closed, &mut forced);
            }
        }
    }
    let mut split = BandSplit::default();
    let (mut forced_in, mut free_in) = (0u64, 0u64);
    for e in mesh.edges() {
        let [a, b] = mesh.edge_vertices(e);
        let local = 0.5 * (t(a) + t(b));
        let d = mesh.edge_length(e);
        let inside = d >= COLLAPSE_FACTOR * local && d <= SPLIT_FACTOR * local;
        if forced[e.idx()] {
            split.forced_edges += 1;
            forced_in += u64::from(inside);
        } else {
            split.free_edges += 1;
            free_in += u64::from(inside);
        }
    }
    let frac = |k: u64, n: u64| if n == 0 { 1.0 } else { k as f64 / n as f64 };
    split.forced_within_band = frac(forced_in, split.forced_edges);
    split.free_within_band = frac(free_in, split.free_edges);
    split
}

#[cfg(test)]
mod tests {
    use super::*;
    use glam::DVec3;

    #[test]
    fn a_box_edge_too_short_for_the_band_is_forced_and_the_rest_free() {
        // A 1 × 1 × 0.1 slab remeshed nowhere: its 0.1-long vertical creases
        // (between corners) cannot be in the band of L = 0.25.
        let slab = crate::shapes::cube(4, DVec3::ZERO, DVec3::new(1.0, 1.0, 0.1));
        let (mut mesh, _) = Mesh::from_trimesh(&slab).unwrap();
        let feats = crate::features::detect_features(&slab, &Default::default());
        let flagged: Vec<EdgeId> = mesh
            .edges()
            .filter(|&e| {
                let [a, b] = mesh.edge_vertices(e);
                feats.is_feature_edge(a.0, b.0)
            })
            .collect();
        for e in flagged {
            mesh.edge_flags[e] |= EDGE_FEATURE;
        }
        let s = band_split(&mesh, |_| 0.25, 45.0);
        // The slab's 4 vertical creases are 4 × 4 segments of 0.025.
        assert_eq!(s.forced_edges, 16);
        assert_eq!(s.forced_within_band, 0.0);
        assert_eq!(s.forced_edges + s.free_edges, mesh.edge_count() as u64);
    }
}
