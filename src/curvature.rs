//! Per-vertex principal curvatures of a [`TriMesh`], estimated after
//! S. Rusinkiewicz, "Estimating Curvatures and Their Derivatives on Triangle
//! Meshes" (3DPVT 2004): every face gets a second fundamental form fitted by
//! least squares to the differences of its corner normals along its three
//! edges; the face tensors are rotated into per-vertex tangent frames and
//! averaged with mixed Voronoi area weights (Meyer et al. 2003), then
//! diagonalised. This module also owns the light, feature-respecting
//! smoothing of the estimates and the curvature of feature polylines
//! ([`feature_curve_curvature`]), which the sizing field uses.
//!
//! # Features and sectors
//!
//! Normals are angle-weighted averages of face normals, but never across a
//! feature edge: the faces around a vertex are split into *sectors* (fans
//! bounded by feature edges, boundary edges, non-manifold edges and edges
//! whose two faces disagree on orientation), and every sector has its own
//! normal, frame and tensor. On a cube whose twelve creases are marked, every
//! face corner therefore sees only flat neighbours and every vertex, crease
//! and corner vertices included, reads κ = 0. Smoothing runs on the sector
//! graph, whose links are face edges inside one sector's fan, so values never
//! diffuse across a marked crease either.
//!
//! A vertex with several sectors reports the sector with the largest
//! `max(|k1|, |k2|)` — the maximum of the one-sided estimates. A cylinder
//! capped by a flat disc thus reads 1/r on its rim (the curved side governs
//! the edges there) while the disc's interior stays flat. Without a feature
//! predicate a sharp crease is treated as a very tightly curved region and
//! reads a large |κ| ≈ dihedral angle / edge length: that is right for a
//! crease the remesher will not preserve, which must be sampled finely to
//! stay within tolerance.
//!
//! # Conventions
//!
//! Curvatures are signed with respect to the (counter-clockwise, outward)
//! face orientation: a sphere of radius r has k1 = k2 = +1/r, the inside of
//! a torus tube has a negative k2. `k1 ≥ k2` by value; `dir1`, `dir2` are
//! the unit principal directions, tangent to the sector normal.

use crate::topology::{corner_fans, Csr};
use glam::DVec3;
use rayon::prelude::*;

use crate::trimesh::TriMesh;

/// A predicate saying whether the undirected edge between two vertices is a
/// feature (sharp crease) edge. It is called once per unique edge shared by
/// two faces, with the smaller vertex index first.
pub type FeatureEdgeFn<'a> = &'a (dyn Fn(u32, u32) -> bool + Sync);

/// Default number of smoothing passes applied by [`principal_curvatures`]:
/// two ½-weighted neighbour averages halve the worst noise of the per-face
/// fits on irregular meshes, while a smoothly varying curvature moves by
/// O(h²) only (`docs/tuning.md`).
pub const DEFAULT_SMOOTHING_PASSES: u32 = 2;

/// Turning angle (radians) at or above which a vertex of a feature or
/// boundary polyline is a corner rather than a sample of a smooth curve:
/// 45°, so a circle tessellated with more than eight segments is a curve and
/// a square's or octagon's corners are corners.
pub const CURVE_CORNER_ANGLE: f64 = std::f64::consts::FRAC_PI_4;

/// Principal curvatures and directions at one vertex.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct Curvature {
    /// The larger principal curvature (by signed value).
    pub k1: f64,
    /// The smaller principal curvature (by signed value).
    pub k2: f64,
    /// Unit principal direction of `k1`.
    pub dir1: DVec3,
    /// Unit principal direction of `k2`.
    pub dir2: DVec3,
}

impl Curvature {
    /// The curvature reported for a vertex with no usable face: zero, with
    /// the x and y axes as (meaningless) directions.
    pub const FLAT: Curvature = Curvature {
        k1: 0.0,
        k2: 0.0,
        dir1: DVec3::X,
        dir2: DVec3::Y,
    };

