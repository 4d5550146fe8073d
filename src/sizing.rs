//! The adaptive sizing field: a target edge length at every vertex of the
//! *input* mesh, derived from an absolute approximation tolerance ε and the
//! principal curvatures ([`crate::curvature`]), clamped to `[min, max]` and
//! gradation-limited, with barycentric evaluation on input faces.
//!
//! # Target length
//!
//! An equilateral triangle of edge L inscribed in a sphere of radius 1/κ
//! deviates from the sphere by at most ε (at its centroid) when
//! `L = sqrt(6ε/κ − 3ε²)` (Dunyach,
//! Vanderhaeghe, Barthe, Botsch, "Adaptive Remeshing for Real-Time Mesh
//! Deformation", Eurographics 2013 short papers; the same formula is used by
//! pmp-library and CGAL), with κ the largest absolute principal curvature.
//! When `6ε/κ − 3ε² ≤ 0` (κ ≥ 2/ε: a feature smaller than the tolerance) the
//! target is the minimum; κ = 0 gives the maximum.
//!
//! On feature and boundary polylines (see
//! [`crate::curvature::feature_curve_curvature`]) a second bound comes from
//! the chord error of the curve itself, `L = sqrt(8ε/κc − 4ε²)` (the sagitta
//! of a chord of a circle of curvature κc); the vertex takes the smaller of
//! the two. The crease itself never counts as curvature: the surface term
//! uses the one-sided estimates of the smooth sides (so a cube's flat faces
//! get the maximum size right up to and including their straight edges), and
//! the curve term only the bending of the polyline, with corners excluded.
//!
//! # Input creases
//!
//! The distance is measured to the input *polyhedron*, and on scans and
//! coarse models its facets are as long as the target edges or longer: the
//! input bends at its edges by angles of 20–45°, below the feature angle, so
//! these creases are not kept as feature lines, and the smoothed curvature
//! spreads each one over a facet. An output edge of length ℓ that crosses an
//! input edge whose face normals differ by θ cuts the crease by up to
//! `(ℓ/2)·tan(θ/2)`, linear in ℓ where the smooth bound is quadratic. A
//! third bound, `L = 2ε / tan(θ/2)`, therefore applies at both endpoints of
//! every interior input edge that is not a feature (the crease bound, on by
//! default: [`SizingOptions::crease_bound`]). Where several creases meet at
//! a vertex of angle defect δ the input is a cone of slope α,
//! `cos α = 1 − |δ|/2π`, and a triangle of edge L around the apex passes
//! `(L/√3)·tan α` below it, so such a vertex (one whose edges are all
//! interior non-feature edges) also gets `L = √3·ε / tan α`; saddles use
//! |δ|. On an input that samples a smooth surface finely (θ ≈ κ·ℓ_in,
//! δ ≈ K·area) both bounds grow like `ε/(κ ℓ_in)` and bind only where the
//! input edges ℓ_in are longer than about half of the smooth bound, i.e.
//! where the input is as coarse as the output, which is where the distance
//! peaks without them (figures in `docs/tuning.md`).
//!
//! # Gradation
//!
//! Sizes are then limited so that `h(v) ≤ h(u) + g·|uv|` on every input
//! edge: `h(v) = min_u (h₀(u) + g·d(u, v))` with `d` the shortest-path
//! distance along input edges, computed exactly by one multi-source Dijkstra
//! pass in O(n log n). A field that already satisfies the bound is returned
//! unchanged.
//!
//! # Use in split/collapse decisions
//!
//! Evaluate the field at a remeshed vertex through the input face and
//! barycentric coordinates of its closest point ([`SizingField::size_at`]),
//! and use for an edge `ab` the mean `h(ab) = (h(a) + h(b)) / 2`: split when
//! `|ab| > 4/3 · h(ab)`, collapse when `|ab| < 4/5 · h(ab)` and every edge
//! the collapse creates stays below `4/3` of its own mean target. Because of
//! the gradation limit, `|h(a) − h(b)| ≤ g·|ab|` on the input, so the mean
//! and the minimum of the endpoint sizes differ by at most `g·|ab|/2` and the
//! mean does not let long edges survive next to a small target; the minimum
//! is the stricter alternative if a hard guarantee is preferred over
//! triangle count.

