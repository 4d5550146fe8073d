//! Writing a mesh as glTF or GLB: one vertex array, one index accessor per
//! label (one primitive per material), materials, and the GLB container.

use std::collections::BTreeMap;

use ::gltf::json;
use base64::Engine;
use glam::DVec3;
use json::accessor::{ComponentType, GenericComponentType, Type};
use json::mesh::{Mode, Semantic};
use json::validation::{Checked, USize64};

use super::super::{Attribute, Format, IoError};
use super::*;
use crate::{Material, TriMesh};

pub(crate) fn buffer_view(
    root: &mut json::Root,
    offset: usize,
    length: usize,
    target: json::buffer::Target,
) -> json::Index<json::buffer::View> {
    root.push(json::buffer::View {
        buffer: json::Index::new(0),
        byte_length: USize64::from(length),
        byte_offset: Some(USize64::from(offset)),
        byte_stride: None,
        name: None,
        target: Some(Checked::Valid(target)),
        extensions: None,
        extras: Default::default(),
    })
}

#[allow(clippy::too_many_arguments)]
pub(crate) fn accessor(
    root: &mut json::Root,
    view: json::Index<json::buffer::View>,
    offset: usize,
    count: usize,
    component: ComponentType,
    type_: Type,
    min: Option<serde_json::Value>,
    max: Option<serde_json::Value>,
) -> json::Index<json::Accessor> {
    root.push(json::Accessor {
        buffer_view: Some(view),
        byte_offset: Some(USize64::from(offset)),
        count: USize64::from(count),
        component_type: Checked::Valid(GenericComponentType(component)),
        extensions: None,
        extras: Default::default(),
        type_: Checked::Valid(type_),
        min,
        max,
        name: None,
        normalized: false,
        sparse: None,
    })
}

pub(crate) fn to_json_material(m: &Material) -> (json::Material, bool) {
    // Emissive factors above 1 are stored as a strength, as glTF requires
    // the factor itself to stay within [0, 1].
    let peak = m.emissive_factor.iter().copied().fold(0.0f32, f32::max);
    let strength = (peak > 1.0).then_some(peak);
    let emissive = match strength {
        Some(s) => m.emissive_factor.map(|c| c / s),
        None => m.emissive_factor,
    };
    let material = json::Material {
        name: m.name.clone(),
        double_sided: m.double_sided,
        emissive_factor: json::material::EmissiveFactor(emissive),
        pbr_metallic_roughness: json::material::PbrMetallicRoughness {
            base_color_factor: json::material::PbrBaseColorFactor(m.base_color_factor),
            metallic_factor: json::material::StrengthFactor(m.metallic_factor),
            roughness_factor: json::material::StrengthFactor(m.roughness_factor),
            ..Default::default()
        },
        extensions: strength.map(|s| json::extensions::material::Material {
            emissive_strength: Some(json::extensions::material::EmissiveStrength {
                emissive_strength: json::extensions::material::EmissiveStrengthFactor(s),
            }),
        }),
        ..Default::default()
    };
    (material, strength.is_some())
}

