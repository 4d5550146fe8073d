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
//! [`polyline_distance`] measures how well an output mesh keeps a set of input
//! edges, the `features` / `boundary` metric of `bench/quality.py`.

use glam::DVec3;
use rayon::prelude::*;

use crate::trimesh::TriMesh;

/// Default dihedral angle above which an interior edge is a crease, degrees.
///
/// 45° as in the bench and gpytoolbox, so that our feature set is the one
/// the bench measures (fandisk: 706 edges). A CAD part's creases are far
/// above it (fandisk's are 60°–120°, except two creases that fade out
/// gradually and end wherever the threshold cuts them), while at 30°
/// (MeshLab's default) scan noise on organic models already registers as
/// hundreds of spurious creases, which would pin the remesher to the scan's
/// triangulation.
pub const DEFAULT_FEATURE_ANGLE_DEG: f64 = 45.0;

/// Default turning angle above which a valence-2 feature vertex is a corner,
/// degrees (deviation of the two feature edges from a straight line).
///
/// 45° keeps the 90° corners of boxes, plates and grids, while a tessellated
/// circle (a cylinder rim, a fillet arc) needs fewer than 8 segments before
/// its vertices turn into corners: a 16-gon turns by 22.5°, an octagon by
/// exactly 45°, which is not more than 45°. On fandisk every valence-2 crease
/// vertex turns by less than 30° (its arcs by 22.5°) except one 160° hairpin,
/// so any value in 30°–160° gives the same 25 corners; 45° sits with margin
/// inside that range. A lower value would also pin the many 20°–40° wiggles
/// of scanned boundaries, which the remesher should be free to coarsen.
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
    /// Root of this line's segment tree in the set's node arena.
    root: u32,
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
    tree: SegTree,
}

/// Finds the features of `mesh`. Robust to unreferenced vertices, triangles
/// with repeated or out-of-range indices (ignored), degenerate faces (never
/// a crease), inconsistent orientation and non-manifold edges.
pub fn detect_features(mesh: &TriMesh, opts: &FeatureOptions) -> FeatureSet {
    let nv = mesh.positions.len();
    let feature_angle = sanitize(opts.feature_angle_deg, DEFAULT_FEATURE_ANGLE_DEG);
    let corner_angle = sanitize(opts.corner_angle_deg, DEFAULT_CORNER_ANGLE_DEG);

    let (mut edges, mut edge_flags) = classify_edges(mesh, opts.preserve_features, feature_angle);
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
            root: 0,
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
    let mut tree = SegTree::default();
    for line in &mut lines {
        let pts = &points[line.point_offset as usize..][..line.vertices.len()];
        line.root = tree.build(line.vertices.len() as u32 - 1, |s| {
            [pts[s as usize], pts[s as usize + 1]]
        });
    }

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
        tree,
    }
}

/// Traces feature lines through the feature graph, recording for every edge
/// its (line, segment) and for every line vertex its kind and index.
struct LineWalker<'a> {
    edges: &'a [[u32; 2]],
    adj_offset: &'a [u32],
    adj: &'a [[u32; 2]],
    kind: &'a mut [VertexKind],
    edge_segment: &'a mut [[u32; 2]],
    line_index: &'a mut [u32],
}