use glam::DVec3;
use std::cmp::Reverse;
use std::collections::BinaryHeap;

use crate::curvature::{
    curvatures_on, curve_curvature_on, Curvature, CurvatureError, CurvatureOptions, FeatureEdgeFn,
    Topology,
};
use crate::trimesh::TriMesh;

/// Lower bound of the Botsch & Kobbelt length band, in units of the local
/// target: the remesher collapses shorter edges, and the statistics report
/// the share of edges inside the band.
pub const COLLAPSE_FACTOR: f64 = 4.0 / 5.0;
/// Upper bound of the length band: the remesher splits longer edges.
pub const SPLIT_FACTOR: f64 = 4.0 / 3.0;

/// Default tolerance as a fraction of the bounding-box diagonal: 0.1 %, below
/// what is visible at any viewing distance that shows the whole model, and
/// coarse enough that smooth regions get edges of a few percent of the
/// diagonal (`sqrt(6ε r)` for a part-sized radius r).
pub const DEFAULT_RELATIVE_TOLERANCE: f64 = 1e-3;

/// Default minimum edge length as a multiple of ε: 1. For every feature of
/// radius ≥ ε the curvature formula already asks for at least √3·ε, so the
/// minimum only binds at features smaller than the tolerance — in practice
/// unmarked sharp creases, which edges of length ε still follow within ε.
pub const DEFAULT_MIN_EDGE_FACTOR: f64 = 1.0;

/// Default maximum edge length as a fraction of the bounding-box diagonal:
/// 5 %. Flat regions need no edges at all for the tolerance, but a bound
/// keeps about twenty edges across the model so that normals, closest-point
/// projection and later deformation stay well sampled.
pub const DEFAULT_MAX_EDGE_FRACTION: f64 = 0.05;

/// Default gradation g in `h(v) ≤ h(u) + g·|uv|`: 0.3, so neighbouring
/// edges differ by at most about 30 %, well inside the 4/5–4/3 band, and the
/// remesher does not oscillate in transitions. Higher and lower values:
/// `docs/tuning.md`.
pub const DEFAULT_GRADATION: f64 = 0.3;

/// Parameters of the sizing field. All lengths are absolute, in mesh units.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct SizingOptions {
    /// Absolute approximation tolerance ε (> 0).
    pub tolerance: f64,
    /// Smallest target edge length (> 0).
    pub min_edge_length: f64,
    /// Largest target edge length (≥ `min_edge_length`, finite).
    pub max_edge_length: f64,
    /// Gradation g ≥ 0 in `h(v) ≤ h(u) + g·|uv|`; `f64::INFINITY` disables it.
    pub gradation: f64,
    /// Apply the crease bound `2ε / tan(θ/2)` of the input's own non-feature
    /// edges and the cone bound `√3·ε / tan α` of its vertices (see the
    /// module docs). On by default; off gives the field of the smooth
    /// surface the input samples.
    pub crease_bound: bool,
}

impl SizingOptions {
    /// Options for an absolute tolerance on a model with bounding-box
    /// diagonal `diagonal`, with the documented defaults:
    /// min = [`DEFAULT_MIN_EDGE_FACTOR`]·ε, max = [`DEFAULT_MAX_EDGE_FRACTION`]·diagonal
    /// (raised to min if smaller), gradation [`DEFAULT_GRADATION`], crease
    /// bound on.
    pub fn for_tolerance(tolerance: f64, diagonal: f64) -> Self {
        let min = DEFAULT_MIN_EDGE_FACTOR * tolerance;
        Self {
            tolerance,
            min_edge_length: min,
            max_edge_length: (DEFAULT_MAX_EDGE_FRACTION * diagonal).max(min),
            gradation: DEFAULT_GRADATION,
            crease_bound: true,
        }
    }

