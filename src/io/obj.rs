//! Wavefront OBJ through `tobj::load_obj_buf`, with polygons triangulated by
//! [`super::polygon`]. tobj runs with one index per corner, so a vertex
//! whose corners name different `vt` or `vn` arrives split, as in glTF; the
//! half-edge builder welds it and the split becomes an attribute seam.
//! `vt` becomes `TEXCOORD_0` (v flipped to glTF's convention), `v x y z r g
//! b` the colour (sRGB, stored linear), `vn` the normals.
//!
//! The material libraries named by `mtllib` are read from the companion
//! files the caller supplied ([`super::mtl`] maps them to glTF materials);
//! tobj itself never opens one: its loader returns name-only placeholders
//! for the `usemtl` names, so that each material becomes one face label
//! (material borders become features later). Groups and objects without
//! materials do not create labels.
//!
//! [`write_files`] writes the `.obj`, its `.mtl` and the texture images.

use std::cell::Cell;
use std::collections::HashMap;
use std::io::Write;
use std::path::Path;

use glam::DVec3;

use super::mtl::LookBuilder;
use super::text::{push_lines, push_u64, push_vec3_line};
use super::{Format, Imported, IoError, ReadOptions};
use crate::appearance::{linear_to_srgb, srgb_to_linear, DroppedAttribute};
use crate::scene::Part;
use crate::{Label, Material, TriMesh};

/// A name tobj is handed as the material library when the file uses
/// materials but declares none; the loader never resolves it.
const PLACEHOLDER_MTLLIB: &[u8] = b"mtllib isoremesh-materials-are-not-loaded\n";

pub(super) fn read(bytes: &[u8], opts: &ReadOptions) -> Result<Imported, IoError> {
    let names = usemtl_names(bytes);
    let uses_materials = !names.is_empty();
    let mut look = LookBuilder::default();
    let defined = libraries(bytes, &opts.external_buffers, &mut look.dropped)?;
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
    // One index per corner: a vertex whose corners name different `vt` or
    // `vn` is split, as glTF stores it; the half-edge builder welds it.
    let options = tobj::LoadOptions {
        single_index: true,
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
        Err(tobj::LoadError::FaceColorOutOfBounds) => {
            return Err(IoError::parse(
                Format::Obj,
                "some vertices have a colour (v x y z r g b) and others do not",
            ))
        }
        Err(
            e @ (tobj::LoadError::PositionParseError
            | tobj::LoadError::ColorParseError
            | tobj::LoadError::NormalParseError
            | tobj::LoadError::TexcoordParseError
            | tobj::LoadError::FaceParseError),
        ) => return Err(locate_bad_line(bytes, &e.to_string())),
        Err(e) => return Err(IoError::parse(Format::Obj, e.to_string())),
    };

    let mut mesh = TriMesh::default();
    // Parts: the distinct `o`/`g` names, in first-use order.
    let mut part_names: Vec<Option<String>> = Vec::new();
    let part_of: Vec<usize> = models
        .iter()
        .map(|model| {
            let name = (model.name != "unnamed_object").then(|| model.name.clone());
            match part_names.iter().position(|n| *n == name) {
                Some(p) => p,
                None => {
                    part_names.push(name);
                    part_names.len() - 1
                }
            }
        })
        .collect();
    let parted = part_names.len() > 1;
    let mut label_of: HashMap<(usize, Option<usize>), u32> = HashMap::new();
    let mut corners = CornerData::new(&models);
    // Faces counted from 0 in file order, for error messages.
    let mut polygons = 0u64;
    for (model, &part) in models.iter().zip(&part_of) {
        let m = &model.mesh;
        let part = if parted { part } else { 0 };
        let base = super::vertex_index(mesh.positions.len())?;
        let count = m.positions.len() / 3;
        super::vertex_index(mesh.positions.len() + count)?;
        mesh.positions.extend(
            m.positions
                .chunks_exact(3)
                .map(|c| DVec3::new(c[0], c[1], c[2])),
        );
        corners.append(m, count);
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
            let mut face: Vec<u32> = Vec::new();
            for &arity in &m.face_arities {
                let end = start + arity as usize;
                face.clear();
                let indices = m.indices.get(start..end).ok_or_else(|| {
                    IoError::parse(Format::Obj, "the parser returned inconsistent faces")
                })?;
                face.extend(indices.iter().map(|&i| i + base));
                super::polygon::triangulate(polygons, &face, &mut mesh.triangles)?;
                polygons += 1;
                start = end;
            }
        }
        if uses_materials || parted {
            let next = label_of.len() as u32;
            let label = *label_of.entry((part, m.material_id)).or_insert(next);
            if label == next {
                let name = m.material_id.and_then(|i| names.get(i)).cloned();
                let material = match &name {
                    Some(n) => Some(match defined.iter().find(|d| &d.name == n) {
                        Some(d) => look.material(d, &opts.external_buffers)?,
                        None => Material {
                            name: Some(n.clone()),
                            ..Default::default()
                        },
                    }),
                    None => None,
                };
                mesh.labels.push(Label {
                    name: name.clone(),
                    material,
                    part: parted.then_some(part as u32),
                    texcoord_sets: None,
                });
            }
            mesh.face_labels.resize(
                mesh.face_labels.len() + (mesh.triangles.len() - first_face),
                label,
            );
        }
    }
    corners.finish(&mut mesh);
    if parted || part_names.iter().any(Option::is_some) {
        mesh.scene = Some(std::sync::Arc::new(crate::scene::Scene {
            parts: part_names.into_iter().map(Part::named).collect(),
            gltf: None,
        }));
    }
    mesh.attributes.dropped.append(&mut look.dropped);
    mesh.appearance = look.finish().map(std::sync::Arc::new);
    Ok(Imported {
        mesh,
        ignored_primitives: 0,
    })
}

