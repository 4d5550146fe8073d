//! Attribute transfer: the input's per-corner attributes (texture
//! coordinates, colours) sampled onto the remeshed surface, chart by chart,
//! so that nothing bleeds across a seam.
//!
//! The rule: the output corners around a vertex fall into wedges, separated
//! by the output's seam edges; each wedge takes the input's attribute at
//! the input point closest to the vertex, read on the input's side of the
//! seam that the wedge lies on. The side is found by starting from the
//! input face closest to a point inside one of the wedge's faces (its
//! centroid) and walking on the input towards the vertex, across edges that
//! are not seams, boundaries or non-manifold: a walk never leaves its chart,
//! and where the vertex sits on a seam (seams are features, so output seam
//! vertices lie on input seam lines) the walk stops on the seam with that
//! side's value. Every corner of one wedge gets the same value, so writers
//! split a vertex exactly where the attribute differs.
//!
//! Seams are the edges across which a corner value differs, and also the
//! folds of a texture coordinate set: edges whose two faces have UV
//! orientations of opposite sign (a mirrored half of a symmetric model that
//! shares the other half's texels). An output triangle that straddled a fold
//! would cover texels of both halves folded onto each other; kept as a
//! feature, the fold stays an edge line of the output.
//!
//! Carried normals (`normals: "transfer"`) are the one channel compared
//! with a tolerance: two corners' normals within 1° are the same
//! ([`crate::features::normals::HARD_EDGE_COS`]), so that a normal written
//! twice with rounding makes no seam, and only authored hard edges do.

use glam::DVec3;
use rayon::prelude::*;

use crate::appearance::VertexAttributes;
use crate::bvh::{closest_point_on_triangle, SurfaceIndex};
use crate::topology::{corner_fans, EdgeTable};
use crate::trimesh::{position_key, weld_positions, TriMesh};

/// A texture-space triangle with less signed area than this is degenerate
/// (the statistics and the remesher's texture guard agree on it).
pub const UV_DEGENERATE_AREA: f64 = 1e-12;

/// No face across an edge: a boundary, a non-manifold edge or a seam.
const NONE: u32 = u32::MAX;

/// The most faces a walk visits before it settles for the best so far
/// (`docs/tuning.md`).
const MAX_WALK: usize = 256;

/// The input's attributes, prepared for sampling: per face corner values
/// over the welded input, the face adjacency that walks use (cut at
/// seams), the input's seam edges and a closest-point index.
pub struct SourceAttributes {
    layout: VertexAttributes,
    width: usize,
    /// `width` floats per corner of each kept face.
    corner_values: Vec<f32>,
    /// Per kept face, the face across the edge from corner k to k + 1.
    across: Vec<[u32; 3]>,
    /// Per kept face, the input face (index into the source) it came from.
    source_face: Vec<u32>,
    /// Per kept face, its label (material and part).
    label: Vec<u32>,
    /// Seam edges as welded-position pairs, a < b.
    seams: Vec<[u32; 2]>,
    index: SurfaceIndex,
}

