//! `normals: "transfer"`: the input's authored shading normals carried onto
//! the remeshed surface, against `recompute`, which shades the new surface
//! itself. The shape is low-poly art: a 12-sided prism whose sides carry
//! smooth, radial normals (a cylinder in look) and whose caps are flat,
//! with a hard edge at each rim.

mod service_support;

use std::f64::consts::TAU;

use glam::DVec3;
use isoremesh::io::{self, Format, ReadOptions, WriteOptions};
use isoremesh::pipeline::{self, JobOutput};
use isoremesh::remesh::{NoObserver, NormalSource, RemeshOptions};
use isoremesh::TriMesh;

const SIDES: usize = 12;
const HALF_HEIGHT: f64 = 1.0;

fn radial(k: usize) -> DVec3 {
    let a = TAU * k as f64 / SIDES as f64;
    DVec3::new(a.cos(), a.sin(), 0.0)
}

/// The prism: side vertices (two rings) with radial normals shared by the
/// sides around them, and each cap with its own vertices and normal.
fn smooth_prism() -> TriMesh {
    let mut m = TriMesh::default();
    let s = SIDES as u32;
    for z in [-HALF_HEIGHT, HALF_HEIGHT] {
        for k in 0..SIDES {
            m.positions.push(radial(k) + DVec3::Z * z);
            m.normals.push(radial(k));
        }
    }
    for k in 0..s {
        let (a, b) = (k, (k + 1) % s);
        m.triangles.push([a, b, b + s]);
        m.triangles.push([a, b + s, a + s]);
    }
    for (z, up) in [(-HALF_HEIGHT, false), (HALF_HEIGHT, true)] {
        let centre = m.positions.len() as u32;
        let normal = if up { DVec3::Z } else { -DVec3::Z };
        m.positions.push(DVec3::Z * z);
        m.normals.push(normal);
        for k in 0..SIDES {
            m.positions.push(radial(k) + DVec3::Z * z);
            m.normals.push(normal);
        }
        for k in 0..s {
            let (a, b) = (centre + 1 + k, centre + 1 + (k + 1) % s);
            m.triangles
                .push(if up { [centre, a, b] } else { [centre, b, a] });
        }
    }
    m
}

fn remesh(normals: NormalSource) -> JobOutput {
    let glb = io::write(&smooth_prism(), Format::Glb, &WriteOptions::default()).unwrap();
    let input = pipeline::load(&glb, Some("prism.glb"), None, &ReadOptions::default()).unwrap();
    assert_eq!(input.source.normals.len(), input.source.positions.len());
    let options = RemeshOptions {
        target_edge_length: Some(0.1),
        normals,
        ..RemeshOptions::default()
    };
    pipeline::run(&input, &options, &mut NoObserver).unwrap()
}

/// The authored normal at a point of a side: the radial normals of the
/// side's two edges, blended linearly along the side as a renderer
/// interpolates them.
fn authored_side_normal(p: DVec3) -> DVec3 {
    let a = p.y.atan2(p.x).rem_euclid(TAU);
    let k = ((a / TAU * SIDES as f64).floor() as usize).min(SIDES - 1);
    let (pa, pb) = (radial(k), radial(k + 1));
    let flat = DVec3::new(p.x, p.y, 0.0);
    let t = ((flat - pa).dot(pb - pa) / (pb - pa).length_squared()).clamp(0.0, 1.0);
    pa.lerp(pb, t).normalize()
}

/// Degrees between each side vertex's written normal and the authored one
/// (vertices off the rims), and how many cap vertices point along ±z.
fn side_errors(job: &JobOutput) -> (Vec<f64>, usize, usize) {
    let m = &job.mesh;
    assert_eq!(m.normals.len(), m.positions.len());
    let (mut errors, mut caps, mut cap_vertices) = (Vec::new(), 0, 0);
    for (&p, &n) in m.positions.iter().zip(&m.normals) {
        assert!((n.length() - 1.0).abs() < 1e-6, "normal {n} at {p}");
        let on_cap = (p.z.abs() - HALF_HEIGHT).abs() < 1e-9;
        if !on_cap {
            let cos = n.dot(authored_side_normal(p)).clamp(-1.0, 1.0);
            errors.push(cos.acos().to_degrees());
        } else if DVec3::new(p.x, p.y, 0.0).length() < 0.9 {
            cap_vertices += 1;
            if (n - DVec3::Z * p.z.signum()).length() < 1e-6 {
                caps += 1;
            }
        }
    }
    (errors, caps, cap_vertices)
}

