//! Textured and coloured meshes come out textured and coloured: texture
//! coordinates and colours are transferred chart by chart, seams are kept,
//! no UV triangle flips or degenerates, the texture sits where it did
//! (colour error), and images are copied byte for byte. Generated shapes
//! with a procedural checker texture, and the Duck.

mod data_support;
mod textured_support;

use std::f64::consts::{PI, TAU};

use glam::DVec3;
use isoremesh::io::{self, Format, ReadOptions, WriteOptions};
use isoremesh::pipeline::{self, JobOutput};
use isoremesh::remesh::{NoObserver, RemeshOptions};
use isoremesh::stats::attributes::TexcoordStats;
use isoremesh::{shapes, TriMesh};
use textured_support::{checker_png, edit_glb, textured_soup};

/// `mesh` as a soup with per-corner texture coordinates from `uv` and one
/// base-colour texture, written as GLB.
fn textured_glb(mesh: &TriMesh, uv: impl Fn([DVec3; 3]) -> [[f32; 2]; 3], png: &[u8]) -> Vec<u8> {
    io::write(
        &textured_soup(mesh, uv, png),
        Format::Glb,
        &WriteOptions::default(),
    )
    .unwrap()
}

/// Remeshes GLB bytes at the bench target (0.75 % of the diagonal, 10 iterations).
fn remesh(glb: &[u8]) -> JobOutput {
    let input = pipeline::load(glb, Some("in.glb"), None, &ReadOptions::default()).unwrap();
    let options = RemeshOptions {
        target_edge_ratio: Some(0.0075),
        ..RemeshOptions::default()
    };
    pipeline::run(&input, &options, &mut NoObserver).unwrap()
}

/// The goals every textured remesh must meet, and the output's round trip.
fn check_textured(job: &JobOutput, png: &[u8]) -> TexcoordStats {
    let a = &job.stats.attributes;
    assert_eq!(a.input, ["TEXCOORD_0"]);
    assert_eq!(a.output, ["TEXCOORD_0"]);
    assert!(a.dropped.is_empty(), "{:?}", a.dropped);
    let uv = a.texcoords[0].clone();
    assert_eq!(uv.uv_flipped, 0, "{uv:?}");
    assert_eq!(uv.uv_degenerate, 0, "{uv:?}");
    assert!(uv.seam_within_1pct_l >= 0.99, "{uv:?}");
    let err = uv.color_error.clone().expect("the checker decodes");
    assert_eq!(err.samples, 100_000);
    for c in 0..3 {
        assert!(err.mean[c] <= 3.0 && err.p99[c] <= 24.0, "{err:?}");
    }
    // Written and read back in every glTF form, the image is the same bytes.
    for format in [Format::Glb, Format::Gltf] {
        let bytes = pipeline::encode(&job.mesh, format).unwrap();
        let back = io::read(&bytes, format, &ReadOptions::default())
            .unwrap()
            .mesh;
        assert_eq!(back.attributes.texcoords.len(), 1);
        assert_eq!(back.appearance.as_ref().unwrap().images[0].bytes, png);
        let m = back.labels[0].material.as_ref().unwrap();
        assert_eq!(
            m.gltf.as_ref().unwrap()["pbrMetallicRoughness"]["baseColorTexture"]["index"],
            0
        );
    }
    uv
}

/// Prints the figures of docs/BENCHMARKS.md's textured table for `job` as
/// one Markdown row (shown with `--nocapture`; `benches/reproduce.sh
/// textured` collects them).
fn print_row(name: &str, job: &JobOutput, uv: &TexcoordStats) {
    let out = &job.stats.output;
    let e = out.edge_length.as_ref().unwrap();
    let colour = uv.color_error.as_ref().map_or("-".to_string(), |c| {
        format!(
            "{:.2}, {:.2}, {:.2} | {:.1}, {:.1}, {:.1}",
            c.mean[0], c.mean[1], c.mean[2], c.p99[0], c.p99[1], c.p99[2]
        )
    });
    println!(
        "| {name} | {} | {:.1} % | {:.1} % | {} → {} | {:.2} % | {} / {} | {:.3} → {:.3} | {colour} |",
        out.faces,
        100.0 * e.within_band,
        100.0 * out.valence.regular_fraction.unwrap_or(0.0),
        uv.seam_edges_in,
        uv.seam_edges_out,
        100.0 * uv.seam_within_1pct_l,
        uv.uv_flipped,
        uv.uv_degenerate,
        uv.stretch_l2_in,
        uv.stretch_l2_out,
    );
}

