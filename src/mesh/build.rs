//! Building a half-edge [`Mesh`] from indexed triangles, repairing what real
//! files contain instead of failing:
//!
//! 1. reject non-finite coordinates and out-of-range indices ([`BuildError`]);
//! 2. weld vertices with equal positions (glTF and OBJ split vertices along
//!    UV and normal seams; without welding the seams become false boundaries);
//! 3. drop degenerate faces (repeated corner or zero area) and duplicate faces
//!    (same three vertices), then unreferenced vertices;
//! 4. cut edges shared by three or more faces into boundary edges;
//! 5. orient each connected component consistently, flipping the minority,
//!    and cut the edges that make a component non-orientable;
//! 6. split vertices where separate fans of faces meet (non-manifold vertices);
//! 7. glue back the two sides of a cut edge that still meet in one fan at
//!    both ends, which would otherwise be two edges between the same vertices.
//!
//! Everything repaired is counted in a [`RepairReport`]. Sorting replaces
//! hashing throughout, so building is O(n log n) with small constants.

use glam::DVec3;
use serde::{Deserialize, Serialize};

use super::{HalfedgeId, Mesh, VertexId};
use crate::mesh::handles::Handle;
use crate::topology::{Csr, EdgeTable};
use crate::trimesh::{first_occurrences, weld_positions, Label, TriMesh};

/// What the builder repaired while turning indexed triangles into a valid
/// half-edge mesh. Every field is a count; all zero means the input was clean.
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq, Serialize, Deserialize)]
pub struct RepairReport {
    /// Vertices merged into another vertex at the same position.
    pub welded_vertices: u64,
    /// Vertices referenced by no face, removed.
    pub unreferenced_vertices: u64,
    /// Faces dropped because two corners were the same vertex or the area was zero.
    pub degenerate_faces: u64,
    /// Faces dropped because another face had the same three vertices.
    pub duplicate_faces: u64,
    /// Edges shared by three or more faces, cut into boundary edges.
    pub non_manifold_edges: u64,
    /// Vertices where separate fans met, split into one vertex per fan.
    pub non_manifold_vertices: u64,
    /// Faces whose orientation was reversed to agree with their component.
    pub flipped_faces: u64,
    /// Connected components that cannot be oriented consistently (Möbius-like);
    /// the offending edges are cut into boundary edges.
    pub non_orientable_components: u64,
    /// Non-triangle primitives (points, lines) in the input that were ignored.
    pub ignored_primitives: u64,
}

impl RepairReport {
    /// Whether anything was repaired.
    pub fn is_clean(&self) -> bool {
        *self == Self::default()
    }
}

/// Why indexed triangles cannot become a mesh.
#[derive(Debug, Clone, PartialEq, thiserror::Error)]
pub enum BuildError {
    /// A coordinate is NaN or infinite.
    #[error("vertex {vertex} has a non-finite coordinate ({x}, {y}, {z})")]
    NonFinite {
        /// Index of the offending vertex.
        vertex: usize,
        /// Its coordinates.
        x: f64,
        /// Its coordinates.
        y: f64,
        /// Its coordinates.
        z: f64,
    },
    /// A coordinate is so large that squared lengths and areas overflow
    /// `f64` (more than [`MAX_COORDINATE`] in magnitude).
    #[error("a coordinate of vertex {vertex} is {value:e}, beyond ±{MAX_COORDINATE:e}, where areas overflow: scale the mesh down")]
    CoordinateTooLarge {
        /// Index of the offending vertex.
        vertex: usize,
        /// The coordinate.
        value: f64,
    },
    /// The mesh is so small that its areas underflow `f64` (a bounding-box
    /// diagonal below [`MIN_EXTENT`], but not a single point).
    #[error("the mesh's bounding-box diagonal is {diagonal:e}, below {MIN_EXTENT:e}, where areas underflow: scale the mesh up")]
    TooSmall {
        /// The bounding-box diagonal.
        diagonal: f64,
    },
    /// A triangle refers to a vertex that does not exist.
    #[error(
        "triangle {face} refers to vertex {index}, but there are only {vertex_count} vertices"
    )]
    IndexOutOfRange {
        /// Index of the offending triangle.
        face: usize,
        /// The bad vertex index.
        index: u32,
        /// Number of vertices.
        vertex_count: usize,
    },
    /// A face label refers to no label, or the label list has the wrong length.
    #[error("face labels are inconsistent: {0}")]
    BadLabels(String),
    /// Nothing is left after dropping degenerate faces (or there was nothing).
    #[error("the mesh has no non-degenerate triangle")]
    Empty,
    /// More elements than `u32` handles can address.
    #[error("the mesh is too large: {0} elements exceed the u32 handle range")]
    TooLarge(usize),
}

