//! Stanford PLY through `ply-rs-bw`: ASCII, binary little and big endian.
//! Reads the `vertex` element's `x y z` (any scalar type), `nx ny nz`,
//! texture coordinates (`s t`, `u v`, `texture_u texture_v`) and colour
//! (`red green blue [alpha]`, sRGB, stored linear as glTF's `COLOR_0`),
//! `face` lists named `vertex_indices` or `vertex_index` (any integer list
//! type, polygons triangulated by [`super::polygon`]) and `tristrips` lists (strips separated by
//! `-1`, as in the original Cyberware scans). Other elements and properties
//! are skipped. Writes doubles, `float s t`, `uchar red green blue
//! [alpha]` and `list uchar uint vertex_indices`.
//!
//! Element types implement `PropertyAccess` directly so that no per-property
//! map is built; face lists of `int`/`uint` are filled in place.

use std::io::Write;

use glam::DVec3;
use ply_rs_bw::parser::{Parser, Reader};
use ply_rs_bw::ply::{
    Addable, BeginList, ElementDef, Encoding, Header, PropertyAccess, PropertyAccessResult,
    PropertyDef, PropertyType, ScalarType,
};
use ply_rs_bw::writer::Writer;

use super::{Attributes, Format, Imported, IoError};
use crate::TriMesh;

/// A `vertex` element: position, optional normal, texture coordinates
/// (`s t`, `u v`, `texture_u texture_v` or `texture_s texture_t`) and colour
/// (`red green blue [alpha]`, integers scaled by their type's maximum).
struct PlyVertex {
    p: [f64; 3],
    n: [f64; 3],
    uv: [f32; 2],
    rgba: [f32; 4],
}

impl PlyVertex {
    fn set(&mut self, name: &str, v: f64) -> PropertyAccessResult {
        let slot = match name {
            "x" => &mut self.p[0],
            "y" => &mut self.p[1],
            "z" => &mut self.p[2],
            "nx" => &mut self.n[0],
            "ny" => &mut self.n[1],
            "nz" => &mut self.n[2],
            _ => return self.set_f32(name, v as f32, 1.0),
        };
        *slot = v;
        PropertyAccessResult::Set
    }

    /// Sets a texture coordinate or a colour channel; `max` is the value
    /// of full intensity for the property's type (1 for floats).
    fn set_f32(&mut self, name: &str, v: f32, max: f32) -> PropertyAccessResult {
        if let Some(k) = uv_axis(name) {
            self.uv[k] = v;
        } else if let Some(k) = COLOR_NAMES.iter().position(|c| *c == name) {
            self.rgba[k] = v / max;
        } else {
            return PropertyAccessResult::Ignored;
        }
        PropertyAccessResult::Set
    }
}

/// The texture coordinate property names, (u, v) pairs in order of preference.
const UV_NAMES: [[&str; 2]; 4] = [
    ["s", "t"],
    ["u", "v"],
    ["texture_u", "texture_v"],
    ["texture_s", "texture_t"],
];

/// The colour channel property names.
const COLOR_NAMES: [&str; 4] = ["red", "green", "blue", "alpha"];

fn uv_axis(name: &str) -> Option<usize> {
    UV_NAMES
        .iter()
        .find_map(|pair| pair.iter().position(|n| *n == name))
}

impl PropertyAccess for PlyVertex {
    fn new() -> Self {
        PlyVertex {
            p: [0.0; 3],
            n: [0.0; 3],
            uv: [0.0; 2],
            rgba: [1.0; 4],
        }
    }
    fn set_char(&mut self, name: &str, v: i8) -> PropertyAccessResult {
        self.set(name, f64::from(v))
    }
    fn set_uchar(&mut self, name: &str, v: u8) -> PropertyAccessResult {
        match self.set_f32(name, f32::from(v), 255.0) {
            PropertyAccessResult::Ignored => self.set(name, f64::from(v)),
            r => r,
        }
    }
    fn set_short(&mut self, name: &str, v: i16) -> PropertyAccessResult {
        self.set(name, f64::from(v))
    }
    fn set_ushort(&mut self, name: &str, v: u16) -> PropertyAccessResult {
        match self.set_f32(name, f32::from(v), 65535.0) {
            PropertyAccessResult::Ignored => self.set(name, f64::from(v)),
            r => r,
        }
    }
    fn set_int(&mut self, name: &str, v: i32) -> PropertyAccessResult {
        self.set(name, f64::from(v))
    }
    fn set_uint(&mut self, name: &str, v: u32) -> PropertyAccessResult {
        self.set(name, f64::from(v))
    }
    fn set_float(&mut self, name: &str, v: f32) -> PropertyAccessResult {
        self.set(name, f64::from(v))
    }
    fn set_double(&mut self, name: &str, v: f64) -> PropertyAccessResult {
        self.set(name, v)
    }
}