    /// The largest absolute principal curvature, `max(|k1|, |k2|)`: the
    /// quantity that bounds the chord error of edges through the vertex.
    #[inline]
    pub fn max_abs(&self) -> f64 {
        self.k1.abs().max(self.k2.abs())
    }

    /// Mean curvature `(k1 + k2) / 2`.
    #[inline]
    pub fn mean(&self) -> f64 {
        0.5 * (self.k1 + self.k2)
    }

    /// Gaussian curvature `k1 · k2`.
    #[inline]
    pub fn gaussian(&self) -> f64 {
        self.k1 * self.k2
    }
}

/// Options of [`principal_curvatures`].
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct CurvatureOptions {
    /// Number of smoothing passes over the principal values (0 disables).
    pub smoothing_passes: u32,
}

impl Default for CurvatureOptions {
    fn default() -> Self {
        Self {
            smoothing_passes: DEFAULT_SMOOTHING_PASSES,
        }
    }
}

/// Why curvature could not be estimated.
#[derive(Debug, thiserror::Error, Clone, PartialEq)]
pub enum CurvatureError {
    /// A triangle refers to a vertex that does not exist.
    #[error("triangle {face} has a vertex index out of range ({vertex_count} vertices)")]
    IndexOutOfRange {
        /// The offending triangle.
        face: usize,
        /// Number of vertices in the mesh.
        vertex_count: usize,
    },
    /// The mesh has more triangle corners than 32-bit corner ids can address.
    #[error("mesh too large: {faces} triangles")]
    TooLarge {
        /// Number of triangles.
        faces: usize,
    },
}

/// Estimates per-vertex principal curvatures (see the module docs for the
/// method, sign convention and feature handling).
///
/// `is_feature_edge`, when given, marks sharp edges across which normals,
/// tensors and smoothing must not be shared. Degenerate faces (repeated
/// vertices, zero or non-finite area) contribute nothing; a vertex with no
/// usable face reports [`Curvature::FLAT`] unless a neighbour fills it in.
pub fn principal_curvatures(
    mesh: &TriMesh,
    opts: &CurvatureOptions,
    is_feature_edge: Option<FeatureEdgeFn>,
) -> Result<Vec<Curvature>, CurvatureError> {
    let topo = Topology::new(mesh, is_feature_edge)?;
    Ok(curvatures_on(mesh, &topo, opts))
}

/// Curvature of the feature and boundary polylines at their vertices.
///
/// Curve edges are the edges marked by `is_feature_edge`, boundary edges and
/// non-manifold edges. At a vertex with exactly two curve edges whose
/// turning angle is below [`CURVE_CORNER_ANGLE`], the value is the
/// reciprocal radius of the circle through the vertex and its two curve
/// neighbours (exact for points sampled from a circle). Every other vertex —
/// off the curves, at a corner, an end or a junction — gets 0.
pub fn feature_curve_curvature(
    mesh: &TriMesh,
    is_feature_edge: Option<FeatureEdgeFn>,
) -> Result<Vec<f64>, CurvatureError> {
    let topo = Topology::new(mesh, is_feature_edge)?;
    Ok(curve_curvature_on(mesh, &topo))
}

// ---------------------------------------------------------------------------
// Topology: corners grouped by vertex and by sector, and the curve edges.

const NONE: u32 = u32::MAX;

