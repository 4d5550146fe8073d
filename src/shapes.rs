//! Shapes generated in code for tests and benchmarks: icosphere, torus, open
//! cylinder, subdivided cube, thin plate and a UV sphere. Each returns a
//! closed or open [`TriMesh`] with counter-clockwise (outward) triangles.

use glam::DVec3;
use std::collections::HashMap;
use std::f64::consts::TAU;

use crate::trimesh::TriMesh;

/// A unit icosphere (radius 1, centred at the origin) after `subdivisions`
/// rounds of 1-to-4 subdivision: 20·4ⁿ triangles, genus 0.
pub fn icosphere(subdivisions: u32) -> TriMesh {
    let t = (1.0 + 5f64.sqrt()) / 2.0;
    let mut positions: Vec<DVec3> = [
        (-1.0, t, 0.0),
        (1.0, t, 0.0),
        (-1.0, -t, 0.0),
        (1.0, -t, 0.0),
        (0.0, -1.0, t),
        (0.0, 1.0, t),
        (0.0, -1.0, -t),
        (0.0, 1.0, -t),
        (t, 0.0, -1.0),
        (t, 0.0, 1.0),
        (-t, 0.0, -1.0),
        (-t, 0.0, 1.0),
    ]
    .iter()
    .map(|&(x, y, z)| DVec3::new(x, y, z).normalize())
    .collect();
    let mut triangles: Vec<[u32; 3]> = vec![
        [0, 11, 5],
        [0, 5, 1],
        [0, 1, 7],
        [0, 7, 10],
        [0, 10, 11],
        [1, 5, 9],
        [5, 11, 4],
        [11, 10, 2],
        [10, 7, 6],
        [7, 1, 8],
        [3, 9, 4],
        [3, 4, 2],
        [3, 2, 6],
        [3, 6, 8],
        [3, 8, 9],
        [4, 9, 5],
        [2, 4, 11],
        [6, 2, 10],
        [8, 6, 7],
        [9, 8, 1],
    ];
    for _ in 0..subdivisions {
        let mut mid: HashMap<(u32, u32), u32> = HashMap::new();
        let mut midpoint = |a: u32, b: u32, positions: &mut Vec<DVec3>| -> u32 {
            let key = (a.min(b), a.max(b));
            *mid.entry(key).or_insert_with(|| {
                let p = ((positions[a as usize] + positions[b as usize]) * 0.5).normalize();
                positions.push(p);
                (positions.len() - 1) as u32
            })
        };
        let mut next = Vec::with_capacity(triangles.len() * 4);
        for [a, b, c] in triangles {
            let ab = midpoint(a, b, &mut positions);
            let bc = midpoint(b, c, &mut positions);
            let ca = midpoint(c, a, &mut positions);
            next.extend_from_slice(&[[a, ab, ca], [b, bc, ab], [c, ca, bc], [ab, bc, ca]]);
        }
        triangles = next;
    }
    TriMesh::new(positions, triangles)
}

/// A UV sphere of the given radius with `rings` latitude bands and `segments`
/// longitude segments (poles are single vertices).
pub fn uv_sphere(radius: f64, rings: u32, segments: u32) -> TriMesh {
    assert!(rings >= 2 && segments >= 3);
    let mut positions = vec![DVec3::new(0.0, 0.0, radius)];
    for i in 1..rings {
        let theta = std::f64::consts::PI * i as f64 / rings as f64;
        for j in 0..segments {
            let phi = TAU * j as f64 / segments as f64;
            positions.push(
                radius
                    * DVec3::new(
                        theta.sin() * phi.cos(),
                        theta.sin() * phi.sin(),
                        theta.cos(),
                    ),
            );
        }
    }
    positions.push(DVec3::new(0.0, 0.0, -radius));
    let south = (positions.len() - 1) as u32;
    let ring = |i: u32, j: u32| 1 + (i - 1) * segments + (j % segments);
    let mut triangles = Vec::new();
    for j in 0..segments {
        triangles.push([0, ring(1, j), ring(1, j + 1)]);
        triangles.push([south, ring(rings - 1, j + 1), ring(rings - 1, j)]);
    }
    for i in 1..rings - 1 {
        for j in 0..segments {
            let (a, b, c, d) = (
                ring(i, j),
                ring(i, j + 1),
                ring(i + 1, j),
                ring(i + 1, j + 1),
            );
            triangles.push([a, c, d]);
            triangles.push([a, d, b]);
        }
    }
    TriMesh::new(positions, triangles)
}

