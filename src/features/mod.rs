//! Sharp features of an input [`TriMesh`]: which edges and vertices the
//! remesher must keep, the corners that never move, and the feature lines as
//! polylines with closest-point queries restricted to one line.
//!
//! The remesher treats features as in Botsch & Kobbelt (2004): feature edges
//! are never flipped or collapsed across, feature vertices only slide along
//! their feature, corners never move. This module supplies that data. A
//! feature edge is an interior edge whose dihedral angle (angle between its
//! two face normals) exceeds [`FeatureOptions::feature_angle_deg`], every
//! boundary edge, every edge between faces with different labels, and every
//! edge with more than two faces. The dihedral test is the one of the bench (`bench/quality.py`,
//! `sharp_edges`): f64 face normals, degenerate faces never make a crease.
//! Corners are feature vertices where the feature graph is not a simple curve
//! (valence ≠ 2) or where the curve turns by more than
//! [`FeatureOptions::corner_angle_deg`]. The edges between corners form
//! [`FeatureLine`]s; each line carries its own segment tree so that a feature
//! vertex is projected back onto *its* line, never onto a neighbouring crease.
//!
//! With [`FeatureOptions::min_crease_length`] set (the remesher sets it from
//! its target), creases too small to resample are dropped first and turns
//! that only wiggle next to another corner are not made corners: the noise
//! creases of scans would otherwise pin corners a fraction of an edge apart.
//! Of two creases drawn a fraction of an edge apart between the same two
//! junctions, one is kept (see `twin_creases_kept`), and a flat face ringed
//! by creases loses its longest (see `flat_creases_kept`).
//!
//! The module's rooms: `anchors.rs` holds the remesher's policy of which
//! vertices stay fixed, `detect.rs` classifies edges and walks the feature
//! graph into lines, `filter.rs` drops the creases too small to keep,
//! `lines.rs` answers closest-point queries on one line (its segment tree),
//! `normals.rs` finds the hard edges authored into an input's normals.
//! How well an output keeps the input's features is measured in
//! [`crate::stats::polyline`].

use glam::DVec3;

use crate::bvh::SegmentIndex;
use crate::topology::EdgeTable;
use crate::trimesh::TriMesh;

pub(crate) mod anchors;
mod detect;
mod filter;
mod lines;
pub mod normals;

use detect::*;
use filter::*;

/// Default dihedral angle above which an interior edge is a crease, degrees.
/// 45°, the bench's and gpytoolbox's value, so that the feature set is the
/// one the bench measures; why neither lower nor higher: `docs/tuning.md`.
pub const DEFAULT_FEATURE_ANGLE_DEG: f64 = 45.0;

/// Default turning angle above which a valence-2 feature vertex is a corner,
/// degrees (deviation of the two feature edges from a straight line).
/// 45° keeps the 90° corners of boxes while circles tessellated with 8 or
/// more segments stay curves; the margins on either side: `docs/tuning.md`.
pub const DEFAULT_CORNER_ANGLE_DEG: f64 = 45.0;

/// How features are detected.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct FeatureOptions {
    /// Detect creases by dihedral angle. When `false`, only the edges that
    /// cannot be dropped without tearing the surface are kept: boundary
    /// edges, label borders (material borders must stay crack-free and
    /// straight in every primitive) and edges with more than two faces.
    pub preserve_features: bool,
    /// An interior edge is a crease when its dihedral angle is strictly
    /// greater than this, degrees. Non-finite values mean the default.
    pub feature_angle_deg: f64,
    /// A valence-2 feature vertex is a corner when its feature line turns by
    /// strictly more than this, degrees. Non-finite values mean the default.
    pub corner_angle_deg: f64,
    /// Creases smaller than this, in model units, are dropped: a crease-only
    /// feature component shorter in total, and a crease-only chain shorter
    /// than this from a free end to a vertex where lines end or meet (a
    /// chain between two junctions is held to `min_bridge_length`); and a turn
    /// that only wiggles within this distance of another corner is not a
    /// corner (see `small_creases_kept` and `turn_is_wiggle`). 0 keeps every
    /// crease. Boundaries, label borders and non-manifold edges are never
    /// dropped.
    pub min_crease_length: f64,
    /// A crease-only chain between two junctions (vertices where three or
    /// more feature edges meet) is dropped only below the smaller of this
    /// and `min_crease_length`: such a bridge is an edge of a real network
    /// (a box's short edge between two corners), and dropping it costs more
    /// shape than dropping a fragment or a spur. Default infinite (the
    /// bridge threshold is `min_crease_length`); the remesher sets it to the
    /// shortest edge of its band, 4/5 of its length unit.
    pub min_bridge_length: f64,
}