/// Connectivity shared by the curvature estimator and the sizing field,
/// built once in O(n) plus tiny per-vertex sorts.
///
/// A corner is `3·face + k`. Corners of faces with a repeated vertex index
/// belong to no vertex list and no sector.
pub(crate) struct Topology {
    /// Faces with three distinct vertex indices.
    face_distinct: Vec<bool>,
    /// CSR offsets into `corners` per vertex (length `nv + 1`).
    pub(crate) vertex_corner_start: Vec<u32>,
    /// Corner ids grouped by vertex and, within a vertex, by sector.
    pub(crate) corners: Vec<u32>,
    /// CSR offsets into `corners` per sector (length `sectors + 1`).
    sector_start: Vec<u32>,
    /// CSR offsets into the sector ids per vertex (length `nv + 1`).
    vertex_sector_start: Vec<u32>,
    /// Sector id of every corner ([`NONE`] for corners of skipped faces).
    corner_sector: Vec<u32>,
    /// Boundary, feature and non-manifold edges, as `[lo, hi]`.
    pub(crate) curve_edges: Vec<[u32; 2]>,
    /// Interior, consistently oriented, non-feature edges as `[lo, hi, f0, f1]`
    /// with their two faces (the sizing field's crease bound).
    pub(crate) smooth_edges: Vec<[u32; 4]>,
}

#[inline]
fn next(c: u32) -> u32 {
    if c % 3 == 2 {
        c - 2
    } else {
        c + 1
    }
}

#[inline]
fn prev(c: u32) -> u32 {
    if c % 3 == 0 {
        c + 2
    } else {
        c - 1
    }
}

impl Topology {
    pub(crate) fn new(
        mesh: &TriMesh,
        is_feature_edge: Option<FeatureEdgeFn>,
    ) -> Result<Self, CurvatureError> {
        let nv = mesh.positions.len();
        let nf = mesh.triangles.len();
        if nf >= (u32::MAX / 3) as usize || nv >= u32::MAX as usize {
            return Err(CurvatureError::TooLarge { faces: nf });
        }
        if let Some(face) = mesh
            .triangles
            .iter()
            .position(|t| t.iter().any(|&v| v as usize >= nv))
        {
            return Err(CurvatureError::IndexOutOfRange {
                face,
                vertex_count: nv,
            });
        }
        let tri = &mesh.triangles;
        let face_distinct: Vec<bool> = tri
            .iter()
            .map(|t| t[0] != t[1] && t[1] != t[2] && t[2] != t[0])
            .collect();
        let vertex_of = |c: u32| tri[(c / 3) as usize][(c % 3) as usize];

        // Sectors are corner fans joined across smooth, consistently
        // oriented edges; every other edge bounds a sector and is a curve.
        let mut curve_edges = Vec::new();
        let mut smooth_edges = Vec::new();
        let sectors = corner_fans(tri, nv, |lo, hi, run| match *run {
            [(_, h0), (_, h1)] => {
                if is_feature_edge.is_some_and(|p| p(lo, hi)) {
                    curve_edges.push([lo, hi]);
                    false
                } else if vertex_of(h0) != vertex_of(h1) {
                    smooth_edges.push([lo, hi, h0 / 3, h1 / 3]);
                    true
                } else {
                    false
                }
            }
            _ => {
                curve_edges.push([lo, hi]);
                false
            }
        });

        // Corners grouped by vertex, then by union-find root (= sector).
        let (vertex_corner_start, mut corners) = Csr::from_pairs(nv, || {
            tri.iter()
                .enumerate()
                .filter(|&(f, _)| face_distinct[f])
                .flat_map(|(f, t)| (0..3).map(move |k| (t[k], (3 * f + k) as u32)))
        })
        .into_parts();
        let root = sectors.into_roots();
        let mut corner_sector = vec![NONE; 3 * nf];
        let mut sector_start = Vec::with_capacity(nv + 1);
        let mut vertex_sector_start = Vec::with_capacity(nv + 1);
        for v in 0..nv {
            vertex_sector_start.push(sector_start.len() as u32);
            let (s, e) = (
                vertex_corner_start[v] as usize,
                vertex_corner_start[v + 1] as usize,
            );
            let bucket = &mut corners[s..e];
            bucket.sort_unstable_by_key(|&c| (root[c as usize], c));
            let mut last_root = NONE;
            for (i, &c) in bucket.iter().enumerate() {
                let r = root[c as usize];
                if r != last_root {
                    sector_start.push((s + i) as u32);
                    last_root = r;
                }
                corner_sector[c as usize] = (sector_start.len() - 1) as u32;
            }
        }
        vertex_sector_start.push(sector_start.len() as u32);
        sector_start.push(corners.len() as u32);

        Ok(Self {
            face_distinct,
            vertex_corner_start,
            corners,
            sector_start,
            vertex_sector_start,
            corner_sector,
            curve_edges,
            smooth_edges,
        })
    }

