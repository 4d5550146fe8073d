//! Writing a mesh as glTF or GLB: one primitive per label (per material),
//! each with its own vertex range and accessors, materials, and the GLB
//! container.

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
/// with their glTF names (`_NAME`), and `tangents` one `TANGENT` per
/// vertex. One primitive per label, each over its own vertex range
/// ([`super::primitives`]) with its own accessors and bounds.
pub(in crate::io) fn write(
    mesh: &TriMesh,
    format: Format,
    normals: bool,
    extra: &[Attribute],
    tangents: Option<&[[f32; 4]]>,
) -> Result<Vec<u8>, IoError> {
    let mut grouped = super::primitives::by_label(mesh, extra, tangents);
    let label_parts = super::scene::label_parts(&grouped.mesh);
    super::scene::localize(
        &mut grouped.mesh,
        grouped.tangents.as_mut(),
        &grouped.ranges,
        &label_parts,
    );
    let (mesh, extra, tangents) = (
        &grouped.mesh,
        &grouped.extra[..],
        grouped.tangents.as_deref(),
    );
    let f32s = |v: DVec3| [v.x as f32, v.y as f32, v.z as f32];
    let positions: Vec<[f32; 3]> = mesh.positions.iter().map(|&p| f32s(p)).collect();
    if let Some(v) = positions
        .iter()
        .position(|p| !p.iter().all(|c| c.is_finite()))
    {
        // Finite in f64 but beyond the f32 range that glTF stores.
        return Err(IoError::NonFinite { vertex: v as u64 });
    }

    // The arrays, one after another in the buffer; each primitive's
    // accessors view its own range of each.
    let mut bin: Vec<u8> = Vec::with_capacity(
        positions.len() * if normals { 24 } else { 12 } + mesh.triangles.len() * 12,
    );
    let push = |bin: &mut Vec<u8>, xs: &mut dyn Iterator<Item = f32>| -> (usize, usize) {
        let at = bin.len();
        xs.for_each(|x| bin.extend_from_slice(&x.to_le_bytes()));
        (at, bin.len() - at)
    };
    let pos_span = push(&mut bin, &mut positions.iter().flatten().copied());
    let normal_span = normals.then(|| {
        push(
            &mut bin,
            &mut mesh
                .normals
                .iter()
                .flat_map(|&n| f32s(n.normalize_or_zero())),
        )
    });
    let index_at = bin.len();
    for (vr, fr) in &grouped.ranges {
        for t in &mesh.triangles[fr.clone()] {
            for &i in t {
                bin.extend_from_slice(&(i - vr.start as u32).to_le_bytes());
            }
        }
    }
    let index_span = (index_at, bin.len() - index_at);
    let extra_spans: Vec<(usize, usize)> = extra
        .iter()
        .map(|a| push(&mut bin, &mut a.values.iter().copied()))
        .collect();
    let attrs = &mesh.attributes;
    let uv_spans: Vec<(usize, usize)> = attrs
        .texcoords
        .iter()
        .map(|set| push(&mut bin, &mut set.iter().flatten().copied()))
        .collect();
    // The colour is vec3, or vec4 with alpha.
    let color_width = if attrs.color_alpha { 4 } else { 3 };
    let color_span = (!attrs.colors.is_empty()).then(|| {
        push(
            &mut bin,
            &mut attrs.colors.iter().flat_map(|c| c[..color_width].to_vec()),
        )
    });
    let tangent_span = tangents.map(|t| push(&mut bin, &mut t.iter().flatten().copied()));
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
    let view = |root: &mut json::Root, (at, len): (usize, usize), target| {
        buffer_view(root, at, len, target)
    };
    let pos_view = view(&mut root, pos_span, Target::ArrayBuffer);
    let normal_view = normal_span.map(|s| view(&mut root, s, Target::ArrayBuffer));
    let index_view = view(&mut root, index_span, Target::ElementArrayBuffer);
    let extra_views: Vec<_> = extra_spans
        .iter()
        .map(|&s| view(&mut root, s, Target::ArrayBuffer))
        .collect();
    let uv_views: Vec<_> = uv_spans
        .iter()
        .map(|&s| view(&mut root, s, Target::ArrayBuffer))
        .collect();
    let color_view = color_span.map(|s| view(&mut root, s, Target::ArrayBuffer));
    let tangent_view = tangent_span.map(|s| view(&mut root, s, Target::ArrayBuffer));
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
    let mut primitive_parts = Vec::new();
    // Per primitive, its custom attributes: gltf-json only names them with
    // its `extras` feature, so they are added to the JSON below.
    let mut extra_accessors: Vec<Vec<(String, usize)>> = Vec::new();
    let mut index_offset = 0;
    let mut uses_strength = false;
    for (l, (vr, fr)) in grouped.ranges.iter().enumerate() {
        if fr.is_empty() {
            continue;
        }
        let (v0, n) = (vr.start, vr.len());
        let (mut lo, mut hi) = ([f32::INFINITY; 3], [f32::NEG_INFINITY; 3]);
        for p in &positions[vr.clone()] {
            for k in 0..3 {
                lo[k] = lo[k].min(p[k]);
                hi[k] = hi[k].max(p[k]);
            }
        }
        let acc = |root: &mut json::Root, v, width: usize, ty, bounds: Option<(_, _)>| {
            let (min, max) = bounds.unzip();
            accessor(root, v, v0 * width * 4, n, ComponentType::F32, ty, min, max)
        };
        let mut attributes = BTreeMap::new();
        let bounds = Some((serde_json::json!(lo), serde_json::json!(hi)));
        let p = acc(&mut root, pos_view, 3, Type::Vec3, bounds);
        attributes.insert(Checked::Valid(Semantic::Positions), p);
        if let Some(v) = normal_view {
            let a = acc(&mut root, v, 3, Type::Vec3, None);
            attributes.insert(Checked::Valid(Semantic::Normals), a);
        }
        let sets = mesh
            .labels
            .get(l)
            .and_then(|label| label.texcoord_sets)
            .map_or(uv_views.len(), |s| s as usize);
        for (k, &v) in uv_views.iter().enumerate().take(sets) {
            let a = acc(&mut root, v, 2, Type::Vec2, None);
            attributes.insert(Checked::Valid(Semantic::TexCoords(k as u32)), a);
        }
        if let Some(v) = color_view {
            let ty = if attrs.color_alpha {
                Type::Vec4
            } else {
                Type::Vec3
            };
            let a = acc(&mut root, v, color_width, ty, None);
            attributes.insert(Checked::Valid(Semantic::Colors(0)), a);
        }
        if let Some(v) = tangent_view {
            let a = acc(&mut root, v, 4, Type::Vec4, None);
            attributes.insert(Checked::Valid(Semantic::Tangents), a);
        }
        let custom = extra
            .iter()
            .zip(&extra_views)
            .map(|(x, &v)| {
                (
                    x.name.clone(),
                    acc(&mut root, v, 1, Type::Scalar, None).value(),
                )
            })
            .collect();
        extra_accessors.push(custom);
        let corners = fr.len() * 3;
        let indices = accessor(
            &mut root,
            index_view,
            index_offset,
            corners,
            ComponentType::U32,
            Type::Scalar,
            None,
            None,
        );
        index_offset += corners * 4;
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
        primitive_parts.push(label_parts[l]);
        primitives.push(json::mesh::Primitive {
            attributes,
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
    // One mesh per part (a single mesh without a scene), its primitives
    // in write order; `at` is each primitive's (mesh, position).
    let scene = mesh.scene.as_deref();
    let plans = match scene {
        Some(sc) => super::scene::plan(&primitive_parts, sc.parts.len()),
        None => vec![super::scene::MeshPlan {
            part: None,
            primitives: (0..primitives.len()).collect(),
        }],
    };
    let mut at = vec![(0, 0); primitives.len()];
    let mut slots: Vec<Option<json::mesh::Primitive>> = primitives.into_iter().map(Some).collect();
    for (m, plan) in plans.iter().enumerate() {
        let prims = plan
            .primitives
            .iter()
            .enumerate()
            .filter_map(|(k, &i)| {
                at[i] = (m, k);
                slots[i].take()
            })
            .collect();
        root.push(json::Mesh {
            extensions: None,
            extras: Default::default(),
            name: Some("isoremesh".to_string()),
            primitives: prims,
            weights: None,
        });
    }
    if scene.is_none() {
        let node = root.push(json::Node {
            mesh: Some(json::Index::new(0)),
            ..Default::default()
        });
        let scene = root.push(json::Scene {
            extensions: None,
            extras: Default::default(),
            name: None,
            nodes: vec![node],
        });
        root.scene = Some(scene);
    }

    let ser =
        |e: serde_json::Error| IoError::parse(format, format!("serializing the JSON failed: {e}"));
    let plain = extra.is_empty() && verbatim.is_empty() && look.is_none() && scene.is_none();
    let json_text = if plain {
        serde_json::to_vec(&root).map_err(ser)?
    } else {
        let mut doc = serde_json::to_value(&root).map_err(ser)?;
        for (i, custom) in extra_accessors.iter().enumerate() {
            let (m, k) = at[i];
            let p = &mut doc["meshes"][m]["primitives"][k];
            for (name, acc) in custom {
                p["attributes"][name] = serde_json::json!(acc);
            }
        }
        if scene.is_some() {
            super::scene::write_graph(&mut doc, scene, &plans);
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