impl Default for FeatureOptions {
    fn default() -> Self {
        Self {
            preserve_features: true,
            feature_angle_deg: DEFAULT_FEATURE_ANGLE_DEG,
            corner_angle_deg: DEFAULT_CORNER_ANGLE_DEG,
            min_crease_length: 0.0,
            min_bridge_length: f64::INFINITY,
        }
    }
}

/// Why an edge is a feature; an edge may have several reasons.
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq, Hash)]
pub struct EdgeFlags(u8);

impl EdgeFlags {
    /// The edge has exactly one face.
    pub const BOUNDARY: EdgeFlags = EdgeFlags(1);
    /// Two faces meet at a dihedral angle above the feature angle.
    pub const SHARP: EdgeFlags = EdgeFlags(2);
    /// The faces on the edge carry different labels.
    pub const LABEL_BORDER: EdgeFlags = EdgeFlags(4);
    /// The edge has more than two faces.
    pub const NON_MANIFOLD: EdgeFlags = EdgeFlags(8);
    /// A corner attribute (a texture coordinate, a colour) differs across
    /// the edge: an attribute seam, kept like a label border.
    pub const SEAM: EdgeFlags = EdgeFlags(16);

    /// Whether every reason in `other` is present.
    pub fn contains(self, other: EdgeFlags) -> bool {
        self.0 & other.0 == other.0
    }

    /// Whether no reason is present.
    pub fn is_empty(self) -> bool {
        self.0 == 0
    }
}

impl std::ops::BitOr for EdgeFlags {
    type Output = EdgeFlags;
    fn bitor(self, rhs: EdgeFlags) -> EdgeFlags {
        EdgeFlags(self.0 | rhs.0)
    }
}

impl std::ops::BitOrAssign for EdgeFlags {
    fn bitor_assign(&mut self, rhs: EdgeFlags) {
        self.0 |= rhs.0;
    }
}

/// What an input vertex is with respect to the features.
#[derive(Clone, Copy, Debug, PartialEq, Eq, Hash)]
pub enum VertexKind {
    /// Not on any feature edge: free to move on the surface.
    Smooth,
    /// Interior vertex of feature line `id`: may only slide along that line.
    Line(u32),
    /// Corner: never moves.
    Corner,
}

/// A maximal feature polyline: from corner to corner, or a closed loop
/// without corners.
///
/// `vertices` lists input vertex ids in order. Segment `s` joins
/// `vertices[s]` and `vertices[s + 1]`, so a line has `vertices.len() - 1`
/// segments. A closed line repeats its first vertex at the end; that vertex is
/// a corner when the loop passes through exactly one corner, and an ordinary
/// line vertex when the loop has no corner at all.
#[derive(Clone, Debug, PartialEq)]
pub struct FeatureLine {
    /// Input vertex ids along the line (first repeated at the end if closed).
    pub vertices: Vec<u32>,
    /// Offset of this line's first point in the set's point array.
    point_offset: u32,
    /// Union of the reasons of the line's edges.
    flags: EdgeFlags,
}

impl FeatureLine {
    /// Number of segments (`vertices.len() - 1`).
    pub fn segment_count(&self) -> usize {
        self.vertices.len() - 1
    }

    /// Whether the line is a closed loop (first vertex equals last).
    pub fn is_closed(&self) -> bool {
        self.vertices.first() == self.vertices.last()
    }

    /// Why the line is a feature: the union of its edges' [`EdgeFlags`] (a
    /// crease may continue as a label border through a valence-2 vertex).
    pub fn flags(&self) -> EdgeFlags {
        self.flags
    }
}

/// The closest point of a feature line to a query point.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct LinePoint {
    /// Segment index within the line.
    pub segment: u32,
    /// Parameter on the segment in [0, 1]: 0 at `vertices[segment]`, 1 at `vertices[segment + 1]`.
    pub t: f64,
    /// The closest point. Exactly the segment's end point when `t` is 0 or 1.
    pub point: DVec3,
    /// Squared distance from the query point.
    pub dist2: f64,
}