    /// Options for a tolerance given as a fraction of the mesh's bounding-box
    /// diagonal (e.g. [`DEFAULT_RELATIVE_TOLERANCE`]), with the defaults of
    /// [`SizingOptions::for_tolerance`].
    pub fn relative(mesh: &TriMesh, relative_tolerance: f64) -> Self {
        let diagonal = mesh.bbox_diagonal();
        Self::for_tolerance(relative_tolerance * diagonal, diagonal)
    }

    /// Checks the documented ranges.
    pub fn validate(&self) -> Result<(), SizingError> {
        let bad = |what: &str| Err(SizingError::InvalidOptions(what.to_string()));
        if !(self.tolerance > 0.0 && self.tolerance.is_finite()) {
            return bad("tolerance must be positive and finite");
        }
        if !(self.min_edge_length > 0.0 && self.min_edge_length.is_finite()) {
            return bad("min_edge_length must be positive and finite");
        }
        if !(self.max_edge_length >= self.min_edge_length && self.max_edge_length.is_finite()) {
            return bad("max_edge_length must be finite and at least min_edge_length");
        }
        let graded = self.gradation >= 0.0;
        if !graded {
            return bad("gradation must be non-negative");
        }
        Ok(())
    }
}

/// Why a sizing field could not be built.
#[derive(Debug, thiserror::Error, Clone, PartialEq)]
pub enum SizingError {
    /// The options are out of their documented ranges.
    #[error("invalid sizing options: {0}")]
    InvalidOptions(String),
    /// The curvature slice does not have one entry per vertex.
    #[error("expected {expected} curvature values (one per vertex), got {got}")]
    CurvatureLength {
        /// Number of vertices.
        expected: usize,
        /// Length of the slice given.
        got: usize,
    },
    /// The mesh itself is unusable.
    #[error(transparent)]
    Mesh(#[from] CurvatureError),
}

/// Unclamped target edge length `sqrt(6ε/κ − 3ε²)` for curvature `kappa`
/// (absolute value used) and tolerance `tolerance`: `+∞` for κ = 0, `0` when
/// κ ≥ 2/ε.
pub fn target_length(kappa: f64, tolerance: f64) -> f64 {
    let k = kappa.abs();
    if k == 0.0 {
        return f64::INFINITY;
    }
    (6.0 * tolerance / k - 3.0 * tolerance * tolerance)
        .max(0.0)
        .sqrt()
}

/// Unclamped chord length `sqrt(8ε/κ − 4ε²)` whose sagitta on a circle of
/// curvature `kappa` is `tolerance`: the bound along feature polylines.
pub fn curve_target_length(kappa: f64, tolerance: f64) -> f64 {
    let k = kappa.abs();
    if k == 0.0 {
        return f64::INFINITY;
    }
    (8.0 * tolerance / k - 4.0 * tolerance * tolerance)
        .max(0.0)
        .sqrt()
}

/// Unclamped edge length `2ε / tan(θ/2)` whose crossing of an input crease
/// whose face normals differ by `angle` (radians, in [0, π]) deviates from
/// it by at most `tolerance` (the chord's midpoint is `(ℓ/2)·tan(θ/2)` from
/// the crease): `+∞` for a flat edge, `0` for a folded one.
pub fn crease_target_length(angle: f64, tolerance: f64) -> f64 {
    let t = (0.5 * angle.abs()).tan();
    if t == 0.0 {
        return f64::INFINITY;
    }
    if !(t > 0.0 && t.is_finite()) || angle.abs() >= std::f64::consts::PI {
        return 0.0;
    }
    2.0 * tolerance / t
}

/// Unclamped edge length `√3·ε / tan α` at a cone vertex of angle defect
/// `defect` (2π minus its face angles, radians; the sign is ignored): a
/// triangle of edge ℓ whose circumcentre sits on the apex of a circular cone
/// of slope α, with `cos α = 1 − |δ|/2π`, passes `(ℓ/√3)·tan α` below it.
/// `+∞` for a flat vertex.
pub fn cone_target_length(defect: f64, tolerance: f64) -> f64 {
    let c = 1.0 - defect.abs() / std::f64::consts::TAU;
    if c >= 1.0 {
        return f64::INFINITY;
    }
    if c.is_nan() || c <= 0.0 {
        return 0.0;
    }
    let tan = (1.0 - c * c).sqrt() / c;
    3f64.sqrt() * tolerance / tan
}

/// Per input vertex, the smallest [`crease_target_length`] over the interior,
/// consistently oriented, non-feature edges at it and, at a vertex all of
/// whose edges are such edges, its [`cone_target_length`] (`+∞` where the
/// input is flat).
fn crease_bounds(mesh: &TriMesh, topo: &Topology, tolerance: f64) -> Vec<f64> {
    use rayon::prelude::*;
    let pos = &mesh.positions;
    let tri = &mesh.triangles;
    let normals: Vec<DVec3> = tri
        .par_iter()
        .map(|t| {
            let [a, b, c] = t.map(|i| pos[i as usize]);
            (b - a).cross(c - a).normalize_or_zero()
        })
        .collect();
    let per_edge: Vec<f64> = topo
        .smooth_edges
        .par_iter()
        .map(|&[_, _, f0, f1]| {
            let (n0, n1) = (normals[f0 as usize], normals[f1 as usize]);
            if n0 == DVec3::ZERO || n1 == DVec3::ZERO {
                f64::INFINITY
            } else {
                crease_target_length(n0.angle_between(n1), tolerance)
            }
        })
        .collect();
    let mut bound = vec![f64::INFINITY; pos.len()];
    // A closed fan of k faces has k edges: the vertex is a cone candidate
    // when all of them are smooth edges (none on a boundary, feature,
    // non-manifold or inconsistently oriented edge).
    let mut smooth_count = vec![0u32; pos.len()];
    for (e, &h) in topo.smooth_edges.iter().zip(&per_edge) {
        for v in [e[0], e[1]] {
            let b = &mut bound[v as usize];
            *b = b.min(h);
            smooth_count[v as usize] += 1;
        }
    }
    bound.par_iter_mut().enumerate().for_each(|(v, b)| {
        let corners = topo.vertex_corners(v);
        // One sector: a pinch vertex joining two closed fans is no cone.
        if corners.is_empty()
            || smooth_count[v] as usize != corners.len()
            || topo.sectors_at(v) != 1
        {
            return;
        }
        let p = pos[v];
        let sum: f64 = corners
            .iter()
            .map(|&c| {
                let t = &tri[(c / 3) as usize];
                let k = (c % 3) as usize;
                let a = pos[t[(k + 1) % 3] as usize] - p;
                let b = pos[t[(k + 2) % 3] as usize] - p;
                a.angle_between(b)
            })
            .sum();
        *b = b.min(cone_target_length(std::f64::consts::TAU - sum, tolerance));
    });
    bound
}

/// Target edge lengths on the vertices of an input mesh; see the module docs.
#[derive(Clone, Debug)]
pub struct SizingField {
    sizes: Vec<f64>,
    triangles: Vec<[u32; 3]>,
    min_size: f64,
    options: SizingOptions,
}

impl SizingField {
    /// Builds the field on `mesh` from per-vertex `curvature` (from
    /// [`crate::curvature::principal_curvatures`] with the same feature
    /// predicate). `is_feature_edge` marks the feature edges whose polylines
    /// add the curve bound; boundary edges always do.
    ///
    /// Vertices used by no face get the maximum size (before gradation).
    pub fn build(
        mesh: &TriMesh,
        curvature: &[Curvature],
        opts: &SizingOptions,
        is_feature_edge: Option<FeatureEdgeFn>,
    ) -> Result<Self, SizingError> {
        opts.validate()?;
        if curvature.len() != mesh.positions.len() {
            return Err(SizingError::CurvatureLength {
                expected: mesh.positions.len(),
                got: curvature.len(),
            });
        }
        let topo = Topology::new(mesh, is_feature_edge)?;
        Ok(Self::from_parts(mesh, &topo, curvature, opts))
    }