const NONE: u32 = u32::MAX;

/// Largest accepted coordinate magnitude. A triangle's area comes from a
/// cross product of coordinate differences, squared once more for its
/// length: coordinates near 1e77 overflow that to infinity. 1e60 leaves a
/// wide margin.
pub const MAX_COORDINATE: f64 = 1e60;
/// Smallest accepted bounding-box diagonal (for a mesh that is not a
/// single point): below about 1e-77 the same fourth powers underflow to
/// zero and every triangle looks degenerate.
pub const MIN_EXTENT: f64 = 1e-60;

impl Mesh {
    /// Builds a manifold, consistently oriented mesh from indexed triangles,
    /// repairing what can be repaired (see the module docs) and reporting it.
    pub fn from_trimesh(input: &TriMesh) -> Result<(Mesh, RepairReport), BuildError> {
        build(input)
    }

    /// Builds from bare positions and triangles (no labels).
    pub fn from_triangles(
        positions: &[DVec3],
        triangles: &[[u32; 3]],
    ) -> Result<(Mesh, RepairReport), BuildError> {
        build(&TriMesh::new(positions.to_vec(), triangles.to_vec()))
    }
}

/// Refuses coordinates whose squared lengths or areas would overflow, and a
/// mesh too small for its areas to be computable (all finite).
fn check_scale(positions: &[DVec3]) -> Result<(), BuildError> {
    if let Some((vertex, p)) = positions
        .iter()
        .enumerate()
        .find(|(_, p)| p.abs().max_element() > MAX_COORDINATE)
    {
        let value = [p.x, p.y, p.z]
            .into_iter()
            .fold(0.0f64, |m, c| if c.abs() > m.abs() { c } else { m });
        return Err(BuildError::CoordinateTooLarge { vertex, value });
    }
    let Some(&first) = positions.first() else {
        return Ok(());
    };
    let (lo, hi) = positions
        .iter()
        .fold((first, first), |(lo, hi), &p| (lo.min(p), hi.max(p)));
    let diagonal = (hi - lo).length();
    if diagonal > 0.0 && diagonal < MIN_EXTENT {
        return Err(BuildError::TooSmall { diagonal });
    }
    Ok(())
}