impl LineWalker<'_> {
    /// Follows feature edges from `start` through `first_edge` until a corner
    /// or back at `start`; returns the vertex ids of line `id`.
    fn walk(&mut self, start: u32, first_edge: u32, id: u32) -> Vec<u32> {
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
fn feature_adjacency(nv: usize, edges: &[[u32; 2]]) -> (Vec<u32>, Vec<[u32; 2]>) {
    let mut offset = vec![0u32; nv + 1];
    for &[a, b] in edges {
        offset[a as usize + 1] += 1;
        offset[b as usize + 1] += 1;
    }
    for i in 0..nv {
        offset[i + 1] += offset[i];
    }
    let mut fill: Vec<u32> = offset[..nv].to_vec();
    let mut adj = vec![[0u32; 2]; 2 * edges.len()];
    for (e, &[a, b]) in edges.iter().enumerate() {
        adj[fill[a as usize] as usize] = [b, e as u32];
        fill[a as usize] += 1;
        adj[fill[b as usize] as usize] = [a, e as u32];
        fill[b as usize] += 1;
    }
    for v in 0..nv {
        let row = &mut adj[offset[v] as usize..offset[v + 1] as usize];
        if row.len() > 1 {
            row.sort_unstable();
        }
    }
    (offset, adj)
}

/// Which feature edges survive the small-crease filter of
/// [`FeatureOptions::min_crease_length`]. A crease smaller than that cannot
/// be resampled by edges of the target length: keeping it pins corners a
/// fraction of an edge apart, and every triangle around such a short edge is
/// a sliver (scans at a 45° feature angle carry dozens of these noise
/// fragments). Two rules, repeated until nothing changes:
/// - a connected component of the feature graph made of creases only, whose
///   total length is below the threshold, goes;
/// - a crease-only chain between two vertices of feature degree other than 2
///   (free ends and junctions, through degree-2 vertices), shorter than the
///   threshold, goes: isolated fragments and spurs; a bridge between two
///   junctions goes only below [`FeatureOptions::min_bridge_length`].
fn small_creases_kept(
    mesh: &TriMesh,
    edges: &[[u32; 2]],
    flags: &[EdgeFlags],
    min_len: f64,
    min_bridge: f64,
) -> Vec<bool> {
    let nv = mesh.positions.len();
    let len = |e: usize| {
        let [a, b] = edges[e];
        (mesh.positions[a as usize] - mesh.positions[b as usize]).length()
    };
    let crease_only = |e: usize| flags[e] == EdgeFlags::SHARP;
    let mut keep = vec![true; edges.len()];
    // Incident edges of each vertex, fixed; `keep` masks the removed ones.
    let (offset, adj) = feature_adjacency(nv, edges);
    fn live<'a>(
        offset: &[u32],
        adj: &'a [[u32; 2]],
        keep: &'a [bool],
        v: u32,
    ) -> impl Iterator<Item = u32> + 'a {
        adj[offset[v as usize] as usize..offset[v as usize + 1] as usize]
            .iter()
            .map(|&[_, e]| e)
            .filter(move |&e| keep[e as usize])
    }
    loop {
        let mut changed = false;
        // Components: flood fill over kept edges.
        let mut seen = vec![false; edges.len()];
        let mut stack = Vec::new();
        let mut comp = Vec::new();
        for e0 in 0..edges.len() {
            if !keep[e0] || seen[e0] {
                continue;
            }
            comp.clear();
            seen[e0] = true;
            stack.push(e0 as u32);
            while let Some(e) = stack.pop() {
                comp.push(e);
                for v in edges[e as usize] {
                    for f in live(&offset, &adj, &keep, v) {
                        if !seen[f as usize] {
                            seen[f as usize] = true;
                            stack.push(f);
                        }
                    }
                }
            }
            let total: f64 = comp.iter().map(|&e| len(e as usize)).sum();
            if total < min_len && comp.iter().all(|&e| crease_only(e as usize)) {
                for &e in &comp {
                    keep[e as usize] = false;
                }
                changed = true;
            }
        }
        // Chains: from every vertex of feature degree other than 2, walk
        // each kept edge through degree-2 vertices to the next such vertex.
        for v0 in 0..nv as u32 {
            let d0 = live(&offset, &adj, &keep, v0).count();
            if d0 == 0 || d0 == 2 {
                continue;
            }
            let starts: Vec<u32> = live(&offset, &adj, &keep, v0).collect();
            for first in starts {
                if !keep[first as usize] {
                    continue;
                }
                let mut chain = Vec::new();
                let (mut v, mut e) = (v0, first);
                let mut total = 0.0;
                // The feature degree of the chain's far end, once reached
                // within the threshold.
                let end_degree = loop {
                    chain.push(e);
                    total += len(e as usize);
                    let [a, b] = edges[e as usize];
                    v = if a == v { b } else { a };
                    if total >= min_len {
                        break None;
                    }
                    let d = live(&offset, &adj, &keep, v).count();
                    if v == v0 || d != 2 {
                        break Some(d);
                    }
                    e = live(&offset, &adj, &keep, v).find(|&f| f != e).unwrap();
                };
                // A bridge between two junctions has its own threshold.
                let short = match end_degree {
                    None => false,
                    Some(d) => d0 <= 2 || d <= 2 || total < min_bridge,
                };
                if short && chain.iter().all(|&e| crease_only(e as usize)) {
                    for &e in &chain {
                        keep[e as usize] = false;
                    }
                    changed = true;
                }
            }
        }
        if !changed {
            return keep;
        }
    }
}

/// Drops the feature edges (and their flags) whose `keep` entry is false.
fn retain_kept(edges: &mut Vec<[u32; 2]>, flags: &mut Vec<EdgeFlags>, keep: &[bool]) {
    (*edges, *flags) = (edges.iter().zip(flags.iter()).zip(keep))
        .filter(|(_, &k)| k)
        .map(|((&e, &f), _)| (e, f))
        .unzip();
}

/// Largest gap between two crease chains that [`twin_creases_kept`] takes
/// for one crease drawn twice, in units of
/// [`FeatureOptions::min_crease_length`]: 1/6, a quarter of the remesher's
/// target length at the default 1.5 L.
const TWIN_GAP: f64 = 1.0 / 6.0;

