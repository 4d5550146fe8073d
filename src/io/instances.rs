//! Instancing for formats without it: a glTF mesh that several nodes use
//! is one part of the result (see [`crate::scene`]), written once in glTF
//! and GLB. OBJ, STL, PLY and OFF have no nodes, so each further node gets
//! its own copy of the part's faces, moved from the first node's place to
//! its own, as the input showed them.

use std::borrow::Cow;

use glam::{DMat3, DMat4};

use super::{Attribute, Attributes, IoError};
use crate::remesh::DEFAULT_MAX_OUTPUT_FACES;
use crate::TriMesh;

/// The mesh with one copy of each instanced part per further node, and
/// the attributes to match; borrowed unchanged when nothing is instanced.
/// Fails when the copies would exceed [`DEFAULT_MAX_OUTPUT_FACES`].
pub(super) fn expand<'a>(
    mesh: &'a TriMesh,
    attrs: &'a Attributes,
) -> Result<(Cow<'a, TriMesh>, Cow<'a, Attributes>), IoError> {
    let Some(scene) = mesh.scene.as_deref().filter(|s| s.has_instances()) else {
        return Ok((Cow::Borrowed(mesh), Cow::Borrowed(attrs)));
    };
    let mut faces_of: Vec<Vec<u32>> = vec![Vec::new(); scene.parts.len()];
    for f in 0..mesh.triangles.len() {
        if let Some(p) = mesh.label_part(mesh.face_label(f) as usize) {
            faces_of[p].push(f as u32);
        }
    }
    let total: u64 = mesh.triangles.len() as u64
        + scene
            .parts
            .iter()
            .zip(&faces_of)
            .map(|(p, f)| (p.instances.len() * f.len()) as u64)
            .sum::<u64>();
    if total > DEFAULT_MAX_OUTPUT_FACES {
        return Err(IoError::TooLarge {
            message: format!(
                "its instanced meshes expand to {total} triangles in a format without \
                 instancing; write glTF or GLB, which keeps the instances"
            ),
        });
    }
    let mut out = mesh.clone();
    let mut out_attrs = attrs.clone();
    let mut origin: Vec<u32> = (0..mesh.positions.len() as u32).collect();
    let mut face_origin: Vec<u32> = (0..mesh.triangles.len() as u32).collect();
    for (part, faces) in scene.parts.iter().zip(&faces_of) {
        if faces.is_empty() {
            continue;
        }
        let first_inverse = DMat4::from_cols_array(&part.world).inverse();
        for other in &part.instances {
            let m = DMat4::from_cols_array(other) * first_inverse;
            let normal = DMat3::from_mat4(m).inverse().transpose();
            let flip = m.determinant() < 0.0;
            // The copy's vertex of each original vertex, made on first use.
            let mut copy = std::collections::HashMap::new();
            for &f in faces {
                let t = mesh.triangles[f as usize].map(|v| {
                    *copy.entry(v).or_insert_with(|| {
                        let i = out.positions.len() as u32;
                        out.positions
                            .push(m.transform_point3(mesh.positions[v as usize]));
                        if !mesh.normals.is_empty() {
                            out.normals
                                .push((normal * mesh.normals[v as usize]).normalize_or_zero());
                        }
                        origin.push(v);
                        i
                    })
                });
                out.triangles
                    .push(if flip { [t[0], t[2], t[1]] } else { t });
                if !out.face_labels.is_empty() {
                    out.face_labels.push(mesh.face_labels[f as usize]);
                }
                face_origin.push(f);
            }
        }
    }
    let copied = &origin[mesh.positions.len()..];
    let tail = mesh.attributes.select(copied);
    for (set, extra) in out.attributes.texcoords.iter_mut().zip(tail.texcoords) {
        set.extend(extra);
    }
    out.attributes.colors.extend(tail.colors);
    let pick = |a: &Attribute, from: &[u32]| Attribute {
        name: a.name.clone(),
        values: from.iter().map(|&o| a.values[o as usize]).collect(),
    };
    out_attrs.vertex = attrs.vertex.iter().map(|a| pick(a, &origin)).collect();
    out_attrs.face = attrs.face.iter().map(|a| pick(a, &face_origin)).collect();
    // Every node now has its own faces; the parts keep their names.
    let mut flat = scene.clone();
    flat.parts.iter_mut().for_each(|p| p.instances.clear());
    out.scene = Some(std::sync::Arc::new(flat));
    Ok((Cow::Owned(out), Cow::Owned(out_attrs)))
}