impl SourceAttributes {
    /// Prepares the attributes of `source`; `None` when it has none.
    /// Bit-identical positions are merged first, so corners of different
    /// vertices at one point meet; faces that weld to fewer than three
    /// corners or have no area are left out.
    pub fn new(source: &TriMesh) -> Option<Self> {
        let layout = &source.attributes;
        if layout.is_empty() || layout.check(source.positions.len()).is_err() {
            return None;
        }
        let width = layout.width();
        let n = source.positions.len();
        let (weld, positions) = weld_positions(&source.positions);
        let mut tris = Vec::with_capacity(source.triangles.len());
        let mut source_face = Vec::with_capacity(source.triangles.len());
        let mut corner_values = Vec::with_capacity(source.triangles.len() * 3 * width);
        for (f, t) in source.triangles.iter().enumerate() {
            if t.iter().any(|&v| v as usize >= n) {
                continue;
            }
            let w = t.map(|v| weld[v as usize]);
            if w[0] == w[1] || w[1] == w[2] || w[0] == w[2] {
                continue;
            }
            let p = w.map(|v| positions[v as usize]);
            if (p[1] - p[0]).cross(p[2] - p[0]) == DVec3::ZERO {
                continue;
            }
            tris.push(w);
            source_face.push(f as u32);
            for &v in t {
                layout.gather(v as usize, &mut corner_values);
            }
        }
        let mut across = vec![[NONE; 3]; tris.len()];
        let mut seams = Vec::new();
        // Values compared bit for bit; carried normals come after them.
        let plain = width - if layout.normals.is_empty() { 0 } else { 3 };
        let edges = EdgeTable::new(&tris, positions.len());
        let value = |h: u32, at: u32| -> &[f32] {
            let f = (h / 3) as usize;
            let k = (0..3).find(|&k| tris[f][k] == at).unwrap_or(0);
            &corner_values[(3 * f + k) * width..][..width]
        };
        edges.for_each(|a, b, run| {
            if let [(_, h0), (_, h1)] = *run {
                let same = |x: &[f32], y: &[f32]| {
                    let (xv, xn) = x.split_at(plain);
                    let (yv, yn) = y.split_at(plain);
                    xv.iter().zip(yv).all(|(p, q)| p.to_bits() == q.to_bits())
                        && (xn.is_empty() || same_normal(xn, yn))
                };
                let sets = layout.texcoords.len();
                let folded = (0..sets).any(|s| {
                    let (x, y) = (
                        uv_area(&corner_values, width, h0 / 3, s),
                        uv_area(&corner_values, width, h1 / 3, s),
                    );
                    x * y < 0.0
                });
                if !folded && same(value(h0, a), value(h1, a)) && same(value(h0, b), value(h1, b)) {
                    across[(h0 / 3) as usize][(h0 % 3) as usize] = h1 / 3;
                    across[(h1 / 3) as usize][(h1 % 3) as usize] = h0 / 3;
                } else {
                    seams.push([a, b]);
                }
            }
        });
        let index = SurfaceIndex::new(&positions, &tris);
        let label = source_face
            .iter()
            .map(|&f| source.face_label(f as usize))
            .collect();
        Some(Self {
            layout: layout.empty_like(),
            width,
            corner_values,
            across,
            source_face,
            label,
            seams,
            index,
        })
    }

    /// The attribute layout (empty lists): which sets and whether a colour.
    pub fn layout(&self) -> &VertexAttributes {
        &self.layout
    }

    /// Floats per corner.
    pub fn width(&self) -> usize {
        self.width
    }

    /// The input's seam edges, as pairs of welded positions: edges with two
    /// faces whose corners disagree at either end.
    pub fn seam_segments(&self) -> Vec<[DVec3; 2]> {
        let p = self.index.positions();
        self.seams
            .iter()
            .map(|&[a, b]| [p[a as usize], p[b as usize]])
            .collect()
    }

    /// Number of seam edges of the input.
    pub fn seam_count(&self) -> usize {
        self.seams.len()
    }

    /// The seams of `mesh` (whose positions are the input's, e.g. the
    /// repaired input): its vertex pairs whose positions form an input
    /// seam edge.
    pub fn seams_on(&self, mesh: &TriMesh) -> Vec<[u32; 2]> {
        let welded = self.index.positions();
        let by_position: std::collections::HashMap<[u64; 3], u32> = welded
            .iter()
            .enumerate()
            .map(|(i, &p)| (position_key(p), i as u32))
            .collect();
        let mut seams = self.seams.clone();
        seams.sort_unstable();
        let id: Vec<u32> = mesh
            .positions
            .iter()
            .map(|&p| by_position.get(&position_key(p)).copied().unwrap_or(NONE))
            .collect();
        let mut out = Vec::new();
        EdgeTable::new(&mesh.triangles, mesh.positions.len()).for_each(|a, b, _| {
            let (wa, wb) = (id[a as usize], id[b as usize]);
            if wa != NONE && wb != NONE && seams.binary_search(&[wa.min(wb), wa.max(wb)]).is_ok() {
                out.push([a, b]);
            }
        });
        out
    }