fn build(input: &TriMesh) -> Result<(Mesh, RepairReport), BuildError> {
    let n = input.positions.len();
    if n >= NONE as usize || input.triangles.len() * 3 >= (NONE as usize) / 2 {
        return Err(BuildError::TooLarge(n.max(input.triangles.len())));
    }
    if let Some((i, p)) = input
        .positions
        .iter()
        .enumerate()
        .find(|(_, p)| !p.is_finite())
    {
        return Err(BuildError::NonFinite {
            vertex: i,
            x: p.x,
            y: p.y,
            z: p.z,
        });
    }
    check_scale(&input.positions)?;
    for (f, t) in input.triangles.iter().enumerate() {
        for &i in t {
            if i as usize >= n {
                return Err(BuildError::IndexOutOfRange {
                    face: f,
                    index: i,
                    vertex_count: n,
                });
            }
        }
    }
    input.check().map_err(BuildError::BadLabels)?;
    let mut report = RepairReport::default();

    // 2. Weld equal positions: sort vertex ids by their coordinate bits.
    let (weld, welded_pos) = weld_positions(&input.positions);
    report.welded_vertices = (n - welded_pos.len()) as u64;

    // 3. Degenerate and duplicate faces.
    let mut tris: Vec<[u32; 3]> = Vec::with_capacity(input.triangles.len());
    let mut labels: Vec<u32> = Vec::with_capacity(input.triangles.len());
    for (f, t) in input.triangles.iter().enumerate() {
        let t = [
            weld[t[0] as usize],
            weld[t[1] as usize],
            weld[t[2] as usize],
        ];
        let degenerate = t[0] == t[1] || t[1] == t[2] || t[2] == t[0] || {
            let [a, b, c] = [
                welded_pos[t[0] as usize],
                welded_pos[t[1] as usize],
                welded_pos[t[2] as usize],
            ];
            (b - a).cross(c - a) == DVec3::ZERO
        };
        if degenerate {
            report.degenerate_faces += 1;
        } else {
            tris.push(t);
            labels.push(input.face_label(f));
        }
    }
    drop(weld);
    {
        let (keep, repeats) = first_occurrences(&tris);
        report.duplicate_faces = repeats as u64;
        if report.duplicate_faces > 0 {
            let mut k = 0;
            tris.retain(|_| {
                k += 1;
                keep[k - 1]
            });
            let mut k = 0;
            labels.retain(|_| {
                k += 1;
                keep[k - 1]
            });
        }
    }
    if tris.is_empty() {
        return Err(BuildError::Empty);
    }

    // Unreferenced vertices.
    let mut vmap = vec![NONE; welded_pos.len()];
    let mut positions = Vec::with_capacity(welded_pos.len());
    for t in &mut tris {
        for i in t.iter_mut() {
            let old = *i as usize;
            if vmap[old] == NONE {
                vmap[old] = positions.len() as u32;
                positions.push(welded_pos[old]);
            }
            *i = vmap[old];
        }
    }
    report.unreferenced_vertices = (welded_pos.len() - positions.len()) as u64;
    drop(welded_pos);
    drop(vmap);

    // 4. Pair corners into edges. Corner c = 3f + k is the directed edge
    // t[k] -> t[k+1]; the edge table groups the corners of each edge.
    let nf = tris.len();
    let corner_from = |c: usize, tris: &[[u32; 3]]| tris[c / 3][c % 3];
    let mut partner = vec![NONE; 3 * nf];
    EdgeTable::new(&tris, positions.len()).for_each(|_, _, run| match *run {
        [_] => {}
        [(_, c1), (_, c2)] => {
            partner[c1 as usize] = c2;
            partner[c2 as usize] = c1;
        }
        _ => report.non_manifold_edges += 1,
    });

    // 5. Orientation by breadth-first search over paired corners: a pair
    // running the same direction means the two faces disagree.
    let mut flip = vec![0u8; nf]; // 0 unknown, 1 keep, 2 flip
    let mut queue: Vec<u32> = Vec::new();
    let mut component: Vec<u32> = Vec::new();
    for seed in 0..nf {
        if flip[seed] != 0 {
            continue;
        }
        flip[seed] = 1;
        queue.clear();
        component.clear();
        queue.push(seed as u32);
        let mut conflict = false;
        while let Some(f) = queue.pop() {
            component.push(f);
            for k in 0..3 {
                let c = 3 * f as usize + k;
                let p = partner[c];
                if p == NONE {
                    continue;
                }
                let g = (p / 3) as usize;
                let same_dir = corner_from(c, &tris) == corner_from(p as usize, &tris);
                let want = if (flip[f as usize] == 2) ^ same_dir {
                    2
                } else {
                    1
                };
                if flip[g] == 0 {
                    flip[g] = want;
                    queue.push(g as u32);
                } else if flip[g] != want {
                    // Non-orientable here: cut the edge.
                    partner[c] = NONE;
                    partner[p as usize] = NONE;
                    conflict = true;
                }
            }
        }
        if conflict {
            report.non_orientable_components += 1;
        }
        let flipped = component.iter().filter(|&&f| flip[f as usize] == 2).count();
        if 2 * flipped > component.len() {
            for &f in &component {
                flip[f as usize] = if flip[f as usize] == 2 { 1 } else { 2 };
            }
        }
    }
    // Apply flips: [a, b, c] -> [a, c, b]; corner k becomes corner 2 - k.
    let mut new_partner = partner.clone();
    for (f, t) in tris.iter_mut().enumerate() {
        if flip[f] == 2 {
            report.flipped_faces += 1;
            t.swap(1, 2);
        }
    }
    let corner_new = |c: u32| -> u32 {
        let f = (c / 3) as usize;
        if flip[f] == 2 {
            3 * f as u32 + (2 - c % 3)
        } else {
            c
        }
    };
    for (c, &p) in partner.iter().enumerate() {
        new_partner[corner_new(c as u32) as usize] = if p == NONE { NONE } else { corner_new(p) };
    }
    let partner = new_partner;
    drop(flip);

    let nv = positions.len();
    let mut assembled = assemble(input, positions, &tris, &labels, &partner);
    // 7. A cut edge whose two remaining sides still meet in one fan at both
    // ends (a face pair that was manifold but for a fin hanging on their
    // edge) leaves two boundary edges joining the same two vertices. Glue
    // each such pair back into one interior edge and assemble again.
    let glue = duplicate_boundary_corners(&assembled);
    if !glue.is_empty() {
        let mut partner = partner;
        for &[c1, c2] in &glue {
            partner[c1 as usize] = c2;
            partner[c2 as usize] = c1;
        }
        let positions = assembled.mesh.pos[..nv].to_vec();
        drop(assembled);
        assembled = assemble(input, positions, &tris, &labels, &partner);
    }
    report.non_manifold_vertices = assembled.split_vertices;
    let mesh = assembled.mesh;
    debug_assert!(mesh.validate().is_ok(), "{:?}", mesh.validate());
    Ok((mesh, report))
}
/// A half-edge mesh assembled from oriented triangles and their corner
/// pairing, with the half-edge of every corner.
struct Assembled {
    mesh: Mesh,
    he_of_corner: Vec<HalfedgeId>,
    split_vertices: u64,
}