/// u from the angle around z, with a face that straddles the cut taking
/// the far side (u > 1) so that it is not stretched across the texture.
fn around(p: [DVec3; 3]) -> [f64; 3] {
    let mut u = p.map(|q| q.y.atan2(q.x).rem_euclid(TAU) / TAU);
    let (lo, hi) = (
        u.iter().copied().fold(1.0, f64::min),
        u.iter().copied().fold(0.0, f64::max),
    );
    if hi - lo > 0.5 {
        u.iter_mut().filter(|x| **x < 0.5).for_each(|x| *x += 1.0);
    }
    u
}

#[test]
fn uv_sphere_with_one_seam_keeps_its_checker() {
    let sphere = shapes::uv_sphere(1.0, 24, 48);
    let png = checker_png();
    let glb = textured_glb(
        &sphere,
        |p| {
            let mut u = around(p);
            // A pole corner takes the mean u of its face's other corners.
            for k in 0..3 {
                if p[k].x.hypot(p[k].y) < 1e-9 {
                    u[k] = (u[(k + 1) % 3] + u[(k + 2) % 3]) / 2.0;
                }
            }
            [0, 1, 2].map(|k| [u[k] as f32, (p[k].z.clamp(-1.0, 1.0).acos() / PI) as f32])
        },
        &png,
    );
    let job = remesh(&glb);
    let uv = check_textured(&job, &png);
    print_row("UV sphere", &job, &uv);
    assert!(uv.seam_edges_in > 0 && uv.seam_edges_out > 0);
}

#[test]
fn cube_with_six_charts_keeps_each_side_on_its_own() {
    let cube = shapes::cube(6, DVec3::splat(-0.5), DVec3::splat(0.5));
    let png = checker_png();
    let glb = textured_glb(
        &cube,
        |p| {
            let n = (p[1] - p[0]).cross(p[2] - p[0]);
            let axis = n.abs().max_position();
            let (i, j) = ((axis + 1) % 3, (axis + 2) % 3);
            // Six charts side by side in a 3×2 atlas with a margin.
            let (cu, cv) = (
                (axis % 3) as f64 / 3.0,
                if n[axis] > 0.0 { 0.0 } else { 0.5 },
            );
            p.map(|q| {
                [
                    (cu + (q[i] + 0.5) * 0.3) as f32,
                    (cv + (q[j] + 0.5) * 0.45) as f32,
                ]
            })
        },
        &png,
    );
    let job = remesh(&glb);
    let uv = check_textured(&job, &png);
    print_row("cube, six charts", &job, &uv);
    assert_eq!(uv.charts_out, 6, "{uv:?}");
}

#[test]
fn open_cylinder_with_a_seam_along_its_length() {
    let cyl = shapes::open_cylinder(0.5, 2.0, 40, 30);
    let png = checker_png();
    let glb = textured_glb(
        &cyl,
        |p| {
            let u = around(p);
            [0, 1, 2].map(|k| [u[k] as f32, (p[k].z / 2.0 + 0.5) as f32])
        },
        &png,
    );
    let job = remesh(&glb);
    let uv = check_textured(&job, &png);
    print_row("open cylinder", &job, &uv);
}