/// The per-vertex data beside the positions (`vt`, `vn`, vertex colours),
/// kept only when every vertex has it.
struct CornerData {
    texcoords: Option<Vec<[f32; 2]>>,
    normals: Option<Vec<DVec3>>,
    colors: Option<Vec<[f32; 4]>>,
    /// Why a kind of data present in the file was not kept.
    partial: Vec<DroppedAttribute>,
}

impl CornerData {
    fn new(models: &[tobj::Model]) -> Self {
        let any = |f: fn(&tobj::Mesh) -> bool| models.iter().any(|m| f(&m.mesh));
        Self {
            texcoords: any(|m| !m.texcoords.is_empty()).then(Vec::new),
            normals: any(|m| !m.normals.is_empty()).then(Vec::new),
            colors: any(|m| !m.vertex_color.is_empty()).then(Vec::new),
            partial: Vec::new(),
        }
    }

    /// Appends the data of one tobj model of `count` vertices. A model
    /// without texture coordinates gets (0, 0), as glTF pads; one where only
    /// some corners name a `vt` (or a `vn`) cannot be aligned, so that kind
    /// of data is dropped for the whole file.
    fn append(&mut self, m: &tobj::Mesh, count: usize) {
        if let Some(uv) = &mut self.texcoords {
            if m.texcoords.is_empty() {
                uv.resize(uv.len() + count, [0.0; 2]);
            } else if m.texcoords.len() == 2 * count {
                // OBJ's v grows upwards, glTF's downwards.
                uv.extend(
                    m.texcoords
                        .chunks_exact(2)
                        .map(|c| [c[0] as f32, 1.0 - c[1] as f32]),
                );
            } else {
                self.texcoords = None;
                self.partial.push(DroppedAttribute {
                    name: "TEXCOORD_0".into(),
                    reason: "some faces name texture coordinates (vt) and others do not".into(),
                });
            }
        }
        if let Some(n) = &mut self.normals {
            if m.normals.len() == 3 * count {
                n.extend(
                    m.normals
                        .chunks_exact(3)
                        .map(|c| DVec3::new(c[0], c[1], c[2])),
                );
            } else {
                // Normals are recomputed anyway; only `normals: transfer` needs them.
                self.normals = None;
            }
        }
        if let Some(c) = &mut self.colors {
            if m.vertex_color.len() == 3 * count {
                c.extend(m.vertex_color.chunks_exact(3).map(|c| {
                    let l = |x: f64| srgb_to_linear(x as f32);
                    [l(c[0]), l(c[1]), l(c[2]), 1.0]
                }));
            } else {
                self.colors = None;
                self.partial.push(DroppedAttribute {
                    name: "COLOR_0".into(),
                    reason: "some objects have vertex colours and others do not".into(),
                });
            }
        }
    }

    fn finish(self, mesh: &mut TriMesh) {
        if let Some(uv) = self.texcoords {
            mesh.attributes.texcoords = vec![uv];
        }
        if let Some(c) = self.colors {
            mesh.attributes.colors = c;
        }
        mesh.normals = self.normals.unwrap_or_default();
        mesh.attributes.dropped = self.partial;
    }
}

/// The `mtllib` names of an OBJ, in order: several on one line when every
/// word ends in `.mtl`, else the whole rest of the line as one name (a name
/// with spaces).
pub(crate) fn mtllib_names(bytes: &[u8]) -> Vec<String> {
    let mut out: Vec<String> = Vec::new();
    for line in bytes.split(|&c| c == b'\n') {
        let Ok(line) = std::str::from_utf8(line) else {
            continue;
        };
        let line = line.trim();
        let Some(rest) = line.strip_prefix("mtllib") else {
            continue;
        };
        if !rest.starts_with(char::is_whitespace) {
            continue;
        }
        let rest = rest.trim();
        let words: Vec<&str> = rest.split_whitespace().collect();
        let is_mtl = |w: &str| w.to_ascii_lowercase().ends_with(".mtl");
        let found: Vec<String> = if words.len() > 1 && words.iter().all(|w| is_mtl(w)) {
            words.iter().map(|w| w.to_string()).collect()
        } else if rest.is_empty() {
            Vec::new()
        } else {
            vec![rest.to_string()]
        };
        for n in found {
            if !out.contains(&n) {
                out.push(n);
            }
        }
    }
    out
}