/// Builds the half-edges of `tris` (corner `c` pairs with `partner[c]`, or
/// is a boundary edge), splits non-manifold vertices (step 6) and links the
/// boundary loops.
fn assemble(
    input: &TriMesh,
    positions: Vec<DVec3>,
    tris: &[[u32; 3]],
    labels: &[u32],
    partner: &[u32],
) -> Assembled {
    let corner_from = |c: usize| tris[c / 3][c % 3];
    let corner_to = |c: usize| tris[c / 3][(c % 3 + 1) % 3];
    // Build half-edges. Each paired corner pair is one edge; each unpaired
    // corner is an edge whose twin is a boundary half-edge.
    let nv = positions.len();
    let nf = tris.len();
    let mut mesh = Mesh {
        pos: positions,
        v_out: vec![HalfedgeId::INVALID; nv],
        v_deleted: vec![false; nv],
        live_vertices: nv,
        labels: if input.labels.is_empty() {
            vec![Label::default()]
        } else {
            input.labels.clone()
        },
        ..Default::default()
    };
    // Euler: E ≈ 1.5 F for closed meshes; boundary edges add a little.
    mesh.reserve(0, 3 * nf / 2 + 16, nf);
    let mut he_of_corner = vec![HalfedgeId::INVALID; 3 * nf];
    for c in 0..3 * nf {
        if he_of_corner[c].is_valid() {
            continue;
        }
        let (a, b) = (VertexId(corner_from(c)), VertexId(corner_to(c)));
        let h = mesh.new_edge(a, b);
        he_of_corner[c] = h;
        let p = partner[c];
        if p != NONE {
            debug_assert_eq!(corner_from(p as usize), b.0);
            he_of_corner[p as usize] = h.twin();
        }
    }
    for (f, &label) in labels.iter().enumerate().take(nf) {
        let hs = [
            he_of_corner[3 * f],
            he_of_corner[3 * f + 1],
            he_of_corner[3 * f + 2],
        ];
        let face = mesh.new_face(hs[0], label);
        for k in 0..3 {
            mesh.he_face[hs[k].idx()] = face;
            mesh.link(hs[k], hs[(k + 1) % 3]);
        }
    }

    // 6. Split non-manifold vertices: one vertex per fan of faces. Outgoing
    // face half-edges per vertex, as CSR.
    let nh = mesh.he_to.len();
    let out = Csr::from_pairs(nv, || {
        (0..nh as u32)
            .map(HalfedgeId)
            .filter(|&h| !mesh.is_boundary_halfedge(h))
            .map(|h| (mesh.from_vertex(h).idx() as u32, h))
    });
    let mut visited = vec![false; nh];
    let mut split_vertices = 0;
    let mut fan: Vec<HalfedgeId> = Vec::new();
    for v in 0..nv {
        let mut fans = 0;
        for &h0 in out.row(v as u32) {
            if visited[h0.idx()] {
                continue;
            }
            fan.clear();
            // Counter-clockwise through faces, then clockwise from h0.
            let mut h = h0;
            loop {
                visited[h.idx()] = true;
                fan.push(h);
                let nxt = mesh.prev(h).twin();
                if mesh.is_boundary_halfedge(nxt) || visited[nxt.idx()] {
                    break;
                }
                h = nxt;
            }
            let mut h = h0;
            loop {
                let t = h.twin();
                if mesh.is_boundary_halfedge(t) {
                    break;
                }
                let nxt = mesh.next(t);
                if visited[nxt.idx()] {
                    break;
                }
                visited[nxt.idx()] = true;
                fan.push(nxt);
                h = nxt;
            }
            fans += 1;
            let target = if fans == 1 {
                VertexId(v as u32)
            } else {
                let p = mesh.pos[v];
                mesh.new_vertex(p)
            };
            for &h in &fan {
                mesh.he_to[h.twin().idx()] = target;
                let incoming = mesh.prev(h);
                mesh.he_to[incoming.idx()] = target;
            }
            mesh.v_out[target.idx()] = h0;
        }
        if fans > 1 {
            split_vertices += 1;
        }
    }
    drop(out);
    drop(visited);

    // Link boundary half-edges into loops and make boundary half-edges the
    // outgoing half-edge of their vertex.
    let nv = mesh.pos.len();
    let mut boundary_out = vec![HalfedgeId::INVALID; nv];
    for h in 0..nh as u32 {
        let h = HalfedgeId(h);
        if mesh.is_boundary_halfedge(h) {
            let v = mesh.from_vertex(h).idx();
            debug_assert!(!boundary_out[v].is_valid(), "two boundary fans at a vertex");
            boundary_out[v] = h;
        }
    }
    for h in 0..nh as u32 {
        let h = HalfedgeId(h);
        if mesh.is_boundary_halfedge(h) {
            let nxt = boundary_out[mesh.to_vertex(h).idx()];
            mesh.link(h, nxt);
        }
    }
    for (v, &b) in boundary_out.iter().enumerate() {
        if b.is_valid() {
            mesh.v_out[v] = b;
        }
    }
    debug_assert!(mesh.validate().is_ok(), "{:?}", mesh.validate());
    Assembled {
        mesh,
        he_of_corner,
        split_vertices,
    }
}