/// The features of one input mesh. Plain data: `Send + Sync`, cheap queries.
///
/// Feature adjacency is stored per vertex in compressed rows sorted by
/// neighbour id, so edge lookups scan the (usually two) feature neighbours of
/// a vertex instead of probing a hash map.
#[derive(Clone, Debug, Default)]
pub struct FeatureSet {
    edges: Vec<[u32; 2]>,
    edge_flags: Vec<EdgeFlags>,
    /// (line, segment) of each feature edge.
    edge_segment: Vec<[u32; 2]>,
    adj_offset: Vec<u32>,
    /// (neighbour, feature edge id), rows sorted by neighbour.
    adj: Vec<[u32; 2]>,
    kind: Vec<VertexKind>,
    /// For `Line` vertices: index in their line's vertex list.
    line_index: Vec<u32>,
    corners: Vec<u32>,
    lines: Vec<FeatureLine>,
    points: Vec<DVec3>,
    /// Per line, the index of its segments.
    line_trees: Vec<SegmentIndex>,
}

/// Finds the features of `mesh`. Robust to unreferenced vertices, triangles
/// with repeated or out-of-range indices (ignored), degenerate faces (never
/// a crease), inconsistent orientation and non-manifold edges.
pub fn detect_features(mesh: &TriMesh, opts: &FeatureOptions) -> FeatureSet {
    detect_features_with_seams(mesh, opts, &[])
}