/// A torus around the z axis with major radius `major`, minor radius `minor`,
/// `nu` segments around the axis and `nv` around the tube (genus 1).
pub fn torus(major: f64, minor: f64, nu: u32, nv: u32) -> TriMesh {
    assert!(nu >= 3 && nv >= 3);
    let mut positions = Vec::with_capacity((nu * nv) as usize);
    for i in 0..nu {
        let u = TAU * i as f64 / nu as f64;
        for j in 0..nv {
            let v = TAU * j as f64 / nv as f64;
            let r = major + minor * v.cos();
            positions.push(DVec3::new(r * u.cos(), r * u.sin(), minor * v.sin()));
        }
    }
    let id = |i: u32, j: u32| (i % nu) * nv + (j % nv);
    let mut triangles = Vec::with_capacity((2 * nu * nv) as usize);
    for i in 0..nu {
        for j in 0..nv {
            let (a, b, c, d) = (id(i, j), id(i + 1, j), id(i + 1, j + 1), id(i, j + 1));
            triangles.push([a, b, c]);
            triangles.push([a, c, d]);
        }
    }
    TriMesh::new(positions, triangles)
}

/// An open cylinder (no caps) around the z axis: radius `radius`, height
/// `height`, `segments` around and `rows` bands along the axis. Two boundary loops.
pub fn open_cylinder(radius: f64, height: f64, segments: u32, rows: u32) -> TriMesh {
    assert!(segments >= 3 && rows >= 1);
    let mut positions = Vec::new();
    for i in 0..=rows {
        let z = height * i as f64 / rows as f64;
        for j in 0..segments {
            let a = TAU * j as f64 / segments as f64;
            positions.push(DVec3::new(radius * a.cos(), radius * a.sin(), z));
        }
    }
    let id = |i: u32, j: u32| i * segments + (j % segments);
    let mut triangles = Vec::new();
    for i in 0..rows {
        for j in 0..segments {
            let (a, b, c, d) = (id(i, j), id(i, j + 1), id(i + 1, j + 1), id(i + 1, j));
            triangles.push([a, b, c]);
            triangles.push([a, c, d]);
        }
    }
    TriMesh::new(positions, triangles)
}

/// An axis-aligned box from `min` to `max`, each face split into `n`×`n`
/// quads of two triangles; shared edges and corners are single vertices.
pub fn cube(n: u32, min: DVec3, max: DVec3) -> TriMesh {
    assert!(n >= 1);
    let mut index: HashMap<[i64; 3], u32> = HashMap::new();
    let mut positions = Vec::new();
    let mut triangles = Vec::new();
    // Integer lattice coordinates in [0, n] on each axis keep shared vertices exact.
    let mut vertex = |c: [i64; 3], positions: &mut Vec<DVec3>| -> u32 {
        *index.entry(c).or_insert_with(|| {
            let t = DVec3::new(c[0] as f64, c[1] as f64, c[2] as f64) / n as f64;
            positions.push(min + (max - min) * t);
            (positions.len() - 1) as u32
        })
    };
    let n_i = n as i64;
    // Each face: a fixed axis at 0 or n, and two in-plane axes ordered so that
    // (u × v) points outward.
    for axis in 0..3usize {
        for side in [0i64, n_i] {
            let (mut u, mut v) = ((axis + 1) % 3, (axis + 2) % 3);
            if side == 0 {
                std::mem::swap(&mut u, &mut v);
            }
            for i in 0..n_i {
                for j in 0..n_i {
                    let corner = |di: i64, dj: i64| {
                        let mut c = [0i64; 3];
                        c[axis] = side;
                        c[u] = i + di;
                        c[v] = j + dj;
                        c
                    };
                    let a = vertex(corner(0, 0), &mut positions);
                    let b = vertex(corner(1, 0), &mut positions);
                    let c = vertex(corner(1, 1), &mut positions);
                    let d = vertex(corner(0, 1), &mut positions);
                    triangles.push([a, b, c]);
                    triangles.push([a, c, d]);
                }
            }
        }
    }
    TriMesh::new(positions, triangles)
}

