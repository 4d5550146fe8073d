//! The texture-space guard after the last iteration: output triangles whose
//! texture coordinates, as the attribute transfer will sample them, are
//! flipped or degenerate against the input's orientation under them are
//! mended by guarded local edits, so that a textured asset comes out without
//! folded texels.
//!
//! Why a separate pass: an input atlas maps some faces to slivers of texture
//! space (a chart squeezed along a seam, an almost collinear UV triangle).
//! An output triangle that spans such a region samples three nearly
//! collinear texture points, and the piecewise-linear map between its
//! corners may fold. The geometry alone cannot see this, so the pass reads
//! the texture coordinates through the same [`SourceAttributes`] that the
//! transfer uses.
//!
//! The edits, tried in order for each bad face:
//! - move one of its free vertices (not on a feature line) toward the apex
//!   of the equilateral triangle over its opposite edge, or toward its
//!   ring's centroid, under the shape pass's 3D checks and length slack,
//!   when every face of its ring is then valid in texture space;
//! - flip one of its edges that is not a feature, under the flip guards,
//!   when both new faces are valid in texture space;
//! - collapse its shortest edge under the collapse pass's guards, when
//!   every face around the kept vertex is then valid in texture space;
//! - split its longest edge that is not a feature, when fewer of the new
//!   faces than of the old pair are invalid in texture space.
//!
//! What is left is reported (`report.uv_repair`), and the statistics count
//! it as `uv_flipped` and `uv_degenerate`.
//!
//! Faces are visited in index order in rounds, so the result is
//! deterministic.

use glam::DVec3;
use rayon::prelude::*;

use super::collapse::collapse_guarded;
use super::flip::{geometry_ok, quad, quad_triangles};
use super::guards::SHAPE_BAND_SLACK;
use super::relax::{settle, walk_closest};
use super::repair::{out_of_band, Probe};
use super::split::split_keeps_orientation;
use super::state::{State, SMOOTH, SPLIT_FACTOR};
use super::RemeshError;
use crate::mesh::{FaceId, HalfedgeId, Handle, VertexId, EDGE_FROZEN};
use crate::transfer::{SourceAttributes, UV_DEGENERATE_AREA};

/// Rounds over the remaining bad faces; each round only revisits faces that
/// are still bad, and a round that mends nothing ends the pass.
const MAX_ROUNDS: usize = 4;

/// How far past the split length the new edge of a texture-space flip may
/// reach (twice the target). The diagonal of two well-shaped triangles is
/// about 1.7 times their edges, so a tighter limit refuses most flips, and
/// the splits that mend those faces instead leave more edges out of the
/// band than the few long diagonals do.
const FLIP_STRETCH: f64 = 1.5;

/// What the pass did.
#[derive(Clone, Copy, Debug, Default)]
pub(super) struct UvRepair {
    /// Faces invalid in texture space before the pass.
    pub found: u64,
    /// Of those, faces over input that is itself degenerate in texture
    /// space, which the pass leaves alone.
    pub inherited: u64,
    /// Edits made (moves, flips and collapses).
    pub edits: u64,
    /// Faces still invalid after it, the inherited ones included.
    pub left: u64,
}

/// Texture coordinates of the output's vertices, as the transfer samples
/// them: one value per free vertex (cached), and, for a vertex on a feature
/// line (where a seam may pass), the value on the side of the face asked
/// about.
struct Texcoords<'a> {
    attrs: &'a SourceAttributes,
    sets: usize,
    /// Per vertex, `2 * sets` floats; meaningful for free vertices only.
    cache: Vec<f32>,
    /// Per vertex, the input face its value was read on ([`NO_FACE`] for
    /// none or a vertex on a feature line).
    faces: Vec<u32>,
}

/// No input face.
const NO_FACE: u32 = u32::MAX;

/// Texture coordinates read at a point, and the input face they were read
/// on.
struct Sample {
    uv: Vec<f32>,
    face: u32,
}