    fn sector_count(&self) -> usize {
        self.sector_start.len() - 1
    }

    fn sector_corners(&self, s: usize) -> &[u32] {
        &self.corners[self.sector_start[s] as usize..self.sector_start[s + 1] as usize]
    }

    /// Number of sectors at vertex `v`.
    pub(crate) fn sectors_at(&self, v: usize) -> usize {
        (self.vertex_sector_start[v + 1] - self.vertex_sector_start[v]) as usize
    }

    /// Corners around vertex `v` (all sectors).
    pub(crate) fn vertex_corners(&self, v: usize) -> &[u32] {
        &self.corners
            [self.vertex_corner_start[v] as usize..self.vertex_corner_start[v + 1] as usize]
    }
}

// ---------------------------------------------------------------------------
// The estimator. Passes alternate between faces (streaming, writing one
// record per corner) and sectors (gathering their corners), so that no pass
// reads large per-face records at random.

/// Frame and weights of a usable face: unit normal `n`, unit first-edge
/// direction `u`, `v = n × u`, `|cross|` (twice the area) and the
/// cotangent of each corner's angle.
struct FaceFrame {
    n: DVec3,
    u: DVec3,
    v: DVec3,
    cross_len: f64,
    cot: [f64; 3],
}

impl FaceFrame {
    /// `None` for zero, sliver-to-machine-precision and non-finite faces,
    /// whose normals and cotangents are noise.
    #[inline]
    fn new(p: [DVec3; 3]) -> Option<Self> {
        let e01 = p[1] - p[0];
        let cross = e01.cross(p[2] - p[0]);
        let len = cross.length();
        let scale = e01
            .length_squared()
            .max((p[2] - p[1]).length_squared())
            .max((p[0] - p[2]).length_squared());
        let well_formed = len > 1e-12 * scale && len.is_finite();
        if !well_formed {
            return None;
        }
        let n = cross / len;
        let u = e01.normalize();
        let mut cot = [0.0; 3];
        for (i, c) in cot.iter_mut().enumerate() {
            *c = (p[(i + 1) % 3] - p[i]).dot(p[(i + 2) % 3] - p[i]) / len;
        }
        Some(Self {
            n,
            u,
            v: n.cross(u),
            cross_len: len,
            cot,
        })
    }

    /// Interior angles, the weights of the face normal in corner normals.
    #[inline]
    fn angles(&self) -> [f64; 3] {
        // cot = cos·|a||b| / (sin·|a||b|), so atan2(1, cot) is the angle.
        self.cot.map(|c| 1f64.atan2(c))
    }

    /// Meyer's mixed Voronoi area of each corner: the Voronoi region for a
    /// non-obtuse triangle, else 1/2 of the area to the obtuse corner and
    /// 1/4 to the others (the circumcentre lies outside).
    #[inline]
    fn voronoi(&self, p: [DVec3; 3]) -> [f64; 3] {
        let area = 0.5 * self.cross_len;
        let cot = self.cot;
        if let Some(obtuse) = (0..3).find(|&i| cot[i] < 0.0) {
            let mut w = [0.25 * area; 3];
            w[obtuse] = 0.5 * area;
            return w;
        }
        // Squared length of the edge opposite each corner.
        let l2 = [
            (p[2] - p[1]).length_squared(),
            (p[0] - p[2]).length_squared(),
            (p[1] - p[0]).length_squared(),
        ];
        [
            0.125 * (l2[1] * cot[1] + l2[2] * cot[2]),
            0.125 * (l2[2] * cot[2] + l2[0] * cot[0]),
            0.125 * (l2[0] * cot[0] + l2[1] * cot[1]),
        ]
    }
}