    /// Estimates curvature ([`crate::curvature`]) and builds the field in one
    /// go, sharing the connectivity between the two.
    pub fn from_mesh(
        mesh: &TriMesh,
        opts: &SizingOptions,
        curvature_opts: &CurvatureOptions,
        is_feature_edge: Option<FeatureEdgeFn>,
    ) -> Result<Self, SizingError> {
        opts.validate()?;
        let topo = Topology::new(mesh, is_feature_edge)?;
        let curvature = curvatures_on(mesh, &topo, curvature_opts);
        Ok(Self::from_parts(mesh, &topo, &curvature, opts))
    }

    fn from_parts(
        mesh: &TriMesh,
        topo: &Topology,
        curvature: &[Curvature],
        opts: &SizingOptions,
    ) -> Self {
        use rayon::prelude::*;
        let eps = opts.tolerance;
        let (lo, hi) = (opts.min_edge_length, opts.max_edge_length);
        let curve = curve_curvature_on(mesh, topo);
        let crease = if opts.crease_bound {
            crease_bounds(mesh, topo, eps)
        } else {
            vec![f64::INFINITY; mesh.positions.len()]
        };
        let mut sizes: Vec<f64> = curvature
            .par_iter()
            .zip(&curve)
            .zip(&crease)
            .map(|((c, &kc), &kx)| {
                let t = target_length(c.max_abs(), eps)
                    .min(curve_target_length(kc, eps))
                    .min(kx);
                // NaN (from a non-finite curvature) falls to the minimum.
                if t >= lo {
                    t.min(hi)
                } else {
                    lo
                }
            })
            .collect();
        limit_gradation(mesh, topo, &mut sizes, opts.gradation);
        let min_size = sizes.iter().copied().fold(hi, f64::min);
        Self {
            sizes,
            triangles: mesh.triangles.clone(),
            min_size,
            options: *opts,
        }
    }