/// Which feature edges survive the flat-face rule: an input face whose three
/// edges are all creases and whose height over its longest edge is at most
/// `gap` (a cap: its third corner lies almost on that edge) loses the
/// longest edge. Scan noise makes such faces, tilted against every
/// neighbour; kept, the three creases meet at two corners with a sector of
/// a few degrees (the bunny's narrowest, 0.48°), and every output triangle
/// in it is a sliver. Every point of the dropped edge lies within the height
/// of the two edges kept, which still join its ends. Faces are visited in
/// index order against the edges still kept.
fn flat_creases_kept(
    mesh: &TriMesh,
    edges: &[[u32; 2]],
    flags: &[EdgeFlags],
    gap: f64,
) -> Vec<bool> {
    let mut keep = vec![true; edges.len()];
    if gap.is_nan() || gap <= 0.0 {
        return keep;
    }
    let nv = mesh.positions.len();
    let (offset, adj) = feature_adjacency(nv, edges);
    let edge_id = |a: u32, b: u32| {
        adj[offset[a as usize] as usize..offset[a as usize + 1] as usize]
            .iter()
            .find(|n| n[0] == b)
            .map(|n| n[1] as usize)
    };
    for t in &mesh.triangles {
        if t.iter().any(|&v| v as usize >= nv) {
            continue;
        }
        let mut ids = [0usize; 3];
        let mut all = true;
        for k in 0..3 {
            match edge_id(t[k], t[(k + 1) % 3]) {
                Some(e) if keep[e] && flags[e] == EdgeFlags::SHARP => ids[k] = e,
                _ => all = false,
            }
        }
        if !all {
            continue;
        }
        let p = t.map(|v| mesh.positions[v as usize]);
        let len = [0, 1, 2].map(|k| p[k].distance(p[(k + 1) % 3]));
        let k = (0..3).fold(0, |k, i| if len[i] > len[k] { i } else { k });
        let area2 = crate::geometry::triangle_cross(p).length();
        if len[k] > 0.0 && area2 / len[k] <= gap {
            keep[ids[k]] = false;
        }
    }
    keep
}

/// Which feature edges survive the twin rule: two crease-only chains that
/// join the same two junctions (vertices where three or more feature edges
/// meet) and stay within `gap` of each other all along (every vertex of each
/// within `gap` of the other polyline) are one crease drawn twice, as scan
/// noise draws a ridge's two flanks; the longer of the two goes. Kept, both
/// pin the output to two lines a fraction of an edge apart, and every
/// triangle between them is a sliver (camelhead: two such chains 0.02·L
/// apart held 68 triangles below 30°), while dropping one moves no crease
/// point farther than `gap` from an output edge.
fn twin_creases_kept(
    mesh: &TriMesh,
    edges: &[[u32; 2]],
    flags: &[EdgeFlags],
    gap: f64,
) -> Vec<bool> {
    let mut keep = vec![true; edges.len()];
    if gap.is_nan() || gap <= 0.0 {
        return keep;
    }
    let nv = mesh.positions.len();
    let (offset, adj) = feature_adjacency(nv, edges);
    let row = |v: u32| &adj[offset[v as usize] as usize..offset[v as usize + 1] as usize];
    // Chains between junctions, each once (from its smaller end, or its
    // smaller first edge when both ends are the same vertex): the ends, the
    // edges, the vertices in order and the length.
    struct Chain {
        ends: [u32; 2],
        edges: Vec<u32>,
        vertices: Vec<u32>,
        length: f64,
    }
    let mut chains: Vec<Chain> = Vec::new();
    for v0 in 0..nv as u32 {
        if row(v0).len() < 3 {
            continue;
        }
        for &[_, first] in row(v0) {
            let mut c = Chain {
                ends: [v0, v0],
                edges: Vec::new(),
                vertices: vec![v0],
                length: 0.0,
            };
            let (mut v, mut e) = (v0, first);
            let ok = loop {
                if flags[e as usize] != EdgeFlags::SHARP {
                    break false;
                }
                c.edges.push(e);
                let [a, b] = edges[e as usize];
                let w = if a == v { b } else { a };
                c.length += (mesh.positions[w as usize] - mesh.positions[v as usize]).length();
                c.vertices.push(w);
                v = w;
                let r = row(v);
                if r.len() != 2 || v == v0 {
                    break r.len() >= 3;
                }
                e = if r[0][1] == e { r[1][1] } else { r[0][1] };
            };
            let last = *c.edges.last().unwrap_or(&first);
            if ok && (v0 < v || (v0 == v && first < last)) {
                c.ends = [v0, v];
                chains.push(c);
            }
        }
    }
    chains.sort_by_key(|c| (c.ends, c.edges[0]));
    let pos = |v: u32| mesh.positions[v as usize];
    // Every vertex of `a` within `gap` of `b`'s polyline.
    let covered = |a: &Chain, b: &Chain| {
        a.vertices.iter().all(|&v| {
            let p = pos(v);
            b.vertices
                .windows(2)
                .any(|s| closest_on_segment(pos(s[0]), pos(s[1]), p).2 <= gap * gap)
        })
    };
    let mut i = 0;
    while i < chains.len() {
        let mut j = i + 1;
        while j < chains.len() && chains[j].ends == chains[i].ends {
            j += 1;
        }
        let group = &chains[i..j];
        for x in 0..group.len() {
            for y in x + 1..group.len() {
                let (a, b) = (&group[x], &group[y]);
                let live = |c: &Chain| c.edges.iter().all(|&e| keep[e as usize]);
                if a.ends[0] == a.ends[1] || !live(a) || !live(b) {
                    continue;
                }
                if covered(a, b) && covered(b, a) {
                    let gone = if b.length >= a.length { b } else { a };
                    for &e in &gone.edges {
                        keep[e as usize] = false;
                    }
                }
            }
        }
        i = j;
    }
    keep
}