/// Fits the face's second fundamental form `[[e, f], [f, g]]` in its frame
/// `(u, v)` so that `II · (e·u, e·v) ≈ (Δn·u, Δn·v)` along the three edges,
/// by least squares. `None` when the normal equations are singular.
fn fit_face_tensor(p: [DVec3; 3], nrm: [DVec3; 3], u: DVec3, v: DVec3) -> Option<[f64; 3]> {
    let (mut a, mut b, mut c) = (0.0, 0.0, 0.0);
    let (mut r0, mut r1, mut r2) = (0.0, 0.0, 0.0);
    for i in 0..3 {
        let (j, k) = ((i + 1) % 3, (i + 2) % 3);
        let e = p[k] - p[j];
        let dn = nrm[k] - nrm[j];
        let (x, y) = (e.dot(u), e.dot(v));
        let (nu, nv) = (dn.dot(u), dn.dot(v));
        a += x * x;
        b += x * y;
        c += y * y;
        r0 += x * nu;
        r1 += y * nu + x * nv;
        r2 += y * nv;
    }
    // Normal matrix [[a, b, 0], [b, a + c, b], [0, b, c]]; its determinant
    // factors as (a + c)(ac − b²), and ac − b² vanishes only when all edges
    // are parallel.
    let d = a + c;
    let gram = a * c - b * b;
    let independent = gram > 1e-12 * d * d;
    if !independent {
        return None;
    }
    let det = d * gram;
    let (c00, c01, c02) = (d * c - b * b, -b * c, b * b);
    let (c11, c12, c22) = (a * c, -a * b, a * d - b * b);
    let e = (c00 * r0 + c01 * r1 + c02 * r2) / det;
    let f = (c01 * r0 + c11 * r1 + c12 * r2) / det;
    let g = (c02 * r0 + c12 * r1 + c22 * r2) / det;
    (e.is_finite() && f.is_finite() && g.is_finite()).then_some([e, f, g])
}

/// Rotates the tangent frame `(u, v)` of normal `from` about `from × to` so
/// that it becomes tangent to `to`. Only valid for `u, v ⟂ from`, which is
/// all it is used for.
#[inline]
fn rotate_frame(u: DVec3, v: DVec3, from: DVec3, to: DVec3) -> (DVec3, DVec3) {
    let c = from.dot(to);
    if c <= -1.0 + 1e-12 {
        return (-u, -v);
    }
    let perp = to - c * from;
    let k = (from + to) / (1.0 + c);
    (u - k * perp.dot(u), v - k * perp.dot(v))
}

/// The tangent frame of a sector, a pure function of its unit normal so it
/// need not be stored.
#[inline]
fn tangent_frame(n: DVec3) -> (DVec3, DVec3) {
    n.any_orthonormal_pair()
}

/// Principal values `[k1, k2]`, `k1 ≥ k2`, of the symmetric tensor
/// `[[e, f], [f, g]]`.
#[inline]
fn principal_values(e: f64, f: f64, g: f64) -> [f64; 2] {
    let h = 0.5 * (e + g);
    let r = (0.5 * (e - g)).hypot(f);
    [h + r, h - r]
}

/// Unit principal directions `(dir1, dir2)` of the tensor `[[e, f], [f, g]]`
/// given in the frame `(u, v)` of normal `n`; `dir1` belongs to the larger
/// value, at angle θ with tan 2θ = 2f / (e − g) from `u`.
fn principal_directions(e: f64, f: f64, g: f64, u: DVec3, v: DVec3, n: DVec3) -> (DVec3, DVec3) {
    let theta = 0.5 * (2.0 * f).atan2(e - g);
    let dir1 = (theta.cos() * u + theta.sin() * v).normalize_or(u);
    (dir1, n.cross(dir1).normalize_or(v))
}

/// Principal values of a sector; NaN marks a sector without estimate.
type Pair = [f64; 2];
const NO_PAIR: Pair = [f64::NAN; 2];