    /// Target edge length at the point of input face `face` with barycentric
    /// coordinates `barycentric` (linear interpolation of the corner sizes).
    /// Negative coordinates are clamped to 0 and the rest renormalised; a
    /// face index out of range yields the field's smallest size, the
    /// conservative choice.
    pub fn size_at(&self, face: u32, barycentric: DVec3) -> f64 {
        let Some(t) = self.triangles.get(face as usize) else {
            return self.min_size;
        };
        let w = barycentric.max(DVec3::ZERO);
        let sum = w.x + w.y + w.z;
        let w = if sum > 0.0 && sum.is_finite() {
            w / sum
        } else {
            DVec3::splat(1.0 / 3.0)
        };
        w.x * self.sizes[t[0] as usize]
            + w.y * self.sizes[t[1] as usize]
            + w.z * self.sizes[t[2] as usize]
    }

    /// Target edge length at input vertex `v`, or `None` out of range.
    pub fn size_at_vertex(&self, v: u32) -> Option<f64> {
        self.sizes.get(v as usize).copied()
    }

    /// Target edge length of every input vertex.
    pub fn vertex_sizes(&self) -> &[f64] {
        &self.sizes
    }

    /// The smallest size in the field (the maximum option for an empty mesh).
    pub fn min_size(&self) -> f64 {
        self.min_size
    }