#[test]
fn transferred_normals_keep_the_authored_smooth_sides_and_flat_caps() {
    let job = remesh(NormalSource::Transfer);
    assert_eq!(job.stats.attributes.normals, "transferred");
    let (errors, caps, cap_vertices) = side_errors(&job);
    assert!(errors.len() > 500, "{} side vertices", errors.len());
    let worst = errors.iter().cloned().fold(0.0, f64::max);
    eprintln!("transfer: worst side normal {worst:.3}° from the authored one");
    assert!(
        worst < 1.0,
        "worst side normal {worst:.2}° from the authored one"
    );
    assert!(cap_vertices > 50);
    assert_eq!(caps, cap_vertices, "a cap vertex lost its flat normal");
    // The rims stay hard: every rim position carries a cap normal and a
    // side normal, on two vertices.
    let m = &job.mesh;
    let rim: Vec<usize> = (0..m.positions.len())
        .filter(|&v| {
            let p = m.positions[v];
            (p.z.abs() - HALF_HEIGHT).abs() < 1e-9 && DVec3::new(p.x, p.y, 0.0).length() > 0.95
        })
        .collect();
    for &v in &rim {
        let p = m.positions[v];
        let sideways = rim
            .iter()
            .any(|&w| m.positions[w] == p && m.normals[w].z.abs() < 1e-6);
        let capped = rim
            .iter()
            .any(|&w| m.positions[w] == p && (m.normals[w].z.abs() - 1.0).abs() < 1e-6);
        assert!(sideways && capped, "rim vertex at {p} is not split");
    }
    // Written and read back, the normals are the file's.
    let glb = pipeline::encode(m, Format::Glb).unwrap();
    let back = io::read(&glb, Format::Glb, &ReadOptions::default())
        .unwrap()
        .mesh;
    assert_eq!(back.normals.len(), back.positions.len());
}

#[test]
fn recomputed_normals_shade_the_new_facets_instead() {
    let job = remesh(NormalSource::Recompute);
    assert_eq!(job.stats.attributes.normals, "recomputed");
    let (errors, _, _) = side_errors(&job);
    let worst = errors.iter().cloned().fold(0.0, f64::max);
    eprintln!("recompute: worst side normal {worst:.3}° from the authored one");
    // Inside a flat side the surface's own normal is the side's, up to
    // 15° from the authored one at its edges.
    assert!(
        worst > 5.0,
        "recomputed normals agree with the authored ones ({worst:.2}°)"
    );
}

#[test]
fn a_transfer_from_an_input_without_normals_recomputes_and_says_so() {
    let mut prism = smooth_prism();
    prism.normals.clear();
    let glb = io::write(&prism, Format::Glb, &WriteOptions::default()).unwrap();
    let input = pipeline::load(&glb, Some("prism.glb"), None, &ReadOptions::default()).unwrap();
    let options = RemeshOptions {
        target_edge_length: Some(0.1),
        normals: NormalSource::Transfer,
        ..RemeshOptions::default()
    };
    let job = pipeline::run(&input, &options, &mut NoObserver).unwrap();
    assert!(
        job.stats.attributes.normals.starts_with("recomputed: "),
        "{}",
        job.stats.attributes.normals
    );
    assert_eq!(job.mesh.normals.len(), job.mesh.positions.len());
}

/// The service takes the parameter by name, in JSON and in the query, and
/// the job's statistics say what became of the normals.
#[test]
fn the_service_transfers_normals_when_asked() {
    let dir = tempfile::tempdir().unwrap();
    let s = service_support::Server::start(service_support::config(dir.path()));
    let glb = io::write(&smooth_prism(), Format::Glb, &WriteOptions::default()).unwrap();
    let id = s.submit_ok(
        "prism.glb",
        glb.clone(),
        serde_json::json!({"normals": "transfer", "target_edge_length": 0.1}),
    );
    let job = s.wait_finished(&id);
    assert_eq!(job["status"], "succeeded", "{job}");
    assert_eq!(job["params"]["normals"], "transfer", "{job}");
    assert_eq!(job["stats"]["attributes"]["normals"], "transferred");
    let r = s.submit_raw("model/gltf-binary", glb, "?normals=sideways");
    service_support::assert_problem(r, 422, Some("normals"));
    s.stop();
}