pub(crate) fn curvatures_on(
    mesh: &TriMesh,
    topo: &Topology,
    opts: &CurvatureOptions,
) -> Vec<Curvature> {
    let tri = &mesh.triangles;
    let ns = topo.sector_count();
    let usable = |f: usize| topo.face_distinct[f];

    // Faces: angle-weighted normal of every corner.
    let mut corner_normal = vec![DVec3::ZERO; 3 * tri.len()];
    corner_normal
        .par_chunks_mut(3)
        .zip(tri.par_iter())
        .enumerate()
        .for_each(|(f, (out, t))| {
            if !usable(f) {
                return;
            }
            if let Some(fr) = FaceFrame::new(mesh.corner_positions(t)) {
                for (o, a) in out.iter_mut().zip(fr.angles()) {
                    *o = a * fr.n;
                }
            }
        });
    // Sectors: unit normals (zero when the fan has no usable face).
    let sector_normal: Vec<DVec3> = (0..ns)
        .into_par_iter()
        .map(|s| {
            topo.sector_corners(s)
                .iter()
                .map(|&c| corner_normal[c as usize])
                .sum::<DVec3>()
                .normalize_or_zero()
        })
        .collect();
    drop(corner_normal);

    // Faces: fit the tensor and express it in each corner's sector frame,
    // weighted by the corner's Voronoi area: [w·e, w·f, w·g, w] per corner.
    let mut corner_tensor = vec![[0.0f64; 4]; 3 * tri.len()];
    corner_tensor
        .par_chunks_mut(3)
        .zip(tri.par_iter())
        .enumerate()
        .for_each(|(f, (out, t))| {
            if !usable(f) {
                return;
            }
            let p = mesh.corner_positions(t);
            let Some(fr) = FaceFrame::new(p) else {
                return;
            };
            let nrm = [0, 1, 2].map(|k| sector_normal[topo.corner_sector[3 * f + k] as usize]);
            if nrm.contains(&DVec3::ZERO) {
                return;
            }
            let Some([e, ff, g]) = fit_face_tensor(p, nrm, fr.u, fr.v) else {
                return;
            };
            let w = fr.voronoi(p);
            for k in 0..3 {
                let (up, vp) = tangent_frame(nrm[k]);
                let (ur, vr) = rotate_frame(up, vp, nrm[k], fr.n);
                let (a, b) = (ur.dot(fr.u), ur.dot(fr.v));
                let (c, d) = (vr.dot(fr.u), vr.dot(fr.v));
                out[k] = [
                    w[k] * (a * a * e + 2.0 * a * b * ff + b * b * g),
                    w[k] * (a * c * e + (a * d + b * c) * ff + b * d * g),
                    w[k] * (c * c * e + 2.0 * c * d * ff + d * d * g),
                    w[k],
                ];
            }
        });
    // Sectors: the weighted mean tensor, kept as [e, f, g] in the sector
    // frame for the directions, and its principal values.
    let sector_tensor: Vec<[f64; 3]> = (0..ns)
        .into_par_iter()
        .map(|s| {
            let mut acc = [0.0; 4];
            for &c in topo.sector_corners(s) {
                let t = &corner_tensor[c as usize];
                for i in 0..4 {
                    acc[i] += t[i];
                }
            }
            let weighted = acc[3] > 0.0;
            if weighted {
                [acc[0] / acc[3], acc[1] / acc[3], acc[2] / acc[3]]
            } else {
                [f64::NAN; 3]
            }
        })
        .collect();
    drop(corner_tensor);
    let mut values: Vec<Pair> = sector_tensor
        .par_iter()
        .map(|&[e, f, g]| {
            let pair = principal_values(e, f, g);
            if pair[0].is_finite() && pair[1].is_finite() {
                pair
            } else {
                NO_PAIR
            }
        })
        .collect();

    // Neighbour average over the sector graph: the other two corners of each
    // face in the sector's fan. Interior fan edges are seen from both of
    // their faces and so weigh twice a fan-boundary edge, which is what a
    // face-ring average does.
    let neighbour_mean = |values: &[Pair], s: usize| -> Option<Pair> {
        let (mut a, mut b, mut w) = (0.0, 0.0, 0.0);
        for &c in topo.sector_corners(s) {
            for o in [next(c), prev(c)] {
                let q = values[topo.corner_sector[o as usize] as usize];
                if !q[0].is_nan() {
                    a += q[0];
                    b += q[1];
                    w += 1.0;
                }
            }
        }
        (w > 0.0).then(|| [a / w, b / w])
    };
    // One fill-in pass gives sectors whose faces are all degenerate the mean
    // of their valid neighbours (directions: the sector frame).
    if values.iter().any(|p| p[0].is_nan()) {
        values = (0..ns)
            .into_par_iter()
            .map(|s| {
                let cur = values[s];
                if !cur[0].is_nan() || sector_normal[s] == DVec3::ZERO {
                    return cur;
                }
                neighbour_mean(&values, s).unwrap_or(cur)
            })
            .collect();
    }
    for _ in 0..opts.smoothing_passes {
        values = (0..ns)
            .into_par_iter()
            .map(|s| {
                let cur = values[s];
                if cur[0].is_nan() {
                    return cur;
                }
                // Averaging the ordered values keeps k1 ≥ k2.
                neighbour_mean(&values, s)
                    .map_or(cur, |m| [0.5 * (cur[0] + m[0]), 0.5 * (cur[1] + m[1])])
            })
            .collect();
    }

    (0..mesh.positions.len())
        .into_par_iter()
        .map(|v| {
            let range =
                topo.vertex_sector_start[v] as usize..topo.vertex_sector_start[v + 1] as usize;
            let Some(s) = range.filter(|&s| !values[s][0].is_nan()).max_by(|&a, &b| {
                let ka = values[a][0].abs().max(values[a][1].abs());
                let kb = values[b][0].abs().max(values[b][1].abs());
                ka.total_cmp(&kb)
            }) else {
                return Curvature::FLAT;
            };
            let n = sector_normal[s];
            let (u, v) = tangent_frame(n);
            let [e, f, g] = sector_tensor[s];
            let (dir1, dir2) = if e.is_nan() {
                (u, v)
            } else {
                principal_directions(e, f, g, u, v, n)
            };
            Curvature {
                k1: values[s][0],
                k2: values[s][1],
                dir1,
                dir2,
            }
        })
        .collect()
}