/// A `face` or `tristrips` element: its index list, signed so that strip
/// restarts (-1) and bad negative indices survive until they are checked.
struct PlyFace {
    ints: Vec<i32>,
    uints: Vec<u32>,
}

fn is_index_list(name: &str) -> bool {
    name == "vertex_indices" || name == "vertex_index"
}

impl PlyFace {
    fn corners(&self) -> impl Iterator<Item = i64> + '_ {
        self.ints
            .iter()
            .map(|&i| i64::from(i))
            .chain(self.uints.iter().map(|&i| i64::from(i)))
    }

    fn set_signed(&mut self, name: &str, v: impl Iterator<Item = i32>) -> PropertyAccessResult {
        if !is_index_list(name) {
            return PropertyAccessResult::Ignored;
        }
        self.ints.clear();
        self.ints.extend(v);
        PropertyAccessResult::Set
    }

    fn set_unsigned(&mut self, name: &str, v: impl Iterator<Item = u32>) -> PropertyAccessResult {
        if !is_index_list(name) {
            return PropertyAccessResult::Ignored;
        }
        self.uints.clear();
        self.uints.extend(v);
        PropertyAccessResult::Set
    }

    fn float_list(name: &str) -> PropertyAccessResult {
        if is_index_list(name) {
            PropertyAccessResult::UnsupportedType
        } else {
            PropertyAccessResult::Ignored
        }
    }
}

impl PropertyAccess for PlyFace {
    fn new() -> Self {
        PlyFace {
            ints: Vec::new(),
            uints: Vec::new(),
        }
    }
    fn begin_list_int(&mut self, name: &str, _len: usize) -> BeginList<'_, i32> {
        if is_index_list(name) {
            BeginList::Fill(&mut self.ints)
        } else {
            BeginList::UseSetter
        }
    }
    fn begin_list_uint(&mut self, name: &str, _len: usize) -> BeginList<'_, u32> {
        if is_index_list(name) {
            BeginList::Fill(&mut self.uints)
        } else {
            BeginList::UseSetter
        }
    }
    fn set_list_char(&mut self, name: &str, v: Vec<i8>) -> PropertyAccessResult {
        self.set_signed(name, v.into_iter().map(i32::from))
    }
    fn set_list_short(&mut self, name: &str, v: Vec<i16>) -> PropertyAccessResult {
        self.set_signed(name, v.into_iter().map(i32::from))
    }
    fn set_list_int(&mut self, name: &str, v: Vec<i32>) -> PropertyAccessResult {
        self.set_signed(name, v.into_iter())
    }
    fn set_list_uchar(&mut self, name: &str, v: Vec<u8>) -> PropertyAccessResult {
        self.set_unsigned(name, v.into_iter().map(u32::from))
    }
    fn set_list_ushort(&mut self, name: &str, v: Vec<u16>) -> PropertyAccessResult {
        self.set_unsigned(name, v.into_iter().map(u32::from))
    }
    fn set_list_uint(&mut self, name: &str, v: Vec<u32>) -> PropertyAccessResult {
        self.set_unsigned(name, v.into_iter())
    }
    fn set_list_float(&mut self, name: &str, _v: Vec<f32>) -> PropertyAccessResult {
        Self::float_list(name)
    }
    fn set_list_double(&mut self, name: &str, _v: Vec<f64>) -> PropertyAccessResult {
        Self::float_list(name)
    }
}

