//! Triangulating the polygon faces of OBJ, OFF and PLY files, in linear time
//! and with bounded vertex valence.
//!
//! Small polygons (the quads and pentagons of real files) become a fan from
//! their first corner, the split every other tool makes. A fan of a large
//! polygon gives its first corner a valence equal to the polygon's size and
//! a pile of long triangles whose bounding boxes all overlap there, which
//! makes spatial indexes and every later pass slow; large polygons instead
//! become a strip that zig-zags between the two ends of the corner list, so
//! that no corner gains more than a few triangles and the triangles stack
//! across the polygon instead of nesting.

use super::IoError;

/// Polygons with up to this many corners are split into a fan.
const FAN_MAX_CORNERS: usize = 8;

/// The largest polygon accepted. Polygons of real files have tens of
/// corners; one of a million corners is a malformed or hostile file, and the
/// limit keeps a single face line from standing in for a whole mesh.
pub const MAX_POLYGON_CORNERS: usize = 65_536;

/// Appends the triangles of the polygon `corners` (in their order, so the
/// triangles keep its orientation) to `out`. Polygons of fewer than three
/// corners add nothing; `face` names the face in the error for a polygon
/// above [`MAX_POLYGON_CORNERS`].
pub(super) fn triangulate(
    face: u64,
    corners: &[u32],
    out: &mut Vec<[u32; 3]>,
) -> Result<(), IoError> {
    let n = corners.len();
    if n > MAX_POLYGON_CORNERS {
        return Err(IoError::TooLarge {
            message: format!(
                "face {face} is a polygon of {n} corners; at most {MAX_POLYGON_CORNERS} are accepted"
            ),
        });
    }
    if n < 3 {
        return Ok(());
    }
    if n <= FAN_MAX_CORNERS {
        out.extend((1..n - 1).map(|k| [corners[0], corners[k], corners[k + 1]]));
        return Ok(());
    }
    // Zig-zag: each triangle takes the next corner from the low end or the
    // high end in turn; (lo, lo+1, hi) and (lo, hi-1, hi) both run forward
    // around the polygon, like the polygon itself.
    out.reserve(n - 2);
    let (mut lo, mut hi) = (0, n - 1);
    while hi - lo >= 2 {
        out.push([corners[lo], corners[lo + 1], corners[hi]]);
        lo += 1;
        if hi - lo >= 2 {
            out.push([corners[lo], corners[hi - 1], corners[hi]]);
            hi -= 1;
        }
    }
    Ok(())
}

#[cfg(test)]
mod tests {
    use super::*;

    fn tris(n: usize) -> Vec<[u32; 3]> {
        let corners: Vec<u32> = (0..n as u32).collect();
        let mut out = Vec::new();
        triangulate(0, &corners, &mut out).unwrap();
        out
    }

    #[test]
    fn small_polygons_become_fans_from_the_first_corner() {
        assert_eq!(tris(2), Vec::<[u32; 3]>::new());
        assert_eq!(tris(3), [[0, 1, 2]]);
        assert_eq!(tris(4), [[0, 1, 2], [0, 2, 3]]);
        assert_eq!(tris(FAN_MAX_CORNERS).len(), FAN_MAX_CORNERS - 2);
    }

    #[test]
    fn large_polygons_become_strips_that_cover_every_edge_once() {
        for n in [FAN_MAX_CORNERS + 1, 10, 11, 1000, 1001] {
            let t = tris(n);
            assert_eq!(t.len(), n - 2, "n = {n}");
            // Each directed polygon edge appears exactly once, and each
            // diagonal once in each direction: a consistently oriented disk.
            let mut directed = std::collections::HashMap::new();
            for tri in &t {
                for k in 0..3 {
                    *directed.entry((tri[k], tri[(k + 1) % 3])).or_insert(0) += 1;
                }
            }
            for i in 0..n as u32 {
                let j = (i + 1) % n as u32;
                assert_eq!(directed.get(&(i, j)), Some(&1), "n = {n}, edge {i}-{j}");
                assert_eq!(directed.get(&(j, i)), None);
            }
            for (&(a, b), &c) in &directed {
                assert_eq!(c, 1);
                let boundary = (a + 1) % n as u32 == b;
                assert!(boundary || directed.contains_key(&(b, a)), "{a}-{b}");
            }
            // Bounded valence: no corner is in more than four triangles.
            let mut uses = vec![0; n];
            for tri in &t {
                for &v in tri {
                    uses[v as usize] += 1;
                }
            }
            assert!(uses.iter().all(|&u| u <= 4), "n = {n}: {uses:?}");
        }
    }

    #[test]
    fn polygons_above_the_limit_are_refused_by_name() {
        let corners: Vec<u32> = (0..MAX_POLYGON_CORNERS as u32 + 1).collect();
        let err = triangulate(7, &corners, &mut Vec::new()).unwrap_err();
        let text = err.to_string();
        assert!(text.contains("face 7") && text.contains("65537"), "{text}");
    }
}