/// [`detect_features`] with the attribute seams `seams` (vertex pairs of
/// `mesh`, either order) as features too: flagged [`EdgeFlags::SEAM`] and,
/// like label borders, never dropped as small creases. A pair that is not
/// an edge of `mesh` is ignored.
pub fn detect_features_with_seams(
    mesh: &TriMesh,
    opts: &FeatureOptions,
    seams: &[[u32; 2]],
) -> FeatureSet {
    let nv = mesh.positions.len();
    let feature_angle = sanitize(opts.feature_angle_deg, DEFAULT_FEATURE_ANGLE_DEG);
    let corner_angle = sanitize(opts.corner_angle_deg, DEFAULT_CORNER_ANGLE_DEG);

    let (mut edges, mut edge_flags) =
        classify_edges(mesh, opts.preserve_features, feature_angle, seams);
    if opts.min_crease_length > 0.0 {
        let bridge = opts.min_bridge_length.min(opts.min_crease_length);
        let gap = TWIN_GAP * opts.min_crease_length;
        let keep = small_creases_kept(mesh, &edges, &edge_flags, opts.min_crease_length, bridge);
        retain_kept(&mut edges, &mut edge_flags, &keep);
        let keep = twin_creases_kept(mesh, &edges, &edge_flags, gap);
        retain_kept(&mut edges, &mut edge_flags, &keep);
        let keep = flat_creases_kept(mesh, &edges, &edge_flags, gap);
        retain_kept(&mut edges, &mut edge_flags, &keep);
    }

    let (adj_offset, adj) = feature_adjacency(nv, &edges);

    // Corners: valence other than 2, or a turn sharper than the corner angle.
    let cos_corner = corner_angle.to_radians().cos();
    let mut kind = vec![VertexKind::Smooth; nv];
    let mut corners = Vec::new();
    // Turn corners: (cosine of the turn, vertex), sharpest first below.
    let mut turns: Vec<(f64, u32)> = Vec::new();
    for v in 0..nv {
        let row = &adj[adj_offset[v] as usize..adj_offset[v + 1] as usize];
        match row.len() {
            0 => {}
            2 => {
                let p = mesh.positions[v];
                let d_in = p - mesh.positions[row[0][0] as usize];
                let d_out = mesh.positions[row[1][0] as usize] - p;
                let l = d_in.length() * d_out.length();
                // Coincident points give no direction; a zero-length edge is
                // not evidence of a corner.
                let cos_turn = d_in.dot(d_out) / l;
                if l > 0.0 && cos_turn < cos_corner {
                    turns.push((cos_turn, v as u32));
                }
            }
            _ => {
                kind[v] = VertexKind::Corner;
                corners.push(v as u32);
            }
        }
    }
    turns.sort_by(|a, b| a.0.total_cmp(&b.0).then(a.1.cmp(&b.1)));
    let crease_only = |v: u32| {
        adj[adj_offset[v as usize] as usize..adj_offset[v as usize + 1] as usize]
            .iter()
            .all(|&[_, e]| edge_flags[e as usize] == EdgeFlags::SHARP)
    };
    for (_, v) in turns {
        if opts.min_crease_length > 0.0
            && crease_only(v)
            && turn_is_wiggle(mesh, &adj_offset, &adj, &kind, v, opts.min_crease_length)
        {
            continue;
        }
        kind[v as usize] = VertexKind::Corner;
        corners.push(v);
    }
    corners.sort_unstable();

    // Lines: walk from every corner along each unused feature edge to the
    // next corner, then pick up the corner-free loops that remain.
    let mut edge_segment = vec![[u32::MAX; 2]; edges.len()];
    let mut line_index = vec![u32::MAX; nv];
    let mut lines: Vec<FeatureLine> = Vec::new();
    let mut points: Vec<DVec3> = Vec::new();
    let mut walker = LineWalker {
        edges: &edges,
        adj_offset: &adj_offset,
        adj: &adj,
        kind: &mut kind,
        edge_segment: &mut edge_segment,
        line_index: &mut line_index,
    };
    let mut push_line = |verts: Vec<u32>, lines: &mut Vec<FeatureLine>| {
        let point_offset = points.len() as u32;
        points.extend(verts.iter().map(|&v| mesh.positions[v as usize]));
        lines.push(FeatureLine {
            vertices: verts,
            point_offset,
            flags: EdgeFlags::default(),
        });
    };
    for &c in &corners {
        for k in adj_offset[c as usize]..adj_offset[c as usize + 1] {
            let e = adj[k as usize][1];
            if walker.edge_segment[e as usize][0] == u32::MAX {
                let verts = walker.walk(c, e, lines.len() as u32);
                push_line(verts, &mut lines);
            }
        }
    }
    for (e, &[a, _]) in edges.iter().enumerate() {
        if walker.edge_segment[e][0] == u32::MAX {
            let verts = walker.walk(a, e as u32, lines.len() as u32);
            push_line(verts, &mut lines);
        }
    }

    for (e, &[l, _]) in edge_segment.iter().enumerate() {
        lines[l as usize].flags |= edge_flags[e];
    }
    let line_trees = lines
        .iter()
        .map(|line| {
            let pts = &points[line.point_offset as usize..][..line.vertices.len()];
            SegmentIndex::new(pts.len() - 1, |s| [pts[s], pts[s + 1]])
        })
        .collect();

    FeatureSet {
        edges,
        edge_flags,
        edge_segment,
        adj_offset,
        adj,
        kind,
        line_index,
        corners,
        lines,
        points,
        line_trees,
    }
}

fn sanitize(deg: f64, default: f64) -> f64 {
    if deg.is_finite() {
        deg
    } else {
        default
    }
}

/// Unit face normal by division (as the bench computes it), zero when degenerate.
fn face_normal(p: [DVec3; 3]) -> DVec3 {
    let c = crate::geometry::triangle_cross(p);
    let l = c.length();
    if l > 0.0 {
        c / l
    } else {
        DVec3::ZERO
    }
}

/// All undirected edges of `mesh` as (a, b) with a < b, sorted. Triangles
/// with repeated or out-of-range indices are ignored.
pub fn mesh_edges(mesh: &TriMesh) -> Vec<[u32; 2]> {
    let mut out = Vec::new();
    EdgeTable::new(&mesh.triangles, mesh.positions.len()).for_each(|a, b, _| out.push([a, b]));
    out
}

/// Edges of `mesh` with exactly one face, sorted.
pub fn boundary_edges(mesh: &TriMesh) -> Vec<[u32; 2]> {
    let mut out = Vec::new();
    EdgeTable::new(&mesh.triangles, mesh.positions.len()).for_each(|a, b, hs| {
        if hs.len() == 1 {
            out.push([a, b]);
        }
    });
    out
}