impl<'a> Texcoords<'a> {
    fn new(st: &State, attrs: &'a SourceAttributes) -> Self {
        let sets = attrs.layout().texcoords.len();
        let m = &st.mesh;
        let samples: Vec<Sample> = st.pool.install(|| {
            (0..m.vertex_capacity() as u32)
                .into_par_iter()
                .map(|vi| {
                    let v = VertexId(vi);
                    if m.is_vertex_deleted(v) || st.kind[v.idx()] != SMOOTH {
                        return Sample {
                            uv: vec![0.0; 2 * sets],
                            face: NO_FACE,
                        };
                    }
                    ring_sample(st, attrs, sets, v, m.position(v))
                })
                .collect()
        });
        let faces = samples.iter().map(|x| x.face).collect();
        let cache = samples.into_iter().flat_map(|x| x.uv).collect();
        Self {
            attrs,
            sets,
            cache,
            faces,
        }
    }

    /// The texture coordinates at `p`, read as the transfer reads them for
    /// a corner of face `face` (its corners, `p` among them; its label
    /// `label`): from the input face nearest the face's centroid, walking
    /// within its chart toward `p`. Starting at `p` itself could begin
    /// across a seam that runs close to `p`.
    fn sample(
        attrs: &SourceAttributes,
        sets: usize,
        p: DVec3,
        face: [DVec3; 3],
        label: u32,
    ) -> Sample {
        let inside = (face[0] + face[1] + face[2]) / 3.0;
        let normal = (face[1] - face[0]).cross(face[2] - face[0]);
        let (mut uv, face) = attrs.lookup(p, inside, normal, label);
        uv.truncate(2 * sets);
        Sample {
            uv,
            face: face.unwrap_or(NO_FACE),
        }
    }

    /// Stores `value`, the texture coordinates that an edit checked its
    /// faces with, for free vertex `v` (new or moved): the cache then
    /// agrees with the checks exactly.
    fn set(&mut self, st: &State, v: VertexId, value: &Sample) {
        let (w, n) = (2 * self.sets, st.mesh.vertex_capacity());
        if self.faces.len() < n {
            self.cache.resize(w * n, 0.0);
            self.faces.resize(n, NO_FACE);
        }
        if st.kind[v.idx()] == SMOOTH {
            self.cache[w * v.idx()..][..w].copy_from_slice(&value.uv);
            self.faces[v.idx()] = value.face;
        }
    }

    /// Whether the triangle of vertices `vs` at positions `p` (counter-
    /// clockwise) is valid in every texture coordinate set: not degenerate,
    /// and oriented like the input face under its centroid. `moved` gives
    /// the texture coordinates of a free vertex at a trial position; the
    /// triangle's label is `label`.
    fn valid(
        &self,
        st: &State,
        vs: [VertexId; 3],
        p: [DVec3; 3],
        moved: Option<(VertexId, &Sample)>,
        label: u32,
    ) -> bool {
        use std::borrow::Cow;
        let g = (p[0] + p[1] + p[2]) / 3.0;
        let n = (p[1] - p[0]).cross(p[2] - p[0]);
        let w = 2 * self.sets;
        let corner: Vec<(Cow<[f32]>, u32)> = (0..3)
            .map(|k| match moved {
                Some((mv, x)) if mv == vs[k] => (Cow::Borrowed(&x.uv[..]), x.face),
                _ if st.kind[vs[k].idx()] == SMOOTH => (
                    Cow::Borrowed(&self.cache[w * vs[k].idx()..][..w]),
                    self.faces[vs[k].idx()],
                ),
                _ => {
                    let (uv, face) = self.attrs.lookup(p[k], g, n, label);
                    (Cow::Owned(uv), face.unwrap_or(NO_FACE))
                }
            })
            .collect();
        (0..self.sets).all(|s| {
            let uv = |k: usize, c: usize| f64::from(corner[k].0[2 * s + c]);
            let a = 0.5
                * ((uv(1, 0) - uv(0, 0)) * (uv(2, 1) - uv(0, 1))
                    - (uv(2, 0) - uv(0, 0)) * (uv(1, 1) - uv(0, 1)));
            if a.abs() < UV_DEGENERATE_AREA {
                return false;
            }
            // Where the three input faces read agree with the triangle's
            // orientation, the input under its centroid almost always does
            // too; only the others pay for the query under the centroid.
            let agree = corner.iter().all(|&(_, f)| {
                f != NO_FACE && {
                    let r = self.attrs.face_uv_area(f, s);
                    r.abs() >= UV_DEGENERATE_AREA && r * a > 0.0
                }
            });
            agree
                || self
                    .attrs
                    .uv_orientation_at(g, n, s, label)
                    .is_none_or(|r| r.abs() < UV_DEGENERATE_AREA || r * a > 0.0)
        })
    }