/// Any other element: every property is read and dropped.
struct Skipped;

impl PropertyAccess for Skipped {
    fn new() -> Self {
        Skipped
    }
}

fn ply_err(e: impl std::fmt::Display) -> IoError {
    IoError::parse(Format::Ply, e.to_string())
}

pub(super) fn read(bytes: &[u8]) -> Result<Imported, IoError> {
    if !bytes.starts_with(b"ply") {
        return Err(IoError::BadMagic {
            format: Format::Ply,
            expected: "\"ply\"",
        });
    }
    let mut reader = Reader::new(bytes);
    let header = Parser::<Skipped>::new()
        .read_header(&mut reader)
        .map_err(ply_err)?;
    // Each element occupies at least one byte (a line in ASCII, a scalar in
    // binary), so a count beyond the file size is a lie: refuse it before
    // the parser loops over it.
    for (name, def) in &header.elements {
        if def.count > bytes.len() {
            return Err(IoError::Truncated {
                format: Format::Ply,
                what: format!("element '{name}' with {} entries", def.count),
                needed: def.count as u64,
                available: bytes.len() as u64,
            });
        }
    }

    let mut vertices: Option<Vec<PlyVertex>> = None;
    let (mut has_normals, mut has_uv, mut has_color, mut has_alpha) = (false, false, false, false);
    let mut faces: Vec<PlyFace> = Vec::new();
    let mut strips: Vec<PlyFace> = Vec::new();
    for (name, def) in &header.elements {
        match name.as_str() {
            "vertex" if vertices.is_none() => {
                for axis in ["x", "y", "z"] {
                    if !matches!(
                        def.properties.get(axis).map(|p| &p.data_type),
                        Some(PropertyType::Scalar(_))
                    ) {
                        return Err(ply_err(format!(
                            "the vertex element has no scalar property '{axis}'"
                        )));
                    }
                }
                let scalar = |a: &str| {
                    matches!(
                        def.properties.get(a).map(|p| &p.data_type),
                        Some(PropertyType::Scalar(_))
                    )
                };
                has_normals = ["nx", "ny", "nz"].into_iter().all(scalar);
                has_uv = UV_NAMES.iter().any(|pair| pair.iter().all(|a| scalar(a)));
                has_color = COLOR_NAMES[..3].iter().copied().all(scalar);
                has_alpha = scalar("alpha");
                vertices = Some(
                    Parser::<PlyVertex>::new()
                        .read_payload_for_element(&mut reader, def, &header)
                        .map_err(ply_err)?,
                );
            }
            "face" | "tristrips" => {
                if !def.properties.keys().any(|k| is_index_list(k)) {
                    return Err(ply_err(format!(
                        "the {name} element has no 'vertex_indices' list"
                    )));
                }
                let list = Parser::<PlyFace>::new()
                    .read_payload_for_element(&mut reader, def, &header)
                    .map_err(ply_err)?;
                if name == "face" {
                    faces.extend(list);
                } else {
                    strips.extend(list);
                }
            }
            _ => {
                Parser::<Skipped>::new()
                    .read_payload_for_element(&mut reader, def, &header)
                    .map_err(ply_err)?;
            }
        }
    }

    let vertices = vertices.unwrap_or_default();
    let nv = vertices.len();
    super::vertex_index(nv)?;
    let mut mesh = TriMesh {
        positions: vertices.iter().map(|v| DVec3::from_array(v.p)).collect(),
        normals: if has_normals {
            vertices.iter().map(|v| DVec3::from_array(v.n)).collect()
        } else {
            Vec::new()
        },
        ..Default::default()
    };
    if has_uv {
        // PLY's v grows upwards, glTF's downwards.
        let uv = vertices.iter().map(|v| [v.uv[0], 1.0 - v.uv[1]]).collect();
        mesh.attributes.texcoords = vec![uv];
    }
    if has_color {
        let lin = crate::appearance::srgb_to_linear;
        mesh.attributes.colors = vertices
            .iter()
            .map(|v| [lin(v.rgba[0]), lin(v.rgba[1]), lin(v.rgba[2]), v.rgba[3]])
            .collect();
        mesh.attributes.color_alpha = has_alpha;
    }
    drop(vertices);
    let check = |face: u64, i: i64| -> Result<u32, IoError> {
        if i < 0 || i >= nv as i64 {
            return Err(IoError::IndexOutOfRange {
                face,
                index: i,
                vertex_count: nv as u64,
            });
        }
        Ok(i as u32)
    };
    let mut ignored = 0;
    mesh.triangles.reserve(faces.len());
    let mut corners: Vec<u32> = Vec::new();
    for (f, face) in faces.iter().enumerate() {
        corners.clear();
        for i in face.corners() {
            corners.push(check(f as u64, i)?);
        }
        if corners.len() < 3 {
            ignored += 1;
            continue;
        }
        super::polygon::triangulate(f as u64, &corners, &mut mesh.triangles)?;
    }
    for (s, strip) in strips.iter().enumerate() {
        let face = (faces.len() + s) as u64;
        let mut window: Vec<u32> = Vec::new();
        for i in strip.corners() {
            if i == -1 {
                window.clear();
                continue;
            }
            window.push(check(face, i)?);
            let k = window.len();
            if k >= 3 {
                let (x, y, z) = (window[k - 3], window[k - 2], window[k - 1]);
                // Strips alternate winding; zero-area joins are not faces.
                if x != y && y != z && x != z {
                    mesh.triangles
                        .push(if k % 2 == 1 { [x, y, z] } else { [y, x, z] });
                }
            }
        }
    }
    Ok(Imported {
        mesh,
        ignored_primitives: ignored,
    })
}