/// Whether turn vertex `v` may be left off the corners: a corner already
/// chosen lies within `reach` of it along the feature graph (walking both
/// ways through degree-2 vertices), and the line's chord over that stretch
/// passes within `reach / 3` of it (0.5·L at the default threshold; the
/// bench's Duck keeps every turn that shapes its outline). Such a turn is a
/// wiggle of the crease (scan noise), and keeping it next to the other corner would pin two
/// output vertices a fraction of an edge apart, with slivers around them. A
/// turn that stands out further than that is a shape the output must keep.
fn turn_is_wiggle(
    mesh: &TriMesh,
    adj_offset: &[u32],
    adj: &[[u32; 2]],
    kind: &[VertexKind],
    v: u32,
    reach: f64,
) -> bool {
    let row = |u: u32| &adj[adj_offset[u as usize] as usize..adj_offset[u as usize + 1] as usize];
    let p = mesh.positions[v as usize];
    let mut near_corner = false;
    let mut ends = [p; 2];
    for (side, &[first, _]) in row(v).iter().enumerate().take(2) {
        let (mut prev, mut cur) = (v, first);
        let mut dist = p.distance(mesh.positions[cur as usize]);
        loop {
            if dist < reach && kind[cur as usize] == VertexKind::Corner {
                near_corner = true;
            }
            let r = row(cur);
            if dist >= reach || r.len() != 2 || cur == v || kind[cur as usize] == VertexKind::Corner
            {
                break;
            }
            let next = if r[0][0] == prev { r[1][0] } else { r[0][0] };
            dist += mesh.positions[cur as usize].distance(mesh.positions[next as usize]);
            prev = cur;
            cur = next;
        }
        ends[side] = mesh.positions[cur as usize];
    }
    if !near_corner {
        return false;
    }
    let (a, ab) = (ends[0], ends[1] - ends[0]);
    let t = if ab.length_squared() > 0.0 {
        ((p - a).dot(ab) / ab.length_squared()).clamp(0.0, 1.0)
    } else {
        0.0
    };
    p.distance(a + ab * t) < reach / 3.0
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

/// Undirected edges of `mesh` with their half-edges, visited in (a, b) order
/// with a < b. A half-edge is `3·face + k`, the edge from corner `k` to corner
/// `k + 1`. Bucketing by the smaller end point replaces a global sort.
struct EdgeTable {
    /// (b, half-edge) grouped by a (CSR over `offset`), sorted within a row.
    items: Vec<(u32, u32)>,
    offset: Vec<u32>,
}

impl EdgeTable {
    fn new(mesh: &TriMesh) -> Self {
        let nv = mesh.positions.len();
        let valid = |t: &[u32; 3]| {
            t.iter().all(|&v| (v as usize) < nv) && t[0] != t[1] && t[1] != t[2] && t[2] != t[0]
        };
        let mut offset = vec![0u32; nv + 1];
        for t in mesh.triangles.iter().filter(|t| valid(t)) {
            for k in 0..3 {
                let (a, b) = (t[k], t[(k + 1) % 3]);
                offset[a.min(b) as usize + 1] += 1;
            }
        }
        for i in 0..nv {
            offset[i + 1] += offset[i];
        }
        let mut fill: Vec<u32> = offset[..nv].to_vec();
        let mut items = vec![(0u32, 0u32); offset[nv] as usize];
        for (f, t) in mesh.triangles.iter().enumerate() {
            if !valid(t) {
                continue;
            }
            for k in 0..3 {
                let (a, b) = (t[k], t[(k + 1) % 3]);
                let lo = a.min(b) as usize;
                items[fill[lo] as usize] = (a.max(b), 3 * f as u32 + k as u32);
                fill[lo] += 1;
            }
        }
        for v in 0..nv {
            let row = &mut items[offset[v] as usize..offset[v + 1] as usize];
            if row.len() > 1 {
                row.sort_unstable();
            }
        }
        Self { items, offset }
    }

    /// Calls `f(a, b, half_edges)` for every undirected edge in sorted order.
    fn for_each(&self, mut f: impl FnMut(u32, u32, &[(u32, u32)])) {
        for a in 0..self.offset.len().saturating_sub(1) {
            let row = &self.items[self.offset[a] as usize..self.offset[a + 1] as usize];
            let mut i = 0;
            while i < row.len() {
                let b = row[i].0;
                let mut j = i + 1;
                while j < row.len() && row[j].0 == b {
                    j += 1;
                }
                f(a as u32, b, &row[i..j]);
                i = j;
            }
        }
    }
}

/// Dihedral angle of the edge shared by half-edges `h0`, `h1`, degrees; 0
/// when a face is degenerate. When both faces run the edge the same way (an
/// orientation flip) one normal is reversed so that a flat but flipped pair
/// does not read as a 180° crease.
fn dihedral_deg(mesh: &TriMesh, normals: &[DVec3], h0: u32, h1: u32) -> f64 {
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

fn classify_edges(
    mesh: &TriMesh,
    preserve_features: bool,
    feature_angle_deg: f64,
) -> (Vec<[u32; 2]>, Vec<EdgeFlags>) {
    let table = EdgeTable::new(mesh);
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
        if !fl.is_empty() {
            edges.push([a, b]);
            flags.push(fl);
        }
    });
    (edges, flags)
}