    /// Whether the input face under the centroid of `f` is degenerate in
    /// some texture coordinate set.
    fn over_degenerate_input(&self, st: &State, f: FaceId) -> bool {
        let p = st.mesh.face_positions(f);
        let g = (p[0] + p[1] + p[2]) / 3.0;
        let n = (p[1] - p[0]).cross(p[2] - p[0]);
        let label = st.mesh.face_label[f];
        (0..self.sets).any(|s| {
            self.attrs
                .uv_orientation_at(g, n, s, label)
                .is_some_and(|r| r.abs() < UV_DEGENERATE_AREA)
        })
    }

    fn face_valid(&self, st: &State, f: FaceId) -> bool {
        let vs = st.mesh.face_vertices(f);
        let label = st.mesh.face_label[f];
        self.valid(st, vs, vs.map(|v| st.mesh.position(v)), None, label)
    }
}

/// The texture coordinates of free vertex `v` placed at `p`, read for the
/// first face of its ring (a free vertex lies inside one chart and one
/// label, so any ring face gives the same value).
fn ring_sample(st: &State, attrs: &SourceAttributes, sets: usize, v: VertexId, p: DVec3) -> Sample {
    let m = &st.mesh;
    match m.outgoing(v).find(|&h| !m.is_boundary_halfedge(h)) {
        Some(h) => {
            let corners = [
                p,
                m.position(m.to_vertex(h)),
                m.position(m.to_vertex(m.next(h))),
            ];
            Texcoords::sample(attrs, sets, p, corners, m.face_label[m.face(h)])
        }
        None => Sample {
            uv: vec![0.0; 2 * sets],
            face: NO_FACE,
        },
    }
}

/// Mends the faces of `st` that are invalid in texture space. Returns what
/// it found and did.
pub(super) fn untangle(st: &mut State, attrs: &SourceAttributes) -> Result<UvRepair, RemeshError> {
    if attrs.layout().texcoords.is_empty() {
        return Ok(UvRepair::default());
    }
    let mut uv = Texcoords::new(st, attrs);
    let bad_faces = |st: &State, uv: &Texcoords, among: Option<&[u32]>| -> Vec<u32> {
        let m = &st.mesh;
        let check = |fi: u32| !m.is_face_deleted(FaceId(fi)) && !uv.face_valid(st, FaceId(fi));
        st.pool.install(|| match among {
            Some(fs) => fs.par_iter().copied().filter(|&f| check(f)).collect(),
            None => (0..m.face_capacity() as u32)
                .into_par_iter()
                .filter(|&f| check(f))
                .collect(),
        })
    };
    let mut bad = bad_faces(st, &uv, None);
    let found = bad.len() as u64;
    // Faces over input that is itself degenerate in texture space cannot
    // be mended by moving the output: they are counted, and left alone.
    bad.retain(|&f| !uv.over_degenerate_input(st, FaceId(f)));
    let mut report = UvRepair {
        found,
        inherited: found - bad.len() as u64,
        ..UvRepair::default()
    };
    for _ in 0..MAX_ROUNDS {
        if bad.is_empty() {
            break;
        }
        let mut edits = 0;
        let mut touched: Vec<u32> = Vec::new();
        for (i, &fi) in bad.iter().enumerate() {
            st.cancel.every(i as u64 + 1)?;
            let f = FaceId(fi);
            if st.mesh.is_face_deleted(f) || uv.face_valid(st, f) {
                continue;
            }
            if let Some(changed) = mend(st, &mut uv, f) {
                edits += 1;
                touched.extend(changed);
            }
        }
        report.edits += edits;
        // Faces that an edit created or changed are checked again with the
        // ones still bad.
        touched.extend(bad.iter().copied());
        touched.sort_unstable();
        touched.dedup();
        bad = bad_faces(st, &uv, Some(&touched));
        if edits == 0 {
            break;
        }
    }
    report.left = bad.len() as u64 + report.inherited;
    Ok(report)
}