/// Writes `mesh` as glTF or GLB; `extra` are per-vertex float attributes
/// with their glTF names (`_NAME`), added to every primitive.
pub(in crate::io) fn write(
    mesh: &TriMesh,
    format: Format,
    normals: bool,
    extra: &[Attribute],
    tangents: Option<&[[f32; 4]]>,
) -> Result<Vec<u8>, IoError> {
    let nv = mesh.positions.len();
    let f32s = |v: DVec3| [v.x as f32, v.y as f32, v.z as f32];
    let positions: Vec<[f32; 3]> = mesh.positions.iter().map(|&p| f32s(p)).collect();
    if let Some(v) = positions
        .iter()
        .position(|p| !p.iter().all(|c| c.is_finite()))
    {
        // Finite in f64 but beyond the f32 range that glTF stores.
        return Err(IoError::NonFinite { vertex: v as u64 });
    }
    let (mut lo, mut hi) = ([f32::INFINITY; 3], [f32::NEG_INFINITY; 3]);
    for p in &positions {
        for k in 0..3 {
            lo[k] = lo[k].min(p[k]);
            hi[k] = hi[k].max(p[k]);
        }
    }

    // Faces grouped by label (stable within a label), one primitive each.
    let nl = mesh.label_count();
    let mut per_label: Vec<Vec<u32>> = vec![Vec::new(); nl];
    for (f, t) in mesh.triangles.iter().enumerate() {
        per_label[mesh.face_label(f) as usize].extend_from_slice(t);
    }

    let mut bin: Vec<u8> =
        Vec::with_capacity(nv * if normals { 24 } else { 12 } + mesh.triangles.len() * 12);
    for p in &positions {
        p.iter()
            .for_each(|c| bin.extend_from_slice(&c.to_le_bytes()));
    }
    let normals_at = bin.len();
    if normals {
        for &n in &mesh.normals {
            f32s(n.normalize_or_zero())
                .iter()
                .for_each(|c| bin.extend_from_slice(&c.to_le_bytes()));
        }
    }
    let indices_at = bin.len();
    for list in &per_label {
        list.iter()
            .for_each(|i| bin.extend_from_slice(&i.to_le_bytes()));
    }
    let extra_at = bin.len();
    for a in extra {
        a.values
            .iter()
            .for_each(|x| bin.extend_from_slice(&x.to_le_bytes()));
    }
    // Texture coordinate sets, then the colour (vec3, or vec4 with alpha).
    let attrs = &mesh.attributes;
    let mut channel_at = Vec::new();
    for set in &attrs.texcoords {
        channel_at.push(bin.len());
        set.iter()
            .flatten()
            .for_each(|x| bin.extend_from_slice(&x.to_le_bytes()));
    }
    let color_at = bin.len();
    let color_width = if attrs.color_alpha { 4 } else { 3 };
    for c in &attrs.colors {
        c[..color_width]
            .iter()
            .for_each(|x| bin.extend_from_slice(&x.to_le_bytes()));
    }
    let tangent_at = bin.len();
    for t in tangents.unwrap_or_default() {
        t.iter()
            .for_each(|x| bin.extend_from_slice(&x.to_le_bytes()));
    }
    // Images go into the binary chunk of a GLB, 4-byte aligned.
    let look = mesh.appearance.as_deref().filter(|a| !a.is_empty());
    let mut image_spans = Vec::new();
    if let (Some(look), Format::Glb) = (look, format) {
        for img in &look.images {
            bin.resize(bin.len().next_multiple_of(4), 0);
            image_spans.push((bin.len(), img.bytes.len()));
            bin.extend_from_slice(&img.bytes);
        }
    }

    let mut root = json::Root {
        asset: json::Asset {
            version: "2.0".to_string(),
            generator: Some(format!("isoremesh {}", env!("CARGO_PKG_VERSION"))),
            copyright: None,
            min_version: None,
            extensions: None,
            extras: Default::default(),
        },
        ..Default::default()
    };
    let uri = (format == Format::Gltf).then(|| {
        format!(
            "data:application/octet-stream;base64,{}",
            base64::engine::general_purpose::STANDARD.encode(&bin)
        )
    });
    root.push(json::Buffer {
        byte_length: USize64::from(bin.len()),
        name: None,
        uri,
        extensions: None,
        extras: Default::default(),
    });
    use json::buffer::Target;
    let pos_view = buffer_view(&mut root, 0, normals_at, Target::ArrayBuffer);
    let pos_acc = accessor(
        &mut root,
        pos_view,
        0,
        nv,
        ComponentType::F32,
        Type::Vec3,
        Some(serde_json::json!(lo)),
        Some(serde_json::json!(hi)),
    );
    let mut attributes = BTreeMap::new();
    attributes.insert(Checked::Valid(Semantic::Positions), pos_acc);
    if normals {
        let view = buffer_view(
            &mut root,
            normals_at,
            indices_at - normals_at,
            Target::ArrayBuffer,
        );
        let acc = accessor(
            &mut root,
            view,
            0,
            nv,
            ComponentType::F32,
            Type::Vec3,
            None,
            None,
        );
        attributes.insert(Checked::Valid(Semantic::Normals), acc);
    }
    let index_view = buffer_view(
        &mut root,
        indices_at,
        extra_at - indices_at,
        Target::ElementArrayBuffer,
    );
    // Custom attributes: gltf-json only names them with its `extras`
    // feature, so they are added to the primitives' JSON below.
    let mut extra_accessors = Vec::with_capacity(extra.len());
    let mut at = extra_at;
    for a in extra {
        let len = a.values.len() * 4;
        let view = buffer_view(&mut root, at, len, Target::ArrayBuffer);
        let acc = accessor(
            &mut root,
            view,
            0,
            a.values.len(),
            ComponentType::F32,
            Type::Scalar,
            None,
            None,
        );
        extra_accessors.push((a.name.clone(), acc.value()));
        at += len;
    }

    let channel_end = channel_at
        .iter()
        .skip(1)
        .copied()
        .chain([color_at])
        .collect::<Vec<_>>();
    for (k, (&at, &end)) in channel_at.iter().zip(&channel_end).enumerate() {
        let view = buffer_view(&mut root, at, end - at, Target::ArrayBuffer);
        let acc = accessor(
            &mut root,
            view,
            0,
            nv,
            ComponentType::F32,
            Type::Vec2,
            None,
            None,
        );
        attributes.insert(Checked::Valid(Semantic::TexCoords(k as u32)), acc);
    }
    if !attrs.colors.is_empty() {
        let len = attrs.colors.len() * color_width * 4;
        let view = buffer_view(&mut root, color_at, len, Target::ArrayBuffer);
        let acc = accessor(
            &mut root,
            view,
            0,
            nv,
            ComponentType::F32,
            if attrs.color_alpha {
                Type::Vec4
            } else {
                Type::Vec3
            },
            None,
            None,
        );
        attributes.insert(Checked::Valid(Semantic::Colors(0)), acc);
    }
    if let Some(t) = tangents {
        let view = buffer_view(&mut root, tangent_at, t.len() * 16, Target::ArrayBuffer);
        let acc = accessor(
            &mut root,
            view,
            0,
            nv,
            ComponentType::F32,
            Type::Vec4,
            None,
            None,
        );
        attributes.insert(Checked::Valid(Semantic::Tangents), acc);
    }
    let image_views: Vec<usize> = image_spans
        .iter()
        .map(|&(at, len)| {
            root.push(json::buffer::View {
                buffer: json::Index::new(0),
                byte_length: USize64::from(len),
                byte_offset: Some(USize64::from(at)),
                byte_stride: None,
                name: None,
                target: None,
                extensions: None,
                extras: Default::default(),
            })
            .value()
        })
        .collect();
    // (material index, verbatim JSON) of the materials written as read.
    let mut verbatim = Vec::new();
    let mut primitives = Vec::new();
    let mut offset = 0;
    let mut uses_strength = false;
    for (l, list) in per_label.iter().enumerate() {
        if list.is_empty() {
            continue;
        }
        let indices = accessor(
            &mut root,
            index_view,
            offset,
            list.len(),
            ComponentType::U32,
            Type::Scalar,
            None,
            None,
        );
        offset += list.len() * 4;
        let material = match mesh.labels.get(l).and_then(|lab| lab.material.as_ref()) {
            Some(m) => {
                let (jm, strength) = to_json_material(m);
                uses_strength |= strength;
                let index = root.push(jm);
                if let Some(raw) = &m.gltf {
                    verbatim.push((index.value(), raw.clone()));
                }
                Some(index)
            }
            None => None,
        };
        primitives.push(json::mesh::Primitive {
            attributes: attributes.clone(),
            extensions: None,
            extras: Default::default(),
            indices: Some(indices),
            material,
            mode: Checked::Valid(Mode::Triangles),
            targets: None,
        });
    }
    if uses_strength {
        root.extensions_used
            .push("KHR_materials_emissive_strength".to_string());
    }
    let mesh_index = root.push(json::Mesh {
        extensions: None,
        extras: Default::default(),
        name: Some("isoremesh".to_string()),
        primitives,
        weights: None,
    });
    let node = root.push(json::Node {
        mesh: Some(mesh_index),
        ..Default::default()
    });
    let scene = root.push(json::Scene {
        extensions: None,
        extras: Default::default(),
        name: None,
        nodes: vec![node],
    });
    root.scene = Some(scene);

    let ser =
        |e: serde_json::Error| IoError::parse(format, format!("serializing the JSON failed: {e}"));
    let json_text = if extra_accessors.is_empty() && verbatim.is_empty() && look.is_none() {
        serde_json::to_vec(&root).map_err(ser)?
    } else {
        let mut doc = serde_json::to_value(&root).map_err(ser)?;
        if let Some(prims) = doc["meshes"][0]["primitives"].as_array_mut() {
            for p in prims {
                for (name, acc) in &extra_accessors {
                    p["attributes"][name] = serde_json::json!(acc);
                }
            }
        }
        for (i, raw) in verbatim {
            doc["materials"][i] = raw;
        }
        if let Some(look) = look {
            let views = (format == Format::Glb).then_some(image_views.as_slice());
            look::write_look(&mut doc, look, views);
        }
        serde_json::to_vec(&doc).map_err(ser)?
    };
    if format == Format::Gltf {
        return Ok(json_text);
    }
    glb_container(json_text, bin)
}