impl FeatureSet {
    /// The feature edge id of input edge (a, b), in either order.
    #[inline]
    pub fn edge_id(&self, a: u32, b: u32) -> Option<u32> {
        let a = a as usize;
        if a + 1 >= self.adj_offset.len() {
            return None;
        }
        self.adj[self.adj_offset[a] as usize..self.adj_offset[a + 1] as usize]
            .iter()
            .find(|n| n[0] == b)
            .map(|n| n[1])
    }

    /// Whether input edge (a, b) is a feature edge.
    #[inline]
    pub fn is_feature_edge(&self, a: u32, b: u32) -> bool {
        self.edge_id(a, b).is_some()
    }

    /// All feature edges as (a, b) with a < b, sorted.
    pub fn edges(&self) -> &[[u32; 2]] {
        &self.edges
    }

    /// Why feature edge `id` (an index into [`Self::edges`]) is a feature.
    pub fn edge_flags(&self, id: u32) -> EdgeFlags {
        self.edge_flags[id as usize]
    }

    /// Number of feature edges having all reasons in `flags`.
    pub fn count_edges_with(&self, flags: EdgeFlags) -> usize {
        self.edge_flags.iter().filter(|f| f.contains(flags)).count()
    }

    /// Whether input vertex `v` is a corner.
    #[inline]
    pub fn is_corner(&self, v: u32) -> bool {
        self.vertex_kind(v) == VertexKind::Corner
    }

    /// The corners, ascending.
    pub fn corners(&self) -> &[u32] {
        &self.corners
    }

    /// What input vertex `v` is ([`VertexKind::Smooth`] for unknown ids).
    #[inline]
    pub fn vertex_kind(&self, v: u32) -> VertexKind {
        self.kind
            .get(v as usize)
            .copied()
            .unwrap_or(VertexKind::Smooth)
    }

    /// For a [`VertexKind::Line`] vertex, its index in its line's vertex list.
    pub fn vertex_line_index(&self, v: u32) -> Option<(u32, u32)> {
        match self.vertex_kind(v) {
            VertexKind::Line(l) => Some((l, self.line_index[v as usize])),
            _ => None,
        }
    }

    /// The feature neighbours of input vertex `v`, ascending.
    pub fn feature_neighbors(&self, v: u32) -> impl Iterator<Item = u32> + '_ {
        let v = v as usize;
        let row: &[[u32; 2]] = if v + 1 < self.adj_offset.len() {
            &self.adj[self.adj_offset[v] as usize..self.adj_offset[v + 1] as usize]
        } else {
            &[]
        };
        row.iter().map(|n| n[0])
    }

    /// The feature lines. Every feature edge is a segment of exactly one line.
    pub fn lines(&self) -> &[FeatureLine] {
        &self.lines
    }

    /// The positions of line `line`'s vertices (as in the input mesh).
    ///
    /// Panics if `line` is out of range.
    pub fn line_points(&self, line: u32) -> &[DVec3] {
        let l = &self.lines[line as usize];
        &self.points[l.point_offset as usize..][..l.vertices.len()]
    }

    /// The line that input feature edge (a, b) belongs to.
    #[inline]
    pub fn edge_line(&self, a: u32, b: u32) -> Option<u32> {
        self.edge_segment(a, b).map(|s| s[0])
    }

    /// (line, segment) of input feature edge (a, b).
    #[inline]
    pub fn edge_segment(&self, a: u32, b: u32) -> Option<[u32; 2]> {
        self.edge_id(a, b).map(|e| self.edge_segment[e as usize])
    }

    /// Unit direction of segment `segment` of line `line` (from
    /// `vertices[segment]` to `vertices[segment + 1]`); zero if degenerate.
    ///
    /// Panics if `line` or `segment` is out of range.
    pub fn line_tangent(&self, line: u32, segment: u32) -> DVec3 {
        let p = self.line_points(line);
        (p[segment as usize + 1] - p[segment as usize]).normalize_or_zero()
    }

    /// The point at parameter `t` on segment `segment` of line `line`.
    ///
    /// Panics if `line` or `segment` is out of range.
    pub fn line_point(&self, line: u32, segment: u32, t: f64) -> DVec3 {
        let p = self.line_points(line);
        lerp_exact(p[segment as usize], p[segment as usize + 1], t)
    }

    /// The closest point to `p` on line `line`. Ties in distance go to the
    /// lowest segment index, so the answer is deterministic. A non-finite
    /// `p` gives segment 0, t = 0 and a NaN distance.
    ///
    /// Panics if `line` is out of range.
    pub fn closest_on_line(&self, line: u32, p: DVec3) -> LinePoint {
        self.closest_from(line, p, Candidate::NONE)
    }

    /// Same answer as [`Self::closest_on_line`] (bit for bit), usually
    /// faster when `hint_segment` is at or next to the answer: a local walk
    /// from the hint gives a tight bound, then the segment tree only opens
    /// the nodes within that bound. Out-of-range hints are clamped.
    ///
    /// Panics if `line` is out of range.
    pub fn closest_on_line_near(&self, line: u32, p: DVec3, hint_segment: u32) -> LinePoint {
        let l = &self.lines[line as usize];
        let pts = self.line_points(line);
        let n = l.segment_count() as u32;
        let closed = l.is_closed();
        let eval = |s: u32| {
            let (t, q, d2) = closest_on_segment(pts[s as usize], pts[s as usize + 1], p);
            Candidate { d2, item: s, t, q }
        };
        if !p.is_finite() {
            return self.closest_on_line(line, p);
        }
        let mut best = eval(hint_segment.min(n - 1));
        // Walk downhill in both directions (a closed line wraps around), a
        // bounded number of steps: a far-off hint must not cost O(n).
        for dir in [1i64, -1] {
            let mut s = best.item;
            for _ in 0..n.min(NEAR_WALK_STEPS) {
                let next = s as i64 + dir;
                let next = if closed {
                    next.rem_euclid(n as i64) as u32
                } else if (0..n as i64).contains(&next) {
                    next as u32
                } else {
                    break;
                };
                let c = eval(next);
                if !c.better_than(&best) {
                    break;
                }
                best = c;
                s = next;
            }
        }
        self.closest_from(line, p, best)
    }

    fn closest_from(&self, line: u32, p: DVec3, init: Candidate) -> LinePoint {
        let l = &self.lines[line as usize];
        let pts = self.line_points(line);
        let best = self
            .tree
            .nearest(l.root, p, init, |s| [pts[s as usize], pts[s as usize + 1]]);
        if best.item == u32::MAX {
            return LinePoint {
                segment: 0,
                t: 0.0,
                point: pts[0],
                dist2: f64::NAN,
            };
        }
        LinePoint {
            segment: best.item,
            t: best.t,
            point: best.q,
            dist2: best.d2,
        }
    }
}