    /// The attribute values of each corner of `out` (`width` floats per
    /// corner, face by face), its corners grouped into wedges by its seam
    /// edges `out_seams` (vertex pairs, either order).
    pub fn sample(&self, out: &TriMesh, out_seams: &[[u32; 2]]) -> Vec<f32> {
        let tris = &out.triangles;
        let nc = tris.len() * 3;
        let mut seam_keys: Vec<u64> = out_seams
            .iter()
            .map(|&[a, b]| crate::topology::edge_key(a, b))
            .collect();
        seam_keys.sort_unstable();
        let wedges = corner_fans(tris, out.positions.len(), |a, b, _| {
            let key = crate::topology::edge_key(a, b);
            seam_keys.binary_search(&key).is_err()
        });
        let roots = wedges.into_roots();
        let mut first = vec![NONE; nc];
        let mut reps = Vec::new();
        for (c, &r) in roots.iter().enumerate() {
            let r = r as usize;
            if first[r] == NONE {
                first[r] = reps.len() as u32;
                reps.push(c as u32);
            }
        }
        let w = self.width;
        let values: Vec<f32> = reps
            .par_iter()
            .flat_map_iter(|&c| {
                let t = tris[(c / 3) as usize];
                let p = out.corner_positions(&t);
                let v = p[(c % 3) as usize];
                let label = out.face_label((c / 3) as usize);
                self.value_at(v, (p[0] + p[1] + p[2]) / 3.0, face_normal(p), label)
            })
            .collect();
        let mut out_values = vec![0f32; nc * w];
        for c in 0..nc {
            let k = first[roots[c] as usize] as usize;
            out_values[c * w..][..w].copy_from_slice(&values[k * w..][..w]);
        }
        out_values
    }

    /// The attributes at `v`, read on the side of `inside`, a point of the
    /// wedge's face whose normal is `normal` and whose label is `label`.
    pub fn value_at(&self, v: DVec3, inside: DVec3, normal: DVec3, label: u32) -> Vec<f32> {
        self.lookup(v, inside, normal, label).0
    }

    /// [`Self::value_at`], with the kept input face the value was read on
    /// (`None` when the input has no face to read).
    pub fn lookup(
        &self,
        v: DVec3,
        inside: DVec3,
        normal: DVec3,
        label: u32,
    ) -> (Vec<f32>, Option<u32>) {
        let Some(start) = self.start(inside, normal, label) else {
            return (vec![0.0; self.width], None);
        };
        let (face, bary) = self.walk(start.face, v);
        let base = 3 * face as usize * self.width;
        let values = (0..self.width)
            .map(|i| {
                let c = |k: usize| f64::from(self.corner_values[base + k * self.width + i]);
                (bary.x * c(0) + bary.y * c(1) + bary.z * c(2)) as f32
            })
            .collect();
        (values, Some(face))
    }

    /// The signed UV area, in set `set`, of kept input face `face`.
    pub fn face_uv_area(&self, face: u32, set: usize) -> f64 {
        uv_area(&self.corner_values, self.width, face, set)
    }

    /// The input face where a lookup for a face of label `label` with
    /// normal `normal` starts: the closest to `inside` among the input's
    /// faces of that label facing the same side, else of that label, else
    /// any. An output face takes its attributes from input faces of its own
    /// label, whose borders are features: where parts of a scene touch or
    /// pass through each other, the closest input face may belong to
    /// another part, with another texture.
    fn start(&self, inside: DVec3, normal: DVec3, label: u32) -> Option<crate::bvh::ClosestPoint> {
        let idx = &self.index;
        let ours = |f: u32| self.label[f as usize] == label;
        idx.closest_point_filtered(inside, |f| ours(f) && idx.face_normal(f).dot(normal) > 0.0)
            .or_else(|| idx.closest_point_filtered(inside, ours))
            .or_else(|| idx.closest_point(inside))
    }