/// A texture map that shears back and forth along rows narrower than the
/// output's triangles (u = x + s(y), s a zigzag; v = y). Every input face
/// is affine and keeps its orientation, but three corners of a coarser
/// triangle sampled on it can fold, so the remesher's texture-space guard
/// must mend them: none is left flipped or degenerate.
#[test]
fn a_shear_finer_than_the_output_folds_no_triangle() {
    let plane = shapes::grid(1.0, 160);
    let png = checker_png();
    // Period 4/160 and amplitude 0.02, its kinks on grid rows: linear on
    // every input face, with slope 1.6.
    let zigzag = |y: f64| {
        let t = (y * 40.0).rem_euclid(1.0);
        0.02 * (1.0 - (2.0 * t - 1.0).abs())
    };
    let glb = textured_glb(
        &plane,
        |p| p.map(|q| [(q.x + zigzag(q.y)) as f32, q.y as f32]),
        &png,
    );
    let job = remesh(&glb);
    let uv = &job.stats.attributes.texcoords[0];
    let guard = job.report.uv_repair;
    println!("shear: texture-space guard {guard:?}");
    assert!(guard.found > 0, "the case no longer folds: {guard:?}");
    assert_eq!(
        (guard.left, uv.uv_flipped, uv.uv_degenerate),
        (0, 0, 0),
        "{guard:?} {uv:?}"
    );
    assert_eq!(uv.seam_edges_out, 0, "{uv:?}");
}

/// A cube whose top maps to one texel point: the output's top faces have
/// no UV area, and the statistics and the texture-space guard say that the
/// input made them so, instead of trying to mend them.
#[test]
fn faces_over_a_point_of_texture_space_are_inherited() {
    let cube = shapes::cube(6, DVec3::splat(-0.5), DVec3::splat(0.5));
    let png = checker_png();
    let glb = textured_glb(
        &cube,
        |p| {
            let n = (p[1] - p[0]).cross(p[2] - p[0]);
            if n.z > 0.0 && n.x.abs() + n.y.abs() < 1e-9 {
                return [[0.5, 0.5]; 3];
            }
            let axis = n.abs().max_position();
            let (i, j) = ((axis + 1) % 3, (axis + 2) % 3);
            p.map(|q| [(q[i] + 0.5) as f32 * 0.3, (q[j] + 0.5) as f32 * 0.3])
        },
        &png,
    );
    let job = remesh(&glb);
    let uv = &job.stats.attributes.texcoords[0];
    let guard = job.report.uv_repair;
    assert!(uv.uv_degenerate > 0, "{uv:?}");
    assert_eq!(uv.uv_degenerate_inherited, uv.uv_degenerate, "{uv:?}");
    assert_eq!(guard.inherited, guard.found, "{guard:?}");
    assert_eq!(guard.edits, 0, "{guard:?}");
}

#[test]
fn vertex_colours_alone_are_transferred() {
    let mut sphere = shapes::icosphere(4);
    let colour = |p: DVec3| {
        let c = 0.5 * (p.normalize() + DVec3::ONE);
        [c.x as f32, c.y as f32, c.z as f32, 1.0]
    };
    sphere.attributes.colors = sphere.positions.iter().map(|&p| colour(p)).collect();
    let glb = io::write(&sphere, Format::Glb, &WriteOptions::default()).unwrap();
    let job = remesh(&glb);
    assert_eq!(job.stats.attributes.output, ["COLOR_0"]);
    assert!(job.stats.attributes.texcoords.is_empty());
    let out = &job.mesh;
    assert_eq!(out.attributes.colors.len(), out.positions.len());
    // Linear interpolation of a smooth field: close to the field everywhere.
    let worst = out
        .positions
        .iter()
        .zip(&out.attributes.colors)
        .map(|(&p, c)| {
            let want = colour(p);
            (0..3)
                .map(|k| (c[k] - want[k]).abs())
                .fold(0.0f32, f32::max)
        })
        .fold(0.0f32, f32::max);
    assert!(worst < 0.02, "worst colour error {worst}");
    let bytes = pipeline::encode(out, Format::Glb).unwrap();
    let back = io::read(&bytes, Format::Glb, &ReadOptions::default())
        .unwrap()
        .mesh;
    assert_eq!(back.attributes.colors.len(), back.positions.len());
    assert!(!back.attributes.color_alpha);
}