/// `a + t (b − a)`, returning the end points exactly at t = 0 and t = 1 so
/// that the shared vertex of two segments has one position.
#[inline]
fn lerp_exact(a: DVec3, b: DVec3, t: f64) -> DVec3 {
    if t <= 0.0 {
        a
    } else if t >= 1.0 {
        b
    } else {
        a + (b - a) * t
    }
}

/// Closest point of segment [a, b] to p: (t, point, squared distance).
#[inline]
fn closest_on_segment(a: DVec3, b: DVec3, p: DVec3) -> (f64, DVec3, f64) {
    let d = b - a;
    let dd = d.length_squared();
    let t = if dd > 0.0 {
        ((p - a).dot(d) / dd).clamp(0.0, 1.0)
    } else {
        0.0
    };
    let q = lerp_exact(a, b, t);
    (t, q, (p - q).length_squared())
}

#[derive(Clone, Copy, Debug)]
struct Candidate {
    d2: f64,
    item: u32,
    t: f64,
    q: DVec3,
}

impl Candidate {
    const NONE: Candidate = Candidate {
        d2: f64::INFINITY,
        item: u32::MAX,
        t: 0.0,
        q: DVec3::ZERO,
    };

    /// Lexicographic (distance, item) order: deterministic under ties.
    #[inline]
    fn better_than(&self, other: &Candidate) -> bool {
        self.d2 < other.d2 || (self.d2 == other.d2 && self.item < other.item)
    }
}

/// Most segments the hint walk of [`FeatureSet::closest_on_line_near`] visits per direction.
const NEAR_WALK_STEPS: u32 = 16;

/// Leaf size of the segment tree: a few segments per leaf amortise the box test.
const LEAF: usize = 4;

#[derive(Clone, Copy, Debug, Default)]
struct Node {
    min: DVec3,
    max: DVec3,
    /// Leaf: first item in `items`; inner: index of the right child (the
    /// left child follows the node directly).
    first: u32,
    /// Leaf: item count; inner: 0.
    count: u32,
}

/// A bounding-box tree over segments, median split on the widest centroid
/// axis. Several trees share one node arena; each is addressed by its root.
#[derive(Clone, Debug, Default)]
struct SegTree {
    nodes: Vec<Node>,
    items: Vec<u32>,
}

impl SegTree {
    /// Adds a tree over segments `0..n` (endpoints from `seg`) and returns
    /// its root. `n` must be at least 1.
    fn build(&mut self, n: u32, seg: impl Fn(u32) -> [DVec3; 2]) -> u32 {
        let base = self.items.len();
        self.items.extend(0..n);
        let centroids: Vec<DVec3> = (0..n)
            .map(|s| {
                let [a, b] = seg(s);
                (a + b) * 0.5
            })
            .collect();
        let root = self.nodes.len() as u32;
        self.build_node(base, base + n as usize, &centroids, &seg);
        root
    }