    /// The options the field was built with.
    pub fn options(&self) -> &SizingOptions {
        &self.options
    }
}

/// Enforces `h(v) ≤ h(u) + g·|uv|` on every edge: `h(v) = min_u (h(u) +
/// g·d(u, v))` by multi-source Dijkstra. Only vertices that violate the
/// bound towards a neighbour seed the queue — a vertex that improves none of
/// its neighbours cannot improve anything farther away either — so a field
/// that already satisfies the bound costs one parallel check and is left
/// untouched. Each vertex is settled once at its final value, which makes
/// the result exact for the edge-graph metric.
fn limit_gradation(mesh: &TriMesh, topo: &Topology, sizes: &mut [f64], g: f64) {
    use rayon::prelude::*;
    if !g.is_finite() {
        return;
    }
    let pos = &mesh.positions;
    let tri = &mesh.triangles;
    let neighbours = |v: usize| {
        topo.vertex_corners(v).iter().flat_map(|&c| {
            let t = &tri[(c / 3) as usize];
            let k = (c % 3) as usize;
            [t[(k + 1) % 3], t[(k + 2) % 3]]
        })
    };
    // Positive finite f64 order like their bit patterns, which makes a cheap
    // total-order heap key.
    let seeds: Vec<Reverse<(u64, u32)>> = {
        let sizes = &*sizes;
        (0..sizes.len())
            .into_par_iter()
            .filter(|&v| {
                let (hv, pv) = (sizes[v], pos[v]);
                neighbours(v).any(|o| hv + g * (pos[o as usize] - pv).length() < sizes[o as usize])
            })
            .map(|v| Reverse((sizes[v].to_bits(), v as u32)))
            .collect()
    };
    let mut heap = BinaryHeap::from(seeds);
    while let Some(Reverse((bits, v))) = heap.pop() {
        let hv = sizes[v as usize];
        if bits != hv.to_bits() {
            continue;
        }
        let pv = pos[v as usize];
        for o in neighbours(v as usize) {
            let cand = hv + g * (pos[o as usize] - pv).length();
            if cand < sizes[o as usize] {
                sizes[o as usize] = cand;
                heap.push(Reverse((cand.to_bits(), o)));
            }
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::shapes;

    /// Brute force: relax every edge until nothing changes (Bellman–Ford).
    fn reference(mesh: &TriMesh, h0: &[f64], g: f64) -> Vec<f64> {
        let mut h = h0.to_vec();
        loop {
            let mut changed = false;
            for t in &mesh.triangles {
                for k in 0..3 {
                    let (a, b) = (t[k] as usize, t[(k + 1) % 3] as usize);
                    let l = (mesh.positions[a] - mesh.positions[b]).length();
                    for (x, y) in [(a, b), (b, a)] {
                        if h[x] + g * l < h[y] {
                            h[y] = h[x] + g * l;
                            changed = true;
                        }
                    }
                }
            }
            if !changed {
                return h;
            }
        }
    }

    #[test]
    fn gradation_matches_brute_force_on_random_fields() {
        let mut mesh = shapes::grid(1.0, 20);
        let mut seed = 0x2545f4914f6cdd1du64;
        let mut rnd = || {
            seed ^= seed << 13;
            seed ^= seed >> 7;
            seed ^= seed << 17;
            (seed >> 11) as f64 / (1u64 << 53) as f64
        };
        // Irregular edge lengths.
        for p in &mut mesh.positions {
            p.z = 0.05 * rnd();
        }
        let topo = Topology::new(&mesh, None).unwrap();
        for g in [0.0, 0.1, 0.3, 1.0] {
            let h0: Vec<f64> = (0..mesh.positions.len())
                .map(|_| 0.01 + rnd() * rnd() * 0.5)
                .collect();
            let mut h = h0.clone();
            limit_gradation(&mesh, &topo, &mut h, g);
            let want = reference(&mesh, &h0, g);
            for (a, b) in h.iter().zip(&want) {
                assert!((a - b).abs() <= 1e-12 * b, "g={g}: {a} vs {b}");
            }
        }
    }
}