#[test]
fn duck_keeps_its_texture() {
    let glb = data_support::bytes("gltf/Duck.glb");
    let png = io::read(&glb, Format::Glb, &ReadOptions::default())
        .unwrap()
        .mesh
        .appearance
        .unwrap()
        .images[0]
        .bytes
        .clone();
    let job = remesh(&glb);
    let uv = &job.stats.attributes.texcoords[0];
    print_row("Duck.glb", &job, uv);
    let err = uv.color_error.as_ref().unwrap();
    for c in 0..3 {
        assert!(err.mean[c] <= 3.0 && err.p99[c] <= 24.0, "{err:?}");
    }
    assert!(uv.seam_within_1pct_l >= 0.99, "{uv:?}");
    assert_eq!(uv.uv_degenerate, 0, "{uv:?}");
    let bytes = pipeline::encode(&job.mesh, Format::Glb).unwrap();
    let back = io::read(&bytes, Format::Glb, &ReadOptions::default())
        .unwrap()
        .mesh;
    assert_eq!(back.appearance.unwrap().images[0].bytes, png);
}

#[test]
fn non_finite_texture_coordinates_name_the_accessor() {
    let mut tri = TriMesh::new(vec![DVec3::ZERO, DVec3::X, DVec3::Y], vec![[0, 1, 2]]);
    tri.attributes.texcoords = vec![vec![[0.0, 0.0], [1.0, 0.0], [0.0, 1.0]]];
    let mut glb = io::write(&tri, Format::Glb, &WriteOptions::default()).unwrap();
    // Overwrite the first texture coordinate (after 3 positions and 3
    // normals, 72 bytes into the binary chunk) with NaN.
    let json_len = u32::from_le_bytes(glb[12..16].try_into().unwrap()) as usize;
    let bin = 20 + json_len + 8;
    let doc: serde_json::Value = serde_json::from_slice(&glb[20..20 + json_len]).unwrap();
    let acc = doc["meshes"][0]["primitives"][0]["attributes"]["TEXCOORD_0"]
        .as_u64()
        .unwrap() as usize;
    let view = doc["accessors"][acc]["bufferView"].as_u64().unwrap() as usize;
    let at = bin + doc["bufferViews"][view]["byteOffset"].as_u64().unwrap() as usize;
    glb[at..at + 4].copy_from_slice(&f32::NAN.to_le_bytes());
    let err = io::read(&glb, Format::Glb, &ReadOptions::default()).unwrap_err();
    let msg = err.to_string();
    assert!(
        msg.contains("TEXCOORD_0") && msg.contains(&format!("accessor {acc}")),
        "{msg}"
    );
}

#[test]
fn an_image_of_unknown_format_is_kept_and_noted() {
    let cube = shapes::cube(3, DVec3::splat(-0.5), DVec3::splat(0.5));
    let odd = b"not an image at all".to_vec();
    let glb = textured_glb(
        &cube,
        |p| p.map(|q| [(q.x + 0.5) as f32, (q.y + 0.5) as f32]),
        &odd,
    );
    let job = remesh(&glb);
    let a = &job.stats.attributes;
    assert!(a.texcoords[0].color_error.is_none());
    assert!(
        a.notes.iter().any(|n| n.contains("not PNG or JPEG")),
        "{:?}",
        a.notes
    );
    let bytes = pipeline::encode(&job.mesh, Format::Glb).unwrap();
    let back = io::read(&bytes, Format::Glb, &ReadOptions::default())
        .unwrap()
        .mesh;
    assert_eq!(back.appearance.unwrap().images[0].bytes, odd);
}

