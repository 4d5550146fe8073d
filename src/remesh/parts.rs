//! Small parts: the connected parts of the input whose bounding-box
//! diagonal is under [`RemeshOptions::small_part_size`] target lengths are
//! kept as they are (their vertices fixed like corners and their edges
//! marked [`EDGE_FROZEN`], so that no pass splits, collapses, flips or
//! moves them), remeshed like the rest, or removed before the first pass,
//! as [`RemeshOptions::small_parts`] says. A part that small cannot keep
//! its shape with edges in the band; keeping it is the default, so that no
//! part disappears unless the caller asks. The largest part is never small.

use glam::DVec3;
use serde::{Deserialize, Serialize};

use super::options::{RemeshOptions, SmallParts};
use super::state::CORNER;
use crate::mesh::{Handle, Mesh, VertexId, EDGE_FROZEN};
use crate::topology::UnionFind;

/// How many parts the input had, and what became of them.
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq, Serialize, Deserialize)]
pub struct PartsReport {
    /// Connected parts of the repaired input.
    pub total: u64,
    /// Parts remeshed.
    pub remeshed: u64,
    /// Small parts kept as they were.
    pub kept: u64,
    /// Small parts removed.
    pub dropped: u64,
}

/// Finds the small parts of `mesh` at target length `unit` and applies the
/// policy of `options`: kept parts get the kind [`CORNER`] in `kind` and
/// frozen edges, dropped parts are removed from `mesh`.
pub(super) fn apply(
    mesh: &mut Mesh,
    kind: &mut [u32],
    unit: f64,
    options: &RemeshOptions,
) -> PartsReport {
    let nv = mesh.vertex_capacity();
    let mut uf = UnionFind::new(nv);
    for e in mesh.edges() {
        let [a, b] = mesh.edge_vertices(e);
        uf.union(a.0, b.0);
    }
    let root = uf.into_roots();
    // Per root: its bounding box.
    let mut lo = vec![DVec3::splat(f64::INFINITY); nv];
    let mut hi = vec![DVec3::splat(f64::NEG_INFINITY); nv];
    let mut is_root = vec![false; nv];
    for v in mesh.vertices() {
        if mesh.is_isolated(v) {
            continue;
        }
        let r = root[v.idx()] as usize;
        let p = mesh.position(v);
        is_root[r] = true;
        lo[r] = lo[r].min(p);
        hi[r] = hi[r].max(p);
    }
    let limit = options.small_part_size * unit;
    let size = |r: usize| (hi[r] - lo[r]).length();
    // The largest part is always remeshed, so that a lone part, or a scene
    // whose every part is under the limit, is not returned untouched.
    let largest = (0..nv)
        .filter(|&r| is_root[r])
        .max_by(|&a, &b| size(a).total_cmp(&size(b)).then(b.cmp(&a)));
    let small: Vec<bool> = (0..nv)
        .map(|r| is_root[r] && Some(r) != largest && size(r) < limit)
        .collect();
    let total = is_root.iter().filter(|&&r| r).count() as u64;
    let small_count = small.iter().filter(|&&s| s).count() as u64;
    let mut report = PartsReport {
        total,
        remeshed: total - small_count,
        ..Default::default()
    };
    if small_count == 0 {
        return report;
    }
    let is_small = |v: VertexId| !mesh.is_isolated(v) && small[root[v.idx()] as usize];
    match options.small_parts {
        SmallParts::Remesh => report.remeshed = total,
        SmallParts::Keep => {
            let frozen: Vec<VertexId> = mesh.vertices().filter(|&v| is_small(v)).collect();
            for &v in &frozen {
                kind[v.idx()] = CORNER;
            }
            let edges: Vec<_> = mesh
                .edges()
                .filter(|&e| small[root[mesh.edge_vertices(e)[0].idx()] as usize])
                .collect();
            for e in edges {
                mesh.edge_flags[e] |= EDGE_FROZEN;
            }
            report.kept = small_count;
        }
        SmallParts::Drop => {
            let doomed: Vec<bool> = (0..nv).map(|v| is_small(VertexId(v as u32))).collect();
            mesh.remove_parts(|v| doomed[v.idx()]);
            report.dropped = small_count;
        }
    }
    report
}