/// Tries the edits for bad face `f`; returns the faces the edit changed.
fn mend(st: &mut State, uv: &mut Texcoords, f: FaceId) -> Option<Vec<u32>> {
    let vs = st.mesh.face_vertices(f);
    for k in 0..3 {
        if let Some(changed) = move_vertex(st, uv, vs[k], [vs[(k + 1) % 3], vs[(k + 2) % 3]]) {
            return Some(changed);
        }
    }
    if let Some(changed) = flip_edge_of(st, uv, f) {
        return Some(changed);
    }
    if let Some(changed) = collapse_edge_of(st, uv, f) {
        return Some(changed);
    }
    split_edge_of(st, uv, f)
}

/// The half-edges of face `f`, shortest first, or longest first when
/// `longest_first` (a stable sort either way, so ties keep face order).
fn by_length(st: &State, f: FaceId, longest_first: bool) -> [HalfedgeId; 3] {
    let m = &st.mesh;
    let h0 = m.face_halfedge(f);
    let mut hs = [h0, m.next(h0), m.next(m.next(h0))];
    let len = |h: HalfedgeId| {
        m.position(m.to_vertex(h))
            .distance_squared(m.position(m.from_vertex(h)))
    };
    if longest_first {
        hs.sort_by(|&x, &y| len(y).total_cmp(&len(x)));
    } else {
        hs.sort_by(|&x, &y| len(x).total_cmp(&len(y)));
    }
    hs
}

/// Splits the longest edge of bad face `f` that is not a feature at the
/// input point nearest its midpoint, when fewer of the new faces than of
/// the old pair are invalid in texture space: smaller triangles follow a
/// strongly bent texture map more closely.
fn split_edge_of(st: &mut State, uv: &mut Texcoords, f: FaceId) -> Option<Vec<u32>> {
    let m = &st.mesh;
    let hs = by_length(st, f, true);
    for h in hs {
        let e = h.edge();
        if st.line_of(e).is_some() || m.is_boundary_edge(e) || m.edge_has_flag(e, EDGE_FROZEN) {
            continue;
        }
        let [a, b, c, d] = quad(m, h);
        let mid = 0.5 * (m.position(a) + m.position(b));
        let hint = st.hint_face[a.idx()];
        let Some(cp) = walk_closest(st, mid, hint, st.size[a.idx()]) else {
            continue;
        };
        if !split_keeps_orientation(st, e, cp.point) {
            continue;
        }
        let p = cp.point;
        let (l0, l1) = (m.face_label[m.face(h)], m.face_label[m.face(h.twin())]);
        let here = Texcoords::sample(uv.attrs, uv.sets, p, [m.position(a), p, m.position(c)], l0);
        // The new vertex is not in the mesh yet: a stand-in id that no
        // vertex has, whose coordinates `here` supplies.
        let nv = VertexId(u32::MAX);
        let pos = |v: VertexId| if v == nv { p } else { m.position(v) };
        let bad = |(t, l): ([VertexId; 3], u32)| !uv.valid(st, t, t.map(pos), Some((nv, &here)), l);
        let before = [([a, b, c], l0), ([b, a, d], l1)]
            .into_iter()
            .filter(|&t| bad(t))
            .count();
        let after = [
            ([a, nv, c], l0),
            ([nv, b, c], l0),
            ([b, nv, d], l1),
            ([nv, a, d], l1),
        ]
        .into_iter()
        .filter(|&t| bad(t))
        .count();
        if after >= before {
            continue;
        }
        let r = st.split(e, p, 0);
        settle(st, r.vertex, &cp);
        uv.set(st, r.vertex, &here);
        return Some(ring_faces(st, r.vertex));
    }
    None
}