/// The corner pairs to glue: the face sides of boundary edges that join the
/// same two vertices as another boundary edge. Each such pair has one face
/// running a→b and the other b→a (they are the two boundary edges of one fan
/// at each end), so gluing them keeps the orientation.
fn duplicate_boundary_corners(a: &Assembled) -> Vec<[u32; 2]> {
    let mesh = &a.mesh;
    let mut ends: Vec<([u32; 2], HalfedgeId)> = (0..mesh.he_to.len() as u32)
        .map(HalfedgeId)
        .filter(|&h| mesh.is_boundary_halfedge(h.twin()) && !mesh.is_boundary_halfedge(h))
        .map(|h| {
            let (u, v) = (mesh.from_vertex(h).0, mesh.to_vertex(h).0);
            ([u.min(v), u.max(v)], h)
        })
        .collect();
    if ends.len() < 2 {
        return Vec::new();
    }
    ends.sort_unstable_by_key(|&(k, h)| (k, h.0));
    let mut pairs: Vec<(HalfedgeId, HalfedgeId)> = Vec::new();
    for run in ends.chunk_by(|x, y| x.0 == y.0) {
        if let [(_, h1), (_, h2)] = *run {
            if mesh.from_vertex(h1) == mesh.to_vertex(h2) {
                pairs.push((h1, h2));
            }
        }
    }
    if pairs.is_empty() {
        return Vec::new();
    }
    let mut corner_of = std::collections::HashMap::with_capacity(2 * pairs.len());
    for &(h1, h2) in &pairs {
        corner_of.insert(h1, NONE);
        corner_of.insert(h2, NONE);
    }
    for (c, h) in a.he_of_corner.iter().enumerate() {
        if let Some(slot) = corner_of.get_mut(h) {
            *slot = c as u32;
        }
    }
    pairs
        .iter()
        .map(|(h1, h2)| [corner_of[h1], corner_of[h2]])
        .collect()
}