/// Wraps JSON and binary data in a GLB container (header, JSON chunk padded
/// with spaces, BIN chunk padded with zeros).
pub(crate) fn glb_container(mut json_text: Vec<u8>, mut bin: Vec<u8>) -> Result<Vec<u8>, IoError> {
    while json_text.len() % 4 != 0 {
        json_text.push(b' ');
    }
    while bin.len() % 4 != 0 {
        bin.push(0);
    }
    let total = 12 + 8 + json_text.len() + 8 + bin.len();
    let too_large = || IoError::TooLarge {
        message: "the GLB would exceed 4 GiB".to_string(),
    };
    let total32 = u32::try_from(total).map_err(|_| too_large())?;
    let mut out = Vec::with_capacity(total);
    out.extend_from_slice(GLB_MAGIC);
    out.extend_from_slice(&2u32.to_le_bytes());
    out.extend_from_slice(&total32.to_le_bytes());
    out.extend_from_slice(&(json_text.len() as u32).to_le_bytes());
    out.extend_from_slice(&CHUNK_JSON.to_le_bytes());
    out.extend_from_slice(&json_text);
    out.extend_from_slice(&(bin.len() as u32).to_le_bytes());
    out.extend_from_slice(&CHUNK_BIN.to_le_bytes());
    out.extend_from_slice(&bin);
    Ok(out)
}