/// Faces around `v`, as face indices.
fn ring_faces(st: &State, v: VertexId) -> Vec<u32> {
    let m = &st.mesh;
    m.outgoing(v)
        .map(|h| m.face(h))
        .filter(|f| f.is_valid())
        .map(|f| f.0)
        .collect()
}

/// Moves free vertex `v` of a bad face whose opposite edge is `ab` to where
/// every ring face is valid in 3D and in texture space.
fn move_vertex(
    st: &mut State,
    uv: &mut Texcoords,
    v: VertexId,
    [a, b]: [VertexId; 2],
) -> Option<Vec<u32>> {
    if st.kind[v.idx()] != SMOOTH || st.mesh.is_boundary_vertex(v) {
        return None;
    }
    let up = st.input_normals[st.hint_face[v.idx()] as usize];
    let probe = Probe::new(st, v, Some(up))?;
    let m = &st.mesh;
    let p = m.position(v);
    let (pa, pb) = (m.position(a), m.position(b));
    let ab = pb - pa;
    let mid = 0.5 * (pa + pb);
    let off = p - mid;
    let perp = (off - ab * (off.dot(ab) / ab.length_squared())).normalize_or_zero();
    let apex = mid + perp * (0.5 * 3f64.sqrt() * ab.length());
    let ring: Vec<DVec3> = m.outgoing(v).map(|h| m.position(m.to_vertex(h))).collect();
    let centroid = ring.iter().sum::<DVec3>() / ring.len() as f64;
    let slack = out_of_band(st, v, p) + SHAPE_BAND_SLACK;
    let mut best: Option<(f64, crate::bvh::ClosestPoint, Sample)> = None;
    for (target, t) in [
        (apex, 0.25),
        (apex, 0.5),
        (apex, 1.0),
        (centroid, 0.5),
        (centroid, 1.0),
    ] {
        if perp == DVec3::ZERO && target == apex {
            continue;
        }
        let q = p + t * (target - p);
        let Some(cp) = walk_closest(st, q, st.hint_face[v.idx()], st.size[v.idx()]) else {
            continue;
        };
        let up = st.input_normals[cp.face as usize];
        if out_of_band(st, v, cp.point) > slack || stretches(st, v, cp.point) {
            continue;
        }
        let Some(score) = probe.score(st, cp.point, Some(up)) else {
            continue;
        };
        if best.as_ref().is_some_and(|b| b.0 >= score) {
            continue;
        }
        let here = ring_sample(st, uv.attrs, uv.sets, v, cp.point);
        if ring_valid(st, uv, v, cp.point, &here) {
            best = Some((score, cp, here));
        }
    }
    let (_, cp, here) = best?;
    st.mesh.set_position(v, cp.point);
    settle(st, v, &cp);
    uv.set(st, v, &here);
    Some(ring_faces(st, v))
}

