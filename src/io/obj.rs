//! Wavefront OBJ through `tobj::load_obj_buf`, with polygons triangulated by
//! [`super::polygon`]. The material library is never opened: the loader passed to tobj
//! returns name-only placeholder materials for the `usemtl` names found in
//! the file itself, so that each material becomes one face label (material
//! borders become features later). Groups and objects without materials do
//! not create labels. tobj gives each object/group/material run its own
//! vertex array, so vertices on those borders arrive duplicated; the
//! half-edge builder welds them.

use std::cell::Cell;
use std::collections::HashMap;
use std::io::Write;
use std::path::Path;

use glam::DVec3;

use super::text::{push_lines, push_u64, push_vec3_line};
use super::{Format, Imported, IoError};
use crate::{Label, Material, TriMesh};

/// A name tobj is handed as the material library when the file uses
/// materials but declares none; the loader never resolves it.
const PLACEHOLDER_MTLLIB: &[u8] = b"mtllib isoremesh-materials-are-not-loaded\n";

pub(super) fn read(bytes: &[u8]) -> Result<Imported, IoError> {
    let names = usemtl_names(bytes);
    let uses_materials = !names.is_empty();
    // The placeholder `mtllib` line makes tobj call the loader once before
    // any `usemtl`, even in files without an `mtllib` statement.
    let prefix: &[u8] = if uses_materials {
        PLACEHOLDER_MTLLIB
    } else {
        b""
    };
    let mut reader = std::io::Read::chain(prefix, bytes);
    let served = Cell::new(false);
    let loader = |_path: &Path| -> tobj::MTLLoadResult {
        if served.replace(true) {
            return Ok((Vec::new(), HashMap::new()));
        }
        let mats = names
            .iter()
            .map(|n| tobj::Material {
                name: n.clone(),
                ..Default::default()
            })
            .collect();
        let map = names
            .iter()
            .enumerate()
            .map(|(i, n)| (n.clone(), i))
            .collect();
        Ok((mats, map))
    };
    let options = tobj::LoadOptions {
        single_index: false,
        triangulate: false,
        ignore_points: true,
        ignore_lines: true,
    };
    let (models, _materials) = match tobj::load_obj_buf(&mut reader, &options, loader) {
        Ok(r) => r,
        Err(tobj::LoadError::FaceVertexOutOfBounds) => return Err(locate_bad_index(bytes)),
        Err(tobj::LoadError::ReadError) => {
            return Err(IoError::parse(Format::Obj, "the file is not UTF-8 text"))
        }
        Err(e) => return Err(IoError::parse(Format::Obj, e.to_string())),
    };

    let mut mesh = TriMesh::default();
    let mut label_of: HashMap<Option<usize>, u32> = HashMap::new();
    let mut normals_ok = true;
    // Faces counted from 0 in file order, for error messages.
    let mut polygons = 0u64;
    for model in &models {
        let m = &model.mesh;
        let base = super::vertex_index(mesh.positions.len())?;
        let count = m.positions.len() / 3;
        super::vertex_index(mesh.positions.len() + count)?;
        mesh.positions.extend(
            m.positions
                .chunks_exact(3)
                .map(|c| DVec3::new(c[0], c[1], c[2])),
        );
        let first_face = mesh.triangles.len();
        if m.face_arities.is_empty() {
            mesh.triangles.extend(
                m.indices
                    .chunks_exact(3)
                    .map(|t| [t[0] + base, t[1] + base, t[2] + base]),
            );
            polygons += (m.indices.len() / 3) as u64;
        } else {
            let mut start = 0;
            let mut corners: Vec<u32> = Vec::new();
            for &arity in &m.face_arities {
                let end = start + arity as usize;
                corners.clear();
                let face = m.indices.get(start..end).ok_or_else(|| {
                    IoError::parse(Format::Obj, "the parser returned inconsistent faces")
                })?;
                corners.extend(face.iter().map(|&i| i + base));
                super::polygon::triangulate(polygons, &corners, &mut mesh.triangles)?;
                polygons += 1;
                start = end;
            }
        }
        if uses_materials {
            let next = label_of.len() as u32;
            let label = *label_of.entry(m.material_id).or_insert(next);
            if label == next {
                let name = m.material_id.and_then(|i| names.get(i)).cloned();
                mesh.labels.push(Label {
                    name: name.clone(),
                    material: name.map(|n| Material {
                        name: Some(n),
                        ..Default::default()
                    }),
                });
            }
            mesh.face_labels.resize(
                mesh.face_labels.len() + (mesh.triangles.len() - first_face),
                label,
            );
        }
        if normals_ok {
            normals_ok = append_normals(&mut mesh.normals, m, count);
        }
    }
    if !normals_ok {
        mesh.normals.clear();
    }
    Ok(Imported {
        mesh,
        ignored_primitives: 0,
    })
}