    fn build_node(
        &mut self,
        lo: usize,
        hi: usize,
        centroids: &[DVec3],
        seg: &impl Fn(u32) -> [DVec3; 2],
    ) {
        let mut min = DVec3::INFINITY;
        let mut max = DVec3::NEG_INFINITY;
        let mut cmin = DVec3::INFINITY;
        let mut cmax = DVec3::NEG_INFINITY;
        for &s in &self.items[lo..hi] {
            let [a, b] = seg(s);
            min = min.min(a).min(b);
            max = max.max(a).max(b);
            let c = centroids[s as usize];
            cmin = cmin.min(c);
            cmax = cmax.max(c);
        }
        let id = self.nodes.len();
        self.nodes.push(Node {
            min,
            max,
            first: lo as u32,
            count: (hi - lo) as u32,
        });
        if hi - lo <= LEAF {
            return;
        }
        let ext = cmax - cmin;
        let axis = if ext.x >= ext.y && ext.x >= ext.z {
            0
        } else if ext.y >= ext.z {
            1
        } else {
            2
        };
        let mid = (lo + hi) / 2;
        self.items[lo..hi].select_nth_unstable_by(mid - lo, |&x, &y| {
            centroids[x as usize][axis].total_cmp(&centroids[y as usize][axis])
        });
        self.build_node(lo, mid, centroids, seg);
        let right = self.nodes.len() as u32;
        self.build_node(mid, hi, centroids, seg);
        self.nodes[id].first = right;
        self.nodes[id].count = 0;
    }

    /// The best candidate among `init` and the segments of the tree at `root`.
    fn nearest(
        &self,
        root: u32,
        p: DVec3,
        init: Candidate,
        seg: impl Fn(u32) -> [DVec3; 2],
    ) -> Candidate {
        let mut best = init;
        let mut stack = [0u32; 96];
        stack[0] = root;
        let mut sp = 1;
        // Nodes at exactly the best distance are still opened: they may hold
        // an equally close segment with a lower index (the tie rule).
        while sp > 0 {
            sp -= 1;
            let node = &self.nodes[stack[sp] as usize];
            if box_dist2(node, p) > best.d2 {
                continue;
            }
            if node.count > 0 {
                for &s in &self.items[node.first as usize..][..node.count as usize] {
                    let [a, b] = seg(s);
                    let (t, q, d2) = closest_on_segment(a, b, p);
                    let c = Candidate { d2, item: s, t, q };
                    if c.better_than(&best) {
                        best = c;
                    }
                }
            } else {
                let left = stack[sp] + 1;
                let right = node.first;
                let dl = box_dist2(&self.nodes[left as usize], p);
                let dr = box_dist2(&self.nodes[right as usize], p);
                // Push the farther child first so the nearer one is opened next.
                let (near, far, dfar) = if dl <= dr {
                    (left, right, dr)
                } else {
                    (right, left, dl)
                };
                if dfar <= best.d2 {
                    stack[sp] = far;
                    sp += 1;
                }
                stack[sp] = near;
                sp += 1;
            }
        }
        best
    }
}

#[inline]
fn box_dist2(n: &Node, p: DVec3) -> f64 {
    let d = (n.min - p).max(p - n.max).max(DVec3::ZERO);
    d.length_squared()
}

/// All undirected edges of `mesh` as (a, b) with a < b, sorted. Triangles
/// with repeated or out-of-range indices are ignored.
pub fn mesh_edges(mesh: &TriMesh) -> Vec<[u32; 2]> {
    let mut out = Vec::new();
    EdgeTable::new(mesh).for_each(|a, b, _| out.push([a, b]));
    out
}