/// The CRC-32 of PNG chunks (ISO 3309), bit by bit.
fn crc32(bytes: &[u8]) -> u32 {
    let mut c = 0xFFFF_FFFFu32;
    for &b in bytes {
        c ^= u32::from(b);
        for _ in 0..8 {
            c = if c & 1 != 0 {
                0xEDB8_8320 ^ (c >> 1)
            } else {
                c >> 1
            };
        }
    }
    !c
}

#[test]
fn a_texture_larger_than_the_limit_is_refused_from_its_header() {
    // A PNG declaring 20000 × 20000 RGBA pixels in its header, with no pixel data.
    let mut png = b"\x89PNG\r\n\x1a\n".to_vec();
    let mut ihdr = b"IHDR".to_vec();
    ihdr.extend_from_slice(&20_000u32.to_be_bytes());
    ihdr.extend_from_slice(&20_000u32.to_be_bytes());
    ihdr.extend_from_slice(&[8, 6, 0, 0, 0]);
    png.extend_from_slice(&13u32.to_be_bytes());
    png.extend_from_slice(&ihdr);
    png.extend_from_slice(&crc32(&ihdr).to_be_bytes());
    for chunk in [&b"IDAT"[..], &b"IEND"[..]] {
        png.extend_from_slice(&0u32.to_be_bytes());
        png.extend_from_slice(chunk);
        png.extend_from_slice(&crc32(chunk).to_be_bytes());
    }
    let cube = shapes::cube(3, DVec3::splat(-0.5), DVec3::splat(0.5));
    let glb = textured_glb(
        &cube,
        |p| p.map(|q| [(q.x + 0.5) as f32, (q.y + 0.5) as f32]),
        &png,
    );
    let job = remesh(&glb);
    let a = &job.stats.attributes;
    assert!(a.texcoords[0].color_error.is_none());
    assert!(
        a.notes.iter().any(|n| n.contains("20000×20000")),
        "{:?}",
        a.notes
    );
    let bytes = pipeline::encode(&job.mesh, Format::Glb).unwrap();
    let back = io::read(&bytes, Format::Glb, &ReadOptions::default())
        .unwrap()
        .mesh;
    assert_eq!(back.appearance.unwrap().images[0].bytes, png);
}

#[test]
fn attributes_that_are_not_carried_are_named() {
    let mut sphere = shapes::icosphere(2);
    sphere.attributes.texcoords = vec![sphere
        .positions
        .iter()
        .map(|p| [p.x as f32, p.y as f32])
        .collect()];
    let glb = io::write(&sphere, Format::Glb, &WriteOptions::default()).unwrap();
    let glb = edit_glb(&glb, |doc| {
        let attrs = &mut doc["meshes"][0]["primitives"][0]["attributes"];
        let positions = attrs["POSITION"].clone();
        attrs["TANGENT"] = positions.clone();
        attrs["COLOR_1"] = positions;
    });
    let job = remesh(&glb);
    let names: Vec<&str> = job
        .stats
        .attributes
        .dropped
        .iter()
        .map(|d| d.name.as_str())
        .collect();
    // Tangents are generated again for the new surface, not dropped.
    assert_eq!(names, ["COLOR_1"], "{:?}", job.stats.attributes.dropped);
    assert_eq!(job.stats.attributes.output, ["TEXCOORD_0", "TANGENT"]);

    // Without texture coordinates there is no basis to generate them from.
    let bare = io::write(&shapes::icosphere(2), Format::Glb, &WriteOptions::default()).unwrap();
    let bare = edit_glb(&bare, |doc| {
        let attrs = &mut doc["meshes"][0]["primitives"][0]["attributes"];
        attrs["TANGENT"] = attrs["POSITION"].clone();
    });
    let job = remesh(&bare);
    let dropped = &job.stats.attributes.dropped;
    assert_eq!(dropped.len(), 1, "{dropped:?}");
    assert_eq!(dropped[0].name, "TANGENT");
    assert!(job.stats.attributes.output.is_empty());
}