    /// From face `f`, the face of its chart nearest to `p` by a descent
    /// over edge neighbours (moves that keep the distance are allowed, so
    /// a walk can go round a vertex fan), with the barycentric coordinates
    /// of the closest point on it.
    fn walk(&self, f: u32, p: DVec3) -> (u32, DVec3) {
        let idx = &self.index;
        let closest = |f: u32| {
            let t = idx.triangles()[f as usize];
            let q = t.map(|v| idx.positions()[v as usize]);
            let (pt, bary) = closest_point_on_triangle(p, q[0], q[1], q[2]);
            (pt.distance_squared(p), bary)
        };
        let mut visited = vec![f];
        let (mut cur, (mut d, mut bary)) = (f, closest(f));
        for _ in 0..MAX_WALK {
            let mut best: Option<(u32, f64, DVec3)> = None;
            for &g in &self.across[cur as usize] {
                if g == NONE || visited.contains(&g) {
                    continue;
                }
                let (dg, bg) = closest(g);
                if best.is_none_or(|b| dg < b.1) {
                    best = Some((g, dg, bg));
                }
            }
            match best {
                Some((g, dg, bg)) if dg <= d => {
                    visited.push(g);
                    if dg < d {
                        visited.clear();
                        visited.push(cur);
                        visited.push(g);
                    }
                    (cur, d, bary) = (g, dg, bg);
                }
                _ => break,
            }
        }
        (cur, bary)
    }

    /// The closest input point to `p` among the input's faces of label
    /// `label` (any face when it has none): its kept face and the texture
    /// coordinates of set `set` there.
    pub fn closest_texcoord(&self, p: DVec3, set: usize, label: u32) -> Option<(u32, [f64; 2])> {
        let cp = self
            .index
            .closest_point_filtered(p, |f| self.label[f as usize] == label)
            .or_else(|| self.index.closest_point(p))?;
        let base = 3 * cp.face as usize * self.width + 2 * set;
        let b = cp.barycentric;
        let at = |k: usize, c: usize| f64::from(self.corner_values[base + k * self.width + c]);
        Some((
            cp.face,
            [0, 1].map(|c| b.x * at(0, c) + b.y * at(1, c) + b.z * at(2, c)),
        ))
    }

    /// The signed UV area, in set `set`, of the input face where a lookup
    /// for a face at `p` with normal `normal` and label `label` starts.
    pub fn uv_orientation_at(
        &self,
        p: DVec3,
        normal: DVec3,
        set: usize,
        label: u32,
    ) -> Option<f64> {
        let cp = self.start(p, normal, label)?;
        Some(uv_area(&self.corner_values, self.width, cp.face, set))
    }

    /// The input face (index into the source's triangles) of kept face `f`.
    pub fn source_face(&self, f: u32) -> u32 {
        self.source_face[f as usize]
    }
}

/// Signed area of kept face `f` in texture coordinate set `set`.
fn uv_area(values: &[f32], width: usize, f: u32, set: usize) -> f64 {
    let at = |k: usize, c: usize| f64::from(values[(3 * f as usize + k) * width + 2 * set + c]);
    0.5 * ((at(1, 0) - at(0, 0)) * (at(2, 1) - at(0, 1))
        - (at(2, 0) - at(0, 0)) * (at(1, 1) - at(0, 1)))
}

/// Whether two carried normals agree within the hard-edge angle.
fn same_normal(a: &[f32], b: &[f32]) -> bool {
    let a = DVec3::new(a[0] as f64, a[1] as f64, a[2] as f64);
    let b = DVec3::new(b[0] as f64, b[1] as f64, b[2] as f64);
    a.dot(b) >= crate::features::normals::HARD_EDGE_COS * a.length() * b.length()
}

fn face_normal(p: [DVec3; 3]) -> DVec3 {
    (p[1] - p[0]).cross(p[2] - p[0]).normalize_or_zero()
}