/// Edges of `mesh` with exactly one face, sorted.
pub fn boundary_edges(mesh: &TriMesh) -> Vec<[u32; 2]> {
    let mut out = Vec::new();
    EdgeTable::new(mesh).for_each(|a, b, hs| {
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
    let (edges, flags) = classify_edges(mesh, true, angle_deg);
    edges
        .into_iter()
        .zip(flags)
        .filter(|(_, f)| f.contains(EdgeFlags::SHARP))
        .map(|(e, _)| e)
        .collect()
}

/// Distances from points sampled along one edge set to the nearest segment
/// of another, in absolute units.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct PolylineDistance {
    /// Largest sample distance.
    pub max: f64,
    /// Mean sample distance.
    pub mean: f64,
    /// Number of samples.
    pub samples: usize,
}

/// Samples every edge of (`from_points`, `from_edges`) at both end points and
/// every ≤ `step` in between (the bench's `sample_polyline`), and measures
/// each sample's exact distance to the nearest segment of (`to_points`,
/// `to_edges`). This is the bench's `features` metric (with the input's
/// [`sharp_edges`] against the output's [`mesh_edges`], `step` = L/4) and its
/// `boundary` metric (with [`boundary_edges`] on both sides), before dividing
/// by L.
///
/// Returns `None` when `from_edges` is empty; `max` and `mean` are infinite
/// when `to_edges` is empty. Edges with out-of-range indices are skipped. A
/// non-positive or non-finite `step` samples the end points only.
pub fn polyline_distance(
    from_points: &[DVec3],
    from_edges: &[[u32; 2]],
    step: f64,
    to_points: &[DVec3],
    to_edges: &[[u32; 2]],
) -> Option<PolylineDistance> {
    let samples = edge_samples(from_points, from_edges, step);
    if samples.is_empty() {
        return None;
    }
    let d = point_edge_distances(&samples, to_points, to_edges);
    Some(PolylineDistance {
        max: d.iter().copied().fold(0.0, f64::max),
        mean: d.iter().sum::<f64>() / d.len() as f64,
        samples: d.len(),
    })
}

/// Points along every edge of (`points`, `edges`): both end points and
/// every ≤ `step` in between, as [`polyline_distance`] samples them. Edges
/// with out-of-range indices are skipped; a non-positive or non-finite
/// `step` gives the end points only.
pub fn edge_samples(points: &[DVec3], edges: &[[u32; 2]], step: f64) -> Vec<DVec3> {
    let mut out = Vec::new();
    for &[a, b] in edges {
        let (Some(&pa), Some(&pb)) = (points.get(a as usize), points.get(b as usize)) else {
            continue;
        };
        let len = (pb - pa).length();
        let k = if step > 0.0 && step.is_finite() && len.is_finite() {
            (len / step).ceil().clamp(1.0, u32::MAX as f64) as u64
        } else {
            1
        };
        out.extend((0..=k).map(|j| lerp_exact(pa, pb, j as f64 / k as f64)));
    }
    out
}

/// The exact distance of every query point to the nearest edge of
/// (`to_points`, `to_edges`), in query order; infinite when there is no
/// edge. Edges with out-of-range indices are skipped.
pub fn point_edge_distances(
    queries: &[DVec3],
    to_points: &[DVec3],
    to_edges: &[[u32; 2]],
) -> Vec<f64> {
    let to: Vec<[u32; 2]> = to_edges
        .iter()
        .filter(|e| e.iter().all(|&v| (v as usize) < to_points.len()))
        .copied()
        .collect();
    if to.is_empty() {
        return vec![f64::INFINITY; queries.len()];
    }
    let seg = |s: u32| {
        let [a, b] = to[s as usize];
        [to_points[a as usize], to_points[b as usize]]
    };
    let mut tree = SegTree::default();
    let root = tree.build(to.len() as u32, seg);
    queries
        .par_iter()
        .map(|&q| tree.nearest(root, q, Candidate::NONE, seg).d2.sqrt())
        .collect()
}

/// The bench's `features` metric before dividing by L: distances from the
/// `input`'s [`sharp_edges`] at `angle_deg`, sampled every ≤ `step` (the bench
/// uses L/4), to the nearest edge of `output`. `None` when the input has no
/// sharp edge.
pub fn sharp_edge_distance(
    input: &TriMesh,
    output: &TriMesh,
    angle_deg: f64,
    step: f64,
) -> Option<PolylineDistance> {
    polyline_distance(
        &input.positions,
        &sharp_edges(input, angle_deg),
        step,
        &output.positions,
        &mesh_edges(output),
    )
}

/// The bench's `boundary` metric before dividing by L: distances from the
/// `input`'s boundary edges, sampled every ≤ `step`, to the nearest boundary
/// edge of `output`. `None` when the input is closed.
pub fn boundary_distance(input: &TriMesh, output: &TriMesh, step: f64) -> Option<PolylineDistance> {
    polyline_distance(
        &input.positions,
        &boundary_edges(input),
        step,
        &output.positions,
        &boundary_edges(output),
    )
}

#[cfg(test)]
mod tests {
    use super::*;
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
        let (t, q, _) = closest_on_segment(a, b, b + DVec3::new(5.0, 0.0, 5.0));
        assert_eq!((t, q), (1.0, b));
        let (t, q, _) = closest_on_segment(a, b, a - (b - a));
        assert_eq!((t, q), (0.0, a));
        let (t, q, d2) = closest_on_segment(a, a, DVec3::ONE);
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
    fn seg_tree_matches_brute_force_on_an_edge_soup() {
        let m = shapes::icosphere(2);
        let edges = mesh_edges(&m);
        let seg = |s: u32| {
            let [a, b] = edges[s as usize];
            [m.positions[a as usize], m.positions[b as usize]]
        };
        let mut tree = SegTree::default();
        let root = tree.build(edges.len() as u32, seg);
        let mut x = 12345u64;
        let mut rnd = || {
            x ^= x << 13;
            x ^= x >> 7;
            x ^= x << 17;
            (x >> 11) as f64 / (1u64 << 53) as f64 * 3.0 - 1.5
        };
        for _ in 0..500 {
            let p = DVec3::new(rnd(), rnd(), rnd());
            let got = tree.nearest(root, p, Candidate::NONE, seg);
            let mut want = Candidate::NONE;
            for s in 0..edges.len() as u32 {
                let [a, b] = seg(s);
                let (t, q, d2) = closest_on_segment(a, b, p);
                let c = Candidate { d2, item: s, t, q };
                if c.better_than(&want) {
                    want = c;
                }
            }
            assert_eq!((got.item, got.d2), (want.item, want.d2));
        }
    }
}