/// Per-vertex normals of one tobj model: kept only when every corner of a
/// vertex names the same normal (as in files written by [`write`]).
fn append_normals(out: &mut Vec<DVec3>, m: &tobj::Mesh, count: usize) -> bool {
    if m.normals.is_empty() || m.normal_indices.len() != m.indices.len() {
        return false;
    }
    let start = out.len();
    out.resize(start + count, DVec3::NAN);
    let mut chosen = vec![u32::MAX; count];
    for (&v, &n) in m.indices.iter().zip(&m.normal_indices) {
        let (v, n3) = (v as usize, n as usize * 3);
        let Some(c) = m.normals.get(n3..n3 + 3) else {
            return false;
        };
        match chosen.get(v) {
            Some(&u32::MAX) => {
                chosen[v] = n;
                out[start + v] = DVec3::new(c[0], c[1], c[2]);
            }
            Some(&prev) if prev == n => {}
            _ => return false,
        }
    }
    chosen.iter().all(|&n| n != u32::MAX)
}

/// The distinct `usemtl` names in first-use order, extracted exactly as tobj
/// does (everything after the first space, trimmed).
fn usemtl_names(bytes: &[u8]) -> Vec<String> {
    let mut names: Vec<String> = Vec::new();
    for line in bytes.split(|&c| c == b'\n') {
        let Ok(line) = std::str::from_utf8(line) else {
            continue;
        };
        if line.split_whitespace().next() != Some("usemtl") {
            continue;
        }
        let name = line.split_once(' ').unwrap_or_default().1.trim();
        if !name.is_empty() && !names.iter().any(|n| n == name) {
            names.push(name.to_owned());
        }
    }
    names
}

/// tobj reports an out-of-range face index without saying where; find the
/// first offending face with the same index rules (1-based, negative =
/// relative to the vertices declared so far, checked against all vertices).
fn locate_bad_index(bytes: &[u8]) -> IoError {
    let is = |line: &[u8], kw: &[u8]| {
        line.split(|c| c.is_ascii_whitespace())
            .find(|w| !w.is_empty())
            == Some(kw)
    };
    let total = bytes.split(|&c| c == b'\n').filter(|l| is(l, b"v")).count() as i64;
    let (mut declared, mut face) = (0i64, 0u64);
    for (number, line) in bytes.split(|&c| c == b'\n').enumerate() {
        if is(line, b"v") {
            declared += 1;
        } else if is(line, b"f") {
            let text = String::from_utf8_lossy(line);
            for word in text.split_whitespace().skip(1) {
                let first = word.split('/').next().unwrap_or("");
                let Ok(i) = first.parse::<i64>() else {
                    continue;
                };
                let index = if i < 0 { declared + i } else { i - 1 };
                if index < 0 || index >= total {
                    return IoError::ObjIndexOutOfRange {
                        line: number as u64 + 1,
                        face: face + 1,
                        index: i,
                        declared: declared as u64,
                        vertex_count: total as u64,
                    };
                }
            }
            face += 1;
        }
    }
    IoError::parse(Format::Obj, "a face refers to a vertex that does not exist")
}

pub(super) fn write(mesh: &TriMesh, normals: bool) -> Vec<u8> {
    let mut out = Vec::with_capacity(mesh.positions.len() * 60 + mesh.triangles.len() * 30);
    // Writing into a Vec cannot fail, so the results are ignored below.
    let _ = writeln!(
        out,
        "# isoremesh {}: {} vertices, {} triangles",
        env!("CARGO_PKG_VERSION"),
        mesh.positions.len(),
        mesh.triangles.len()
    );
    push_lines(&mut out, &mesh.positions, 64, |o, _, &p| {
        push_vec3_line(o, b"v ", p)
    });
    if normals {
        push_lines(&mut out, &mesh.normals, 64, |o, _, &n| {
            push_vec3_line(o, b"vn ", n)
        });
    }
    let names = label_names(mesh);
    if names.is_empty() {
        push_lines(&mut out, &mesh.triangles, 40, |o, _, t| {
            push_face_line(o, t, normals)
        });
    } else {
        let mut current = None;
        for (f, t) in mesh.triangles.iter().enumerate() {
            let l = mesh.face_label(f) as usize;
            if current != Some(l) {
                current = Some(l);
                let _ = writeln!(out, "usemtl {}", names[l]);
            }
            push_face_line(&mut out, t, normals);
        }
    }
    out
}

/// Appends `f a b c` (or `f a//a b//b c//c` with normals), 1-based.
fn push_face_line(out: &mut Vec<u8>, t: &[u32; 3], normals: bool) {
    out.extend_from_slice(b"f");
    for &v in t {
        let i = v as u64 + 1;
        out.push(b' ');
        push_u64(out, i);
        if normals {
            out.extend_from_slice(b"//");
            push_u64(out, i);
        }
    }
    out.push(b'\n');
}

/// One distinct, single-line `usemtl` name per label (the material name,
/// else the label name, else `label_<i>`); empty when the mesh carries no
/// labels.
fn label_names(mesh: &TriMesh) -> Vec<String> {
    if mesh.face_labels.is_empty() || mesh.labels.is_empty() {
        return Vec::new();
    }
    let mut names: Vec<String> = Vec::with_capacity(mesh.labels.len());
    for (i, l) in mesh.labels.iter().enumerate() {
        let raw = l
            .material
            .as_ref()
            .and_then(|m| m.name.clone())
            .or_else(|| l.name.clone())
            .unwrap_or_default();
        let mut name = raw.split_whitespace().collect::<Vec<_>>().join(" ");
        if name.is_empty() {
            name = format!("label_{i}");
        }
        while names.contains(&name) {
            name = format!("{name}_{i}");
        }
        names.push(name);
    }
    names
}