/// A thin closed plate: a box `width`×`width`×`thickness`, with `n`×`n` quads per face.
pub fn thin_plate(width: f64, thickness: f64, n: u32) -> TriMesh {
    cube(
        n,
        DVec3::new(0.0, 0.0, 0.0),
        DVec3::new(width, width, thickness),
    )
}

/// A flat open square grid in the xy plane, side `size`, `n`×`n` quads (one boundary loop).
pub fn grid(size: f64, n: u32) -> TriMesh {
    assert!(n >= 1);
    let mut positions = Vec::new();
    for i in 0..=n {
        for j in 0..=n {
            positions.push(DVec3::new(
                size * j as f64 / n as f64,
                size * i as f64 / n as f64,
                0.0,
            ));
        }
    }
    let id = |i: u32, j: u32| i * (n + 1) + j;
    let mut triangles = Vec::new();
    for i in 0..n {
        for j in 0..n {
            triangles.push([id(i, j), id(i, j + 1), id(i + 1, j + 1)]);
            triangles.push([id(i, j), id(i + 1, j + 1), id(i + 1, j)]);
        }
    }
    TriMesh::new(positions, triangles)
}

/// Concatenates meshes into one with several components (labels are dropped).
pub fn union(parts: &[TriMesh]) -> TriMesh {
    let mut out = TriMesh::default();
    for p in parts {
        let off = out.positions.len() as u32;
        out.positions.extend_from_slice(&p.positions);
        out.triangles.extend(
            p.triangles
                .iter()
                .map(|t| [t[0] + off, t[1] + off, t[2] + off]),
        );
    }
    out
}

/// Moves every vertex by `offset`.
pub fn translated(mut mesh: TriMesh, offset: DVec3) -> TriMesh {
    for p in &mut mesh.positions {
        *p += offset;
    }
    mesh
}

#[cfg(test)]
mod tests {
    use super::*;

    fn euler(m: &TriMesh) -> i64 {
        let mut edges = std::collections::HashSet::new();
        for t in &m.triangles {
            for k in 0..3 {
                let (a, b) = (t[k], t[(k + 1) % 3]);
                edges.insert((a.min(b), a.max(b)));
            }
        }
        m.positions.len() as i64 - edges.len() as i64 + m.triangles.len() as i64
    }

    fn signed_volume(m: &TriMesh) -> f64 {
        m.triangles
            .iter()
            .map(|t| {
                let [a, b, c] = m.corner_positions(t);
                a.dot(b.cross(c)) / 6.0
            })
            .sum()
    }

    #[test]
    fn generated_shapes_have_expected_topology_and_outward_orientation() {
        let s = icosphere(2);
        assert_eq!(s.triangles.len(), 320);
        assert_eq!(euler(&s), 2);
        assert!(signed_volume(&s) > 0.0);
        let t = torus(2.0, 0.5, 24, 12);
        assert_eq!(euler(&t), 0);
        assert!(signed_volume(&t) > 0.0);
        let c = cube(3, DVec3::ZERO, DVec3::ONE);
        assert_eq!(euler(&c), 2);
        assert!((signed_volume(&c) - 1.0).abs() < 1e-12);
        assert_eq!(euler(&open_cylinder(1.0, 2.0, 16, 4)), 0);
        let u = uv_sphere(1.0, 8, 12);
        assert_eq!(euler(&u), 2);
        assert!(signed_volume(&u) > 0.0);
        assert_eq!(euler(&grid(1.0, 4)), 1);
    }
}