/// A copy of `mesh` whose vertices are split so that each carries one
/// value of `corner_values` (`width` floats per corner, face by face, laid
/// out as [`VertexAttributes::gather`] writes them for `layout`'s sets,
/// when `has_color` a colour and when `has_normals` normals): the first
/// value met at a vertex keeps its
/// index, others get copies (position and normal copied). The attributes
/// are set from the values.
pub fn split_by_values(
    mesh: &TriMesh,
    corner_values: &[f32],
    layout: &VertexAttributes,
    has_color: bool,
    has_normals: bool,
) -> TriMesh {
    let w = VertexAttributes::width_of(layout.texcoords.len(), has_color, has_normals);
    let n = mesh.positions.len();
    let mut out = mesh.clone();
    let mut attrs = layout.empty_like();
    // Per vertex, the (value offset, vertex) pairs met so far.
    let mut met: Vec<Vec<(usize, u32)>> = vec![Vec::new(); n];
    let mut vertex_values: Vec<usize> = vec![usize::MAX; n];
    for (f, t) in out.triangles.iter_mut().enumerate() {
        for (k, slot) in t.iter_mut().enumerate() {
            let c = 3 * f + k;
            let val = &corner_values[c * w..][..w];
            let v = *slot as usize;
            let same = |o: usize| {
                corner_values[o..][..w]
                    .iter()
                    .zip(val)
                    .all(|(a, b)| a.to_bits() == b.to_bits())
            };
            if let Some(&(_, id)) = met[v].iter().find(|(o, _)| same(*o)) {
                *slot = id;
                continue;
            }
            let id = if met[v].is_empty() {
                v as u32
            } else {
                out.positions.push(mesh.positions[v]);
                if !mesh.normals.is_empty() {
                    out.normals.push(mesh.normals[v]);
                }
                vertex_values.push(usize::MAX);
                (out.positions.len() - 1) as u32
            };
            met[v].push((c * w, id));
            vertex_values[id as usize] = c * w;
            *slot = id;
        }
    }
    let zero = vec![0f32; w];
    for &o in &vertex_values {
        let val = if o == usize::MAX {
            &zero[..]
        } else {
            &corner_values[o..][..w]
        };
        attrs.push(val, has_color, has_normals);
    }
    out.attributes = attrs;
    out
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::shapes;

    /// A unit cube whose six sides each map onto their own UV square.
    fn charted_cube() -> TriMesh {
        let cube = shapes::cube(4, DVec3::splat(-0.5), DVec3::splat(0.5));
        let mut soup = TriMesh::default();
        let mut uv = Vec::new();
        for t in &cube.triangles {
            let p = cube.corner_positions(t);
            let n = face_normal(p);
            let axis = n.abs().max_position();
            let (i, j) = ((axis + 1) % 3, (axis + 2) % 3);
            let base = soup.positions.len() as u32;
            for q in p {
                soup.positions.push(q);
                uv.push([q[i] as f32 + 0.5, q[j] as f32 + 0.5 + 2.0 * axis as f32]);
            }
            soup.triangles.push([base, base + 1, base + 2]);
        }
        soup.attributes.texcoords = vec![uv];
        soup
    }

    #[test]
    fn cube_sides_are_charts_and_values_come_back() {
        let cube = charted_cube();
        let src = SourceAttributes::new(&cube).expect("has UVs");
        // Every cube edge between two sides is a seam: 12 edges of 4 segments.
        assert_eq!(src.seam_count(), 48);
        let (welded, _) = cube.welded();
        let seams = src.seams_on(&welded);
        assert_eq!(seams.len(), 48);
        let values = src.sample(&welded, &seams);
        // Sampling the input at its own corners gives its own values.
        for (f, t) in welded.triangles.iter().enumerate() {
            let p = welded.corner_positions(t);
            let axis = face_normal(p).abs().max_position();
            let (i, j) = ((axis + 1) % 3, (axis + 2) % 3);
            for (k, q) in p.iter().enumerate() {
                let got = &values[(3 * f + k) * 2..][..2];
                let want = [q[i] as f32 + 0.5, q[j] as f32 + 0.5 + 2.0 * axis as f32];
                assert!(
                    (got[0] - want[0]).abs() < 1e-5 && (got[1] - want[1]).abs() < 1e-5,
                    "face {f} corner {k}: {got:?} vs {want:?}"
                );
            }
        }
        let split = split_by_values(&welded, &values, src.layout(), false, false);
        // Each of the 8 cube corners is split in three, each edge vertex in two.
        assert_eq!(split.positions.len(), 6 * 25);
        assert!(split.check().is_ok());
    }
}