/// Output vertex: position, (possibly unused) normal and the values of
/// the extra float properties named in `names`.
struct OutVertex<'a> {
    p: DVec3,
    n: DVec3,
    /// Texture coordinates in PLY's convention (v upwards).
    uv: [f32; 2],
    /// sRGB colour and alpha, 0–255.
    rgba: [u8; 4],
    names: &'a [String],
    extra: Vec<f32>,
}

/// The value of the extra property `name`, if it is one.
fn extra_value(names: &[String], extra: &[f32], name: &str) -> Option<f32> {
    names.iter().position(|n| n == name).map(|k| extra[k])
}

impl PropertyAccess for OutVertex<'_> {
    fn new() -> Self {
        OutVertex {
            p: DVec3::ZERO,
            n: DVec3::ZERO,
            uv: [0.0; 2],
            rgba: [255; 4],
            names: &[],
            extra: Vec::new(),
        }
    }
    fn get_float(&self, name: &str) -> Option<f32> {
        match name {
            "s" => Some(self.uv[0]),
            "t" => Some(self.uv[1]),
            _ => extra_value(self.names, &self.extra, name),
        }
    }
    fn get_uchar(&self, name: &str) -> Option<u8> {
        COLOR_NAMES
            .iter()
            .position(|c| *c == name)
            .map(|k| self.rgba[k])
    }
    fn get_double(&self, name: &str) -> Option<f64> {
        Some(match name {
            "x" => self.p.x,
            "y" => self.p.y,
            "z" => self.p.z,
            "nx" => self.n.x,
            "ny" => self.n.y,
            "nz" => self.n.z,
            _ => return None,
        })
    }
}

/// Output face: one triangle and the values of its extra float properties.
struct OutFace<'a> {
    t: [u32; 3],
    names: &'a [String],
    extra: Vec<f32>,
}

impl PropertyAccess for OutFace<'_> {
    fn new() -> Self {
        OutFace {
            t: [0; 3],
            names: &[],
            extra: Vec::new(),
        }
    }
    fn get_list_uint(&self, name: &str) -> Option<&[u32]> {
        (name == "vertex_indices").then_some(&self.t[..])
    }
    fn get_float(&self, name: &str) -> Option<f32> {
        extra_value(self.names, &self.extra, name)
    }
}

