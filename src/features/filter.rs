//! The crease filters: creases too small to resample at the target length,
//! creases drawn twice side by side, flat faces ringed by creases, and turns
//! that only wiggle next to another corner.

use super::*;
use crate::bvh::closest_point_on_segment;

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
pub(crate) fn small_creases_kept(
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
    pub(crate) fn live<'a>(
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
pub(crate) fn retain_kept(edges: &mut Vec<[u32; 2]>, flags: &mut Vec<EdgeFlags>, keep: &[bool]) {
    (*edges, *flags) = (edges.iter().zip(flags.iter()).zip(keep))
        .filter(|(_, &k)| k)
        .map(|((&e, &f), _)| (e, f))
        .unzip();
}

/// Largest gap between two crease chains that [`twin_creases_kept`] takes
/// for one crease drawn twice, in units of
/// [`FeatureOptions::min_crease_length`]: 1/6, a quarter of the remesher's
/// target length at the default 1.5 L.
pub(crate) const TWIN_GAP: f64 = 1.0 / 6.0;

/// Which feature edges survive the flat-face rule: an input face whose three
/// edges are all creases and whose height over its longest edge is at most
/// `gap` (a cap: its third corner lies almost on that edge) loses the
/// longest edge. Scan noise makes such faces, tilted against every
/// neighbour; kept, the three creases meet at two corners with a sector of
/// a few degrees (the bunny's narrowest, 0.48°), and every output triangle
/// in it is a sliver. Every point of the dropped edge lies within the height
/// of the two edges kept, which still join its ends. Faces are visited in
/// index order against the edges still kept.
pub(crate) fn flat_creases_kept(
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
pub(crate) fn twin_creases_kept(
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
                .any(|s| closest_point_on_segment(p, pos(s[0]), pos(s[1])).2 <= gap * gap)
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
pub(crate) fn turn_is_wiggle(
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