pub(crate) fn curve_curvature_on(mesh: &TriMesh, topo: &Topology) -> Vec<f64> {
    let nv = mesh.positions.len();
    let mut count = vec![0u8; nv];
    let mut nbr = vec![[NONE; 2]; nv];
    for &[a, b] in &topo.curve_edges {
        for (v, o) in [(a, b), (b, a)] {
            let slot = &mut count[v as usize];
            if (*slot as usize) < 2 {
                nbr[v as usize][*slot as usize] = o;
            }
            *slot = slot.saturating_add(1);
        }
    }
    let pos = &mesh.positions;
    (0..nv)
        .into_par_iter()
        .map(|v| {
            if count[v] != 2 {
                return 0.0;
            }
            let p = pos[v];
            let (a, b) = (pos[nbr[v][0] as usize] - p, pos[nbr[v][1] as usize] - p);
            let (la, lb, lab) = (a.length(), b.length(), (a - b).length());
            // Turning angle between the incoming and outgoing directions.
            let cos_turn = -a.dot(b) / (la * lb);
            let smooth_turn = cos_turn > CURVE_CORNER_ANGLE.cos();
            if !smooth_turn {
                return 0.0;
            }
            let k = 2.0 * a.cross(b).length() / (la * lb * lab);
            if k.is_finite() {
                k
            } else {
                0.0
            }
        })
        .collect()
}