/// Writes `mesh` as PLY, with `attrs` as extra float properties of the
/// `vertex` and `face` elements.
pub(super) fn write(
    mesh: &TriMesh,
    binary: bool,
    normals: bool,
    attrs: &Attributes,
) -> Result<Vec<u8>, IoError> {
    let mut header = Header::new();
    header.encoding = if binary {
        Encoding::BinaryLittleEndian
    } else {
        Encoding::Ascii
    };
    header
        .comments
        .push(format!("isoremesh {}", env!("CARGO_PKG_VERSION")));
    let mut vdef = ElementDef::new("vertex".to_string());
    vdef.count = mesh.positions.len();
    let mut names = vec!["x", "y", "z"];
    if normals {
        names.extend(["nx", "ny", "nz"]);
    }
    for n in names {
        vdef.properties.add(PropertyDef::new(
            n.to_string(),
            PropertyType::Scalar(ScalarType::Double),
        ));
    }
    let float =
        |name: &String| PropertyDef::new(name.clone(), PropertyType::Scalar(ScalarType::Float));
    let nv = mesh.positions.len();
    let uv = mesh
        .attributes
        .texcoords
        .first()
        .filter(|set| set.len() == nv);
    if uv.is_some() {
        for n in ["s", "t"] {
            vdef.properties.add(float(&n.to_string()));
        }
    }
    let colors = &mesh.attributes.colors;
    let channels = match (colors.len() == nv, mesh.attributes.color_alpha) {
        (false, _) => 0,
        (true, false) => 3,
        (true, true) => 4,
    };
    for n in &COLOR_NAMES[..channels] {
        vdef.properties.add(PropertyDef::new(
            n.to_string(),
            PropertyType::Scalar(ScalarType::UChar),
        ));
    }
    let vnames: Vec<String> = attrs.vertex.iter().map(|a| a.name.clone()).collect();
    vnames.iter().for_each(|n| vdef.properties.add(float(n)));
    let mut fdef = ElementDef::new("face".to_string());
    fdef.count = mesh.triangles.len();
    fdef.properties.add(PropertyDef::new(
        "vertex_indices".to_string(),
        PropertyType::List(ScalarType::UChar, ScalarType::UInt),
    ));
    let fnames: Vec<String> = attrs.face.iter().map(|a| a.name.clone()).collect();
    fnames.iter().for_each(|n| fdef.properties.add(float(n)));
    header.elements.add(vdef.clone());
    header.elements.add(fdef.clone());

    let verts: Vec<OutVertex> = mesh
        .positions
        .iter()
        .enumerate()
        .map(|(i, &p)| OutVertex {
            p,
            n: if normals {
                mesh.normals[i]
            } else {
                DVec3::ZERO
            },
            uv: uv.map_or([0.0; 2], |set| [set[i][0], 1.0 - set[i][1]]),
            rgba: if channels == 0 {
                [255; 4]
            } else {
                let c = colors[i];
                let byte = |x: f32| (x.clamp(0.0, 1.0) * 255.0).round() as u8;
                let srgb = crate::appearance::linear_to_srgb;
                [
                    byte(srgb(c[0])),
                    byte(srgb(c[1])),
                    byte(srgb(c[2])),
                    byte(c[3]),
                ]
            },
            names: &vnames,
            extra: attrs.vertex.iter().map(|a| a.values[i]).collect(),
        })
        .collect();
    let faces: Vec<OutFace> = mesh
        .triangles
        .iter()
        .enumerate()
        .map(|(f, &t)| OutFace {
            t,
            names: &fnames,
            extra: attrs.face.iter().map(|a| a.values[f]).collect(),
        })
        .collect();
    let bytes_per = if binary { 8 } else { 25 };
    let mut out = Vec::with_capacity(
        256 + verts.len() * bytes_per * if normals { 6 } else { 3 } + faces.len() * 16,
    );
    let w = |e: std::io::Error| IoError::parse(Format::Ply, format!("writing failed: {e}"));
    let vw = Writer::<OutVertex>::new();
    vw.write_header(&mut out, &header).map_err(w)?;
    vw.write_payload_of_element(&mut out, &verts, &vdef, &header)
        .map_err(w)?;
    Writer::<OutFace>::new()
        .write_payload_of_element(&mut out, &faces, &fdef, &header)
        .map_err(w)?;
    out.flush().map_err(w)?;
    Ok(out)
}