/// The materials that the file's supplied material libraries define, in
/// library order (the first definition of a name wins). A library that was
/// not supplied is named in `dropped`.
fn libraries(
    bytes: &[u8],
    parts: &HashMap<String, Vec<u8>>,
    dropped: &mut Vec<DroppedAttribute>,
) -> Result<Vec<tobj::Material>, IoError> {
    let mut out: Vec<tobj::Material> = Vec::new();
    for name in mtllib_names(bytes) {
        match super::companions::find(parts, &name) {
            Some(lib) => {
                for m in super::mtl::parse(&name, lib)? {
                    if !out.iter().any(|o| o.name == m.name) {
                        out.push(m);
                    }
                }
            }
            None => dropped.push(DroppedAttribute {
                name: format!("material library {name}"),
                reason: "it was not supplied; material names are kept, their colours and textures are not".into(),
            }),
        }
    }
    Ok(out)
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

/// tobj reports a malformed `v`, `vt`, `vn` or `f` statement without
/// saying where: find the first one that breaks the rules tobj reads by
/// (`v`: 3, 4 or 6 numbers; `vn`: 3; `vt`: 1 to 3; `f`: at least one
/// corner, each `v`, `v/t`, `v//n` or `v/t/n` with integer indices) and
/// name its line, with an excerpt of it.
fn locate_bad_line(bytes: &[u8], what: &str) -> IoError {
    let numbers = |words: &[&str]| words.iter().all(|w| w.parse::<f64>().is_ok());
    let corner = |w: &str| {
        let parts: Vec<&str> = w.split('/').collect();
        parts.len() <= 3
            && parts[0].parse::<i64>().is_ok()
            && parts[1..]
                .iter()
                .all(|p| p.is_empty() || p.parse::<i64>().is_ok())
    };
    for (number, line) in bytes.split(|&c| c == b'\n').enumerate() {
        let text = String::from_utf8_lossy(line);
        let words: Vec<&str> = text.split_whitespace().collect();
        let Some((&kw, rest)) = words.split_first() else {
            continue;
        };
        let ok = match kw {
            "v" => matches!(rest.len(), 3 | 4 | 6) && numbers(rest),
            "vn" => rest.len() == 3 && numbers(rest),
            "vt" => (1..=3).contains(&rest.len()) && numbers(rest),
            "f" => !rest.is_empty() && rest.iter().all(|w| corner(w)),
            _ => true,
        };
        if !ok {
            let mut excerpt: String = text.trim().chars().take(60).collect();
            if text.trim().chars().count() > 60 {
                excerpt.push('…');
            }
            return IoError::parse(
                Format::Obj,
                format!("line {}: {what}: {excerpt:?}", number + 1),
            );
        }
    }
    IoError::parse(Format::Obj, what)
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

/// Writes `mesh` as OBJ: `v` (with an sRGB colour when the mesh has
/// one), `vt` for the first texture coordinate set, `vn` when `normals`,
/// `usemtl` per label, and `mtllib` naming `mtllib` when given.
pub(super) fn write(mesh: &TriMesh, normals: bool, mtllib: Option<&str>) -> Vec<u8> {
    let mut out = Vec::with_capacity(mesh.positions.len() * 60 + mesh.triangles.len() * 30);
    // Writing into a Vec cannot fail, so the results are ignored below.
    let _ = writeln!(
        out,
        "# isoremesh {}: {} vertices, {} triangles",
        env!("CARGO_PKG_VERSION"),
        mesh.positions.len(),
        mesh.triangles.len()
    );
    if let Some(lib) = mtllib {
        let _ = writeln!(out, "mtllib {lib}");
    }
    let colors = &mesh.attributes.colors;
    if colors.len() == mesh.positions.len() {
        push_lines(&mut out, &mesh.positions, 96, |o, i, &p| {
            push_vec3_line(o, b"v ", p);
            o.pop();
            for &c in &colors[i][..3] {
                o.push(b' ');
                push_f32(o, linear_to_srgb(c));
            }
            o.push(b'\n');
        });
    } else {
        push_lines(&mut out, &mesh.positions, 64, |o, _, &p| {
            push_vec3_line(o, b"v ", p)
        });
    }
    let uv = mesh
        .attributes
        .texcoords
        .first()
        .filter(|set| set.len() == mesh.positions.len());
    if let Some(set) = uv {
        push_lines(&mut out, set, 32, |o, _, t| {
            o.extend_from_slice(b"vt ");
            push_f32(o, t[0]);
            o.push(b' ');
            push_f32(o, 1.0 - t[1]);
            o.push(b'\n');
        });
    }
    if normals {
        push_lines(&mut out, &mesh.normals, 64, |o, _, &n| {
            push_vec3_line(o, b"vn ", n)
        });
    }
    let layout = (uv.is_some(), normals);
    let names = label_names(mesh);
    let objects = object_names(mesh);
    if names.is_empty() && objects.is_empty() {
        push_lines(&mut out, &mesh.triangles, 40, |o, _, t| {
            push_face_line(o, t, layout)
        });
    } else {
        let (mut label, mut object) = (None, None);
        for (f, t) in mesh.triangles.iter().enumerate() {
            let l = mesh.face_label(f) as usize;
            if let Some(name) = objects.get(l).filter(|_| object != Some(&objects[l])) {
                object = Some(name);
                let _ = writeln!(out, "o {name}");
                // A new object starts without a material in some readers.
                label = None;
            }
            if label != Some(l) && !names.is_empty() {
                label = Some(l);
                let _ = writeln!(out, "usemtl {}", names[l]);
            }
            push_face_line(&mut out, t, layout);
        }
    }
    out
}

/// Per label, the single-line `o` name of its part (`part_<i>` for an
/// unnamed one); empty when the mesh has no named or several parts.
fn object_names(mesh: &TriMesh) -> Vec<String> {
    let Some(scene) = mesh.scene.as_deref().filter(|s| s.is_structured()) else {
        return Vec::new();
    };
    (0..mesh.label_count())
        .map(|l| {
            let p = mesh.label_part(l).unwrap_or(0);
            let name = scene.parts.get(p).and_then(|part| part.name.as_deref());
            let clean = name
                .map(|n| n.split_whitespace().collect::<Vec<_>>().join(" "))
                .filter(|n| !n.is_empty());
            clean.unwrap_or_else(|| format!("part_{p}"))
        })
        .collect()
}

/// The files of a textured or materialled OBJ result: `stem.obj` naming
/// `stem.mtl`, the library, and the images of its textures, in that order.
/// A mesh without materials is the `.obj` alone.
pub(super) fn write_files(mesh: &TriMesh, normals: bool, stem: &str) -> Vec<(String, Vec<u8>)> {
    let names = label_names(mesh);
    let has_material = mesh.labels.iter().any(|l| l.material.is_some());
    if names.is_empty() || !has_material {
        return vec![(format!("{stem}.obj"), write(mesh, normals, None))];
    }
    let lib = format!("{stem}.mtl");
    let images: Vec<String> = mesh
        .appearance
        .as_deref()
        .map(|a| super::mtl::image_file_names(a, stem))
        .unwrap_or_default();
    let mut files = vec![
        (format!("{stem}.obj"), write(mesh, normals, Some(&lib))),
        (lib, super::mtl::write(mesh, &names, &images)),
    ];
    if let Some(look) = mesh.appearance.as_deref() {
        for (name, img) in images.into_iter().zip(&look.images) {
            files.push((name, img.bytes.clone()));
        }
    }
    files
}

/// Appends a float in its shortest round-trip form.
fn push_f32(out: &mut Vec<u8>, x: f32) {
    let mut buf = ryu::Buffer::new();
    out.extend_from_slice(buf.format(x).as_bytes());
}

/// Appends `f a b c`, with `/t` and `/n` (or `//n`) parts as `layout`
/// (texture coordinates, normals) says; every part uses the vertex's own
/// 1-based index, since the writer's vertices carry one value of each.
fn push_face_line(out: &mut Vec<u8>, t: &[u32; 3], layout: (bool, bool)) {
    out.extend_from_slice(b"f");
    for &v in t {
        let i = v as u64 + 1;
        out.push(b' ');
        push_u64(out, i);
        match layout {
            (false, false) => {}
            (true, false) => {
                out.push(b'/');
                push_u64(out, i);
            }
            (false, true) => {
                out.extend_from_slice(b"//");
                push_u64(out, i);
            }
            (true, true) => {
                out.push(b'/');
                push_u64(out, i);
                out.push(b'/');
                push_u64(out, i);
            }
        }
    }
    out.push(b'\n');
}

/// One distinct, single-line `usemtl` name per label (the material name,
/// else the label name, else `label_<i>`); empty when the mesh carries no
/// labels.
fn label_names(mesh: &TriMesh) -> Vec<String> {
    // Without per-face labels every face has label 0; a lone label is
    // named only when it carries a material.
    let lone = mesh.face_labels.is_empty();
    if mesh.labels.is_empty() || (lone && mesh.labels[0].material.is_none()) {
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