/// Interior two-face edges whose dihedral angle exceeds `angle_deg`, sorted:
/// exactly the bench's `sharp_edges` (boundaries and label borders are not
/// included; see [`detect_features`] for the remesher's full feature set).
pub fn sharp_edges(mesh: &TriMesh, angle_deg: f64) -> Vec<[u32; 2]> {
    let (edges, flags) = classify_edges(mesh, true, angle_deg, &[]);
    edges
        .into_iter()
        .zip(flags)
        .filter(|(_, f)| f.contains(EdgeFlags::SHARP))
        .map(|(e, _)| e)
        .collect()
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::bvh::{closest_point_on_segment, SegmentPoint};
    use crate::shapes;

    /// Two crease chains between junctions J1 (vertex 0) and J2 (vertex 1),
    /// each junction with a spur: chain A runs straight, chain B beside it
    /// at height `offset` (and so longer). Returns the positions, the edges
    /// (spurs first, then A, then B) and the flags (B's taken from `b_flags`).
    fn lens(offset: f64, b_flags: EdgeFlags) -> (TriMesh, Vec<[u32; 2]>, Vec<EdgeFlags>) {
        let p = |x: f64, y: f64| DVec3::new(x, y, 0.0);
        let positions = vec![
            p(0.0, 0.0),
            p(4.0, 0.0),
            p(-1.0, 0.0),
            p(5.0, 0.0),
            p(1.0, 0.0),
            p(2.0, 0.0),
            p(3.0, 0.0),
            p(1.0, offset),
            p(2.0, 1.2 * offset),
            p(3.0, offset),
        ];
        let edges = vec![
            [0, 2],
            [1, 3],
            [0, 4],
            [4, 5],
            [5, 6],
            [1, 6],
            [0, 7],
            [7, 8],
            [8, 9],
            [1, 9],
        ];
        let mut flags = vec![EdgeFlags::SHARP; edges.len()];
        for f in &mut flags[6..] {
            *f = b_flags;
        }
        (TriMesh::new(positions, Vec::new()), edges, flags)
    }

    /// Two creases between the same junctions within the gap: the longer
    /// goes, the other and the spurs stay. Farther apart, or when one of
    /// them is not a crease (a boundary), both stay.
    #[test]
    fn twin_creases_lose_the_longer_chain() {
        let (mesh, edges, flags) = lens(0.1, EdgeFlags::SHARP);
        let keep = twin_creases_kept(&mesh, &edges, &flags, 0.25);
        assert_eq!(
            keep,
            [true, true, true, true, true, true, false, false, false, false]
        );
        let (mesh, edges, flags) = lens(0.5, EdgeFlags::SHARP);
        assert!(twin_creases_kept(&mesh, &edges, &flags, 0.25)
            .iter()
            .all(|&k| k));
        let (mesh, edges, flags) = lens(0.1, EdgeFlags::BOUNDARY);
        assert!(twin_creases_kept(&mesh, &edges, &flags, 0.25)
            .iter()
            .all(|&k| k));
        // A gap of zero switches the rule off.
        let (mesh, edges, flags) = lens(0.0, EdgeFlags::SHARP);
        assert!(twin_creases_kept(&mesh, &edges, &flags, 0.0)
            .iter()
            .all(|&k| k));
    }

    /// A cap face whose three edges are creases loses its longest edge when
    /// its height is within the gap, and keeps all three otherwise.
    #[test]
    fn flat_crease_faces_lose_their_longest_edge() {
        let cap = |h: f64| {
            TriMesh::new(
                vec![
                    DVec3::ZERO,
                    DVec3::new(2.0, 0.0, 0.0),
                    DVec3::new(0.8, h, 0.0),
                ],
                vec![[0, 1, 2]],
            )
        };
        let edges = [[0, 1], [0, 2], [1, 2]];
        let sharp = [EdgeFlags::SHARP; 3];
        assert_eq!(
            flat_creases_kept(&cap(0.1), &edges, &sharp, 0.25),
            [false, true, true]
        );
        assert_eq!(
            flat_creases_kept(&cap(0.5), &edges, &sharp, 0.25),
            [true; 3]
        );
        // A boundary edge is never dropped, nor any edge of its face.
        let flags = [EdgeFlags::BOUNDARY, EdgeFlags::SHARP, EdgeFlags::SHARP];
        assert_eq!(
            flat_creases_kept(&cap(0.1), &edges, &flags, 0.25),
            [true; 3]
        );
    }

    #[test]
    fn segment_closest_point_returns_exact_end_points() {
        let (a, b) = (DVec3::new(0.1, 0.2, 0.3), DVec3::new(1.7, -0.4, 2.9));
        let (t, q, _) = closest_point_on_segment(b + DVec3::new(5.0, 0.0, 5.0), a, b);
        assert_eq!((t, q), (1.0, b));
        let (t, q, _) = closest_point_on_segment(a - (b - a), a, b);
        assert_eq!((t, q), (0.0, a));
        let (t, q, d2) = closest_point_on_segment(DVec3::ONE, a, a);
        assert_eq!((t, q), (0.0, a));
        assert!((d2 - (DVec3::ONE - a).length_squared()).abs() < 1e-15);
    }

    #[test]
    fn edge_flags_combine() {
        let f = EdgeFlags::BOUNDARY | EdgeFlags::LABEL_BORDER;
        assert!(f.contains(EdgeFlags::BOUNDARY));
        assert!(f.contains(EdgeFlags::LABEL_BORDER));
        assert!(!f.contains(EdgeFlags::SHARP));
        assert!(EdgeFlags::default().is_empty());
    }

    #[test]
    fn flipped_flat_pair_is_not_a_crease() {
        // Two coplanar triangles whose orientations disagree.
        let m = TriMesh::new(
            vec![DVec3::ZERO, DVec3::X, DVec3::Y, DVec3::new(1.0, 1.0, 0.0)],
            vec![[0, 1, 2], [1, 2, 3]],
        );
        let fs = detect_features(&m, &FeatureOptions::default());
        assert!(!fs.is_feature_edge(1, 2));
        assert_eq!(fs.edges().len(), 4);
    }

    #[test]
    fn degenerate_and_invalid_triangles_do_not_create_features_or_panic() {
        // A flat grid with a zero-area sliver glued along one interior edge
        // and garbage triangles that must be ignored.
        let mut m = shapes::grid(1.0, 2);
        m.triangles.push([0, 0, 1]);
        m.triangles.push([0, 1, 99]);
        let base = detect_features(&shapes::grid(1.0, 2), &FeatureOptions::default());
        let fs = detect_features(&m, &FeatureOptions::default());
        assert_eq!(fs.edges(), base.edges());

        // A zero-area face (collinear corners) next to a real one: the shared
        // edge has no defined dihedral and must not become a crease.
        let m = TriMesh::new(
            vec![
                DVec3::ZERO,
                DVec3::X,
                DVec3::new(0.5, 1.0, 0.0),
                DVec3::new(2.0, 0.0, 0.0),
            ],
            vec![[0, 1, 2], [1, 0, 3]],
        );
        let fs = detect_features(&m, &FeatureOptions::default());
        assert!(!fs.is_feature_edge(0, 1));
        assert!(fs.is_feature_edge(0, 3) && fs.is_feature_edge(1, 2));
    }

    #[test]
    fn segment_index_matches_brute_force_on_an_edge_soup() {
        let m = shapes::icosphere(2);
        let edges = mesh_edges(&m);
        let seg = |s: u32| {
            let [a, b] = edges[s as usize];
            [m.positions[a as usize], m.positions[b as usize]]
        };
        let tree = SegmentIndex::new(edges.len(), |s| seg(s as u32));
        let mut x = 12345u64;
        let mut rnd = || {
            x ^= x << 13;
            x ^= x >> 7;
            x ^= x << 17;
            (x >> 11) as f64 / (1u64 << 53) as f64 * 3.0 - 1.5
        };
        for _ in 0..500 {
            let p = DVec3::new(rnd(), rnd(), rnd());
            let got = tree.closest(p).unwrap();
            let mut want = SegmentPoint::on_segment(p, 0, seg(0)[0], seg(0)[1]);
            for s in 1..edges.len() as u32 {
                let [a, b] = seg(s);
                let c = SegmentPoint::on_segment(p, s, a, b);
                if c.better_than(&want) {
                    want = c;
                }
            }
            assert_eq!(
                (got.segment, got.distance_squared),
                (want.segment, want.distance_squared)
            );
        }
    }
}