/// Whether moving `v` to `p` makes one of its edges longer than both the
/// split length and what it was.
fn stretches(st: &State, v: VertexId, p: DVec3) -> bool {
    let m = &st.mesh;
    let here = m.position(v);
    m.outgoing(v).any(|h| {
        let w = m.to_vertex(h);
        let (pw, limit) = (m.position(w), SPLIT_FACTOR * st.edge_target(v, w));
        let d = p.distance(pw);
        d > limit && d > here.distance(pw)
    })
}

/// Whether every face around `v`, with `v` at `p` and texture coordinates
/// `here`, is valid in texture space.
fn ring_valid(st: &State, uv: &Texcoords, v: VertexId, p: DVec3, here: &Sample) -> bool {
    let m = &st.mesh;
    m.outgoing(v)
        .filter(|&h| !m.is_boundary_halfedge(h))
        .all(|h| {
            let (a, b) = (m.to_vertex(h), m.to_vertex(m.next(h)));
            uv.valid(
                st,
                [v, a, b],
                [p, m.position(a), m.position(b)],
                Some((v, here)),
                m.face_label[m.face(h)],
            )
        })
}

/// Flips an edge of bad face `f` that is not a feature, under the flip
/// guards, when both new faces are valid in texture space and the new
/// edge is at most [`FLIP_STRETCH`] times the split length.
fn flip_edge_of(st: &mut State, uv: &Texcoords, f: FaceId) -> Option<Vec<u32>> {
    let m = &st.mesh;
    let h0 = m.face_halfedge(f);
    for h in [h0, m.next(h0), m.next(m.next(h0))] {
        let e = h.edge();
        if st.line_of(e).is_some()
            || m.is_boundary_edge(e)
            || m.edge_has_flag(e, EDGE_FROZEN)
            || !m.can_flip(e)
        {
            continue;
        }
        let q = quad(m, h);
        let (old, new) = quad_triangles(m, q);
        if !geometry_ok(old, new) {
            continue;
        }
        let [a, b, c, d] = q;
        let cd = m.position(c).distance(m.position(d));
        if cd > FLIP_STRETCH * SPLIT_FACTOR * st.edge_target(c, d) {
            continue;
        }
        let label = m.face_label[m.face(h)];
        if uv.valid(st, [c, a, d], new[0], None, label)
            && uv.valid(st, [d, b, c], new[1], None, label)
        {
            let faces = [m.face(h).0, m.face(h.twin()).0];
            st.mesh.flip_edge(e);
            return Some(faces.to_vec());
        }
    }
    None
}

/// Collapses the shortest edge of bad face `f` that the collapse guards
/// allow, when every face around the kept vertex is then valid in texture
/// space.
fn collapse_edge_of(st: &mut State, uv: &mut Texcoords, f: FaceId) -> Option<Vec<u32>> {
    let hs = by_length(st, f, false);
    // The kept vertex's texture coordinates as the accepted check saw them.
    let chosen = std::cell::RefCell::new(None);
    let accept = |st: &State, kept: VertexId, p: DVec3, faces: &[([VertexId; 3], FaceId)]| {
        let m = &st.mesh;
        let here = (st.kind[kept.idx()] == SMOOTH).then(|| {
            let (t, f) = faces.first().copied().unwrap_or(([kept; 3], FaceId(0)));
            let corners = [p, m.position(t[1]), m.position(t[2])];
            Texcoords::sample(uv.attrs, uv.sets, p, corners, m.face_label[f])
        });
        let ok = faces.iter().all(|&(t, f)| {
            let p3 = [p, m.position(t[1]), m.position(t[2])];
            uv.valid(st, t, p3, here.as_ref().map(|s| (kept, s)), m.face_label[f])
        });
        if ok {
            *chosen.borrow_mut() = here;
        }
        ok
    };
    for h in hs {
        for h in [h, h.twin()] {
            if let Some(kept) = collapse_guarded(st, h, accept) {
                if let Some(here) = chosen.take() {
                    uv.set(st, kept, &here);
                }
                return Some(ring_faces(st, kept));
            }
        }
    }
    None
}
