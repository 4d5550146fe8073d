//! glTF 2.0 (Khronos specification 2.0.1): `.gltf` JSON with `data:` base64
//! buffers or caller-provided external buffers, and the `.glb` container.
//!
//! Reading uses `gltf::json` only to deserialize the document; the GLB
//! header and chunks, buffer views, accessors, strides and indices are
//! validated here with checked arithmetic and read by this module, because
//! the `gltf` crate's reader panics on hostile counts and strides. Every
//! triangle primitive of every mesh reachable from the default scene (else
//! scene 0, else all root nodes, else every mesh when there are no nodes)
//! is read in world space: node matrices / TRS are composed down the
//! hierarchy (each node is visited once, so cycles terminate), normals use
//! the inverse-transpose, and mirroring transforms flip the winding.
//! Strips and fans become triangle lists; points and lines are counted in
//! [`Imported::ignored_primitives`]. Morph targets and skins are ignored
//! (the rest pose is read). A mesh that several nodes use is read once,
//! under its first node, and becomes one part of the mesh's
//! [`crate::scene::Scene`] (see `scene.rs`).
//!
//! Labels: one label per mesh and material index, so primitives of one
//! mesh that share a material share a label; primitives without a material
//! share one label per mesh. Primitives of one mesh that share their
//! POSITION/NORMAL accessors share vertices. [`write`] gives each primitive
//! its own vertex range instead, copying a vertex on a material border into
//! every primitive that uses it; the half-edge builder welds the copies
//! again, so a round trip keeps the topology.
//!
//! Rooms: `access.rs` validates and reads the binary side (GLB chunks,
//! buffers, views, accessors); `look.rs` reads and writes materials,
//! textures, samplers and images; `scene.rs` keeps the node hierarchy and
//! the parts and maps each part back into its own space on write; this
//! file walks the scene and reads the primitives; `write.rs`
//! writes a mesh back as glTF or GLB, with `primitives.rs` regrouping its
//! vertices into one compact range per primitive.

use std::collections::HashMap;

use ::gltf::json;
use glam::{DMat3, DMat4, DQuat, DVec3};
use json::mesh::{Mode, Semantic};
use json::validation::Checked;

use super::{check_triangle_budget, Format, Imported, IoError, ReadOptions};
use crate::appearance::DroppedAttribute;
use crate::{Label, Material, TriMesh};

mod access;
mod look;
mod primitives;
mod scene;
mod write;

pub use access::percent_decode;
use access::*;
pub(super) use write::write;

fn to_material(m: &json::Material) -> Material {
    let pbr = &m.pbr_metallic_roughness;
    let strength = m
        .extensions
        .as_ref()
        .and_then(|e| e.emissive_strength.as_ref())
        .map_or(1.0, |s| s.emissive_strength.0);
    Material {
        name: m.name.clone(),
        base_color_factor: pbr.base_color_factor.0,
        metallic_factor: pbr.metallic_factor.0,
        roughness_factor: pbr.roughness_factor.0,
        emissive_factor: m.emissive_factor.0.map(|c| c * strength),
        double_sided: m.double_sided,
        gltf: None,
    }
}

fn local_matrix(node: &json::Node) -> DMat4 {
    if let Some(m) = node.matrix {
        return DMat4::from_cols_array(&m.map(f64::from));
    }
    let t = node.translation.map_or(DVec3::ZERO, |t| {
        DVec3::new(f64::from(t[0]), f64::from(t[1]), f64::from(t[2]))
    });
    let s = node.scale.map_or(DVec3::ONE, |s| {
        DVec3::new(f64::from(s[0]), f64::from(s[1]), f64::from(s[2]))
    });
    let r = node
        .rotation
        .map(|q| {
            let [x, y, z, w] = q.0.map(f64::from);
            DQuat::from_xyzw(x, y, z, w)
        })
        .filter(|q| q.length() > 1e-12 && q.is_finite())
        .map_or(DQuat::IDENTITY, DQuat::normalize);
    DMat4::from_scale_rotation_translation(s, r, t)
}

/// The meshes to read with their world matrices, in the document order of
/// their nodes (the order trimesh, and so the benchmark, concatenates them),
/// whatever the hierarchy's shape.
fn instances(root: &json::Root, format: Format) -> Result<Vec<Instance>, IoError> {
    let nodes = &root.nodes;
    let roots: Vec<usize> = if let Some(s) = root
        .scene
        .map(|s| s.value())
        .or_else(|| (!root.scenes.is_empty()).then_some(0))
    {
        let scene = root.scenes.get(s).ok_or_else(|| {
            IoError::parse(format, format!("the default scene {s} does not exist"))
        })?;
        scene.nodes.iter().map(|n| n.value()).collect()
    } else if !nodes.is_empty() {
        let mut is_child = vec![false; nodes.len()];
        for c in nodes.iter().flat_map(|n| n.children.iter().flatten()) {
            if let Some(flag) = is_child.get_mut(c.value()) {
                *flag = true;
            }
        }
        (0..nodes.len()).filter(|&i| !is_child[i]).collect()
    } else {
        return Ok((0..root.meshes.len())
            .map(|m| Instance {
                mesh: m,
                world: DMat4::IDENTITY,
                others: Vec::new(),
            })
            .collect());
    };
    let mut visited = vec![false; nodes.len()];
    let mut stack: Vec<(usize, DMat4)> =
        roots.iter().rev().map(|&n| (n, DMat4::IDENTITY)).collect();
    let mut out = Vec::new();
    while let Some((n, parent)) = stack.pop() {
        let Some(node) = nodes.get(n) else {
            return Err(IoError::parse(format, format!("node {n} does not exist")));
        };
        // The hierarchy must be a forest; visiting each node once makes
        // cycles and shared children terminate.
        if std::mem::replace(&mut visited[n], true) {
            continue;
        }
        let world = parent * local_matrix(node);
        if let Some(m) = node.mesh {
            if m.value() >= root.meshes.len() {
                return Err(IoError::parse(
                    format,
                    format!("node {n} uses mesh {}, which does not exist", m.value()),
                ));
            }
            out.push((n, m.value(), world));
        }
        for c in node.children.iter().flatten().rev() {
            stack.push((c.value(), world));
        }
    }
    // Each node is visited once, so node indices are unique keys. A mesh
    // that several nodes use is read once, under its first node; the other
    // nodes' matrices go with it.
    out.sort_unstable_by_key(|&(n, _, _)| n);
    let mut first: Vec<Option<usize>> = vec![None; root.meshes.len()];
    let mut read: Vec<Instance> = Vec::new();
    for (_, m, w) in out {
        match first[m] {
            Some(i) => read[i].others.push(w),
            None => {
                first[m] = Some(read.len());
                read.push(Instance {
                    mesh: m,
                    world: w,
                    others: Vec::new(),
                });
            }
        }
    }
    Ok(read)
}

/// A mesh to read: under the world matrix of its first node, with those
/// of the other nodes that use it.
struct Instance {
    mesh: usize,
    world: DMat4,
    others: Vec<DMat4>,
}

pub(super) fn read(bytes: &[u8], format: Format, opts: &ReadOptions) -> Result<Imported, IoError> {
    let is_glb = bytes.starts_with(GLB_MAGIC) || format == Format::Glb;
    let format = if is_glb { Format::Glb } else { Format::Gltf };
    let (json_bytes, bin) = if is_glb {
        split_glb(bytes)?
    } else {
        // A byte order mark is tolerated in .gltf text (not in GLB).
        (bytes.strip_prefix(b"\xEF\xBB\xBF").unwrap_or(bytes), None)
    };
    let root: json::Root = serde_json::from_slice(json_bytes)
        .map_err(|e| IoError::parse(format, format!("JSON: {e}")))?;
    let major = root.asset.version.split('.').next().unwrap_or("");
    if major != "2" {
        return Err(IoError::unsupported(
            format,
            format!("glTF version {:?} (only 2.x is read)", root.asset.version),
        ));
    }
    if let Some(ext) = root
        .extensions_required
        .iter()
        .find(|e| GEOMETRY_EXTENSIONS.contains(&e.as_str()))
    {
        return Err(IoError::unsupported(
            format,
            format!("the file requires {ext}, which isoremesh cannot decode"),
        ));
    }
    let look = look::RawLook::parse(json_bytes, format)?;
    let raw_scene = scene::RawScene::parse(json_bytes, format)?;
    let instances = instances(&root, format)?;
    let max_vertices = opts
        .max_triangles
        .saturating_mul(3)
        .min(u64::from(u32::MAX));
    let mut reader = Reader {
        format,
        root: &root,
        buffers: Buffers::new(format, &root, bin, opts),
        max_elements: max_vertices,
    };

    let mut mesh = TriMesh::default();
    let mut dropped: Vec<DroppedAttribute> = Vec::new();
    let mut any_tangents = false;
    if !root.skins.is_empty() {
        dropped.push(DroppedAttribute {
            name: "skins".into(),
            reason: "skinning is not carried: the rest pose is remeshed as a static mesh".into(),
        });
    }
    if !root.animations.is_empty() {
        dropped.push(DroppedAttribute {
            name: "animations".into(),
            reason: "animations are not carried: the mesh is remeshed as a static mesh".into(),
        });
    }
    let mut ignored = 0u64;
    let mut dropped_scene = Vec::new();
    let mut all_normals = true;
    let mut labels: HashMap<(usize, Option<usize>), u32> = HashMap::new();
    let mut label_sets: HashMap<u32, u32> = HashMap::new();
    let mut parts = Vec::with_capacity(instances.len());
    type VertexKey = (usize, usize, Option<usize>, Vec<usize>, Option<usize>);
    let mut shared: HashMap<VertexKey, (u32, u32)> = HashMap::new();
    let mut scratch: Vec<f64> = Vec::new();
    for (instance, read) in instances.iter().enumerate() {
        let (m, world) = (read.mesh, read.world);
        parts.push(raw_scene.part(m, world, &read.others));
        let det = world.determinant();
        let normal_matrix = if det.abs() > 1e-300 {
            DMat3::from_mat4(world).inverse().transpose()
        } else {
            DMat3::from_mat4(world)
        };
        for prim in &root.meshes[m].primitives {
            let mode = match prim.mode {
                Checked::Valid(mode) => mode,
                Checked::Invalid => {
                    return Err(IoError::parse(
                        format,
                        format!("a primitive of mesh {m} has an invalid mode"),
                    ))
                }
            };
            if !matches!(
                mode,
                Mode::Triangles | Mode::TriangleStrip | Mode::TriangleFan
            ) {
                ignored += 1;
                continue;
            }
            let Some(pos_acc) = prim
                .attributes
                .get(&Checked::Valid(Semantic::Positions))
                .map(|i| i.value())
            else {
                // The spec lets clients skip primitives without positions.
                ignored += 1;
                continue;
            };
            let nrm_acc = prim
                .attributes
                .get(&Checked::Valid(Semantic::Normals))
                .map(|i| i.value());
            let idx_acc = prim.indices.map(|i| i.value());
            let tex_accs: Vec<usize> = (0u32..)
                .map_while(|k| {
                    prim.attributes
                        .get(&Checked::Valid(Semantic::TexCoords(k)))
                        .map(|i| i.value())
                })
                .collect();
            let color_acc = prim
                .attributes
                .get(&Checked::Valid(Semantic::Colors(0)))
                .map(|i| i.value());
            note_dropped(prim, tex_accs.len() as u32, &mut dropped);
            any_tangents |= prim
                .attributes
                .contains_key(&Checked::Valid(Semantic::Tangents));

            // Bound the output before reading anything.
            let corner_count = match idx_acc {
                Some(i) => root.accessors.get(i).map_or(0, |a| a.count.0),
                None => root.accessors.get(pos_acc).map_or(0, |a| a.count.0),
            };
            let new_triangles = match mode {
                Mode::Triangles => corner_count / 3,
                _ => corner_count.saturating_sub(2),
            };
            check_triangle_budget(mesh.triangles.len() as u64 + new_triangles, opts)?;

            let key = (instance, pos_acc, nrm_acc, tex_accs.clone(), color_acc);
            let (base, vcount) = match shared.get(&key) {
                Some(&b) => b,
                None => {
                    let base = super::vertex_index(mesh.positions.len())?;
                    scratch.clear();
                    let n = reader.read(pos_acc, Role::Vec3, &mut scratch)?;
                    if mesh.positions.len() as u64 + n as u64 > max_vertices {
                        return Err(IoError::TooLarge {
                            message: format!(
                                "more than {max_vertices} vertices (3 per allowed triangle)"
                            ),
                        });
                    }
                    mesh.positions.extend(
                        scratch
                            .chunks_exact(3)
                            .map(|c| world.transform_point3(DVec3::new(c[0], c[1], c[2]))),
                    );
                    match nrm_acc {
                        Some(na) => {
                            scratch.clear();
                            let nn = reader.read(na, Role::Vec3, &mut scratch)?;
                            if nn != n {
                                return Err(IoError::parse(
                                    format,
                                    format!(
                                        "NORMAL accessor {na} has {nn} elements but POSITION accessor {pos_acc} has {n}"
                                    ),
                                ));
                            }
                            mesh.normals.resize(base as usize, DVec3::ZERO);
                            mesh.normals.extend(scratch.chunks_exact(3).map(|c| {
                                (normal_matrix * DVec3::new(c[0], c[1], c[2])).normalize_or_zero()
                            }));
                        }
                        None => all_normals = false,
                    }
                    read_vertex_attributes(
                        &mut reader,
                        &mut mesh,
                        &tex_accs,
                        color_acc,
                        (pos_acc, n),
                        &mut scratch,
                    )?;
                    let entry = (base, super::vertex_index(n)?);
                    shared.insert(key, entry);
                    entry
                }
            };

            scratch.clear();
            let corners: Vec<u32> = match idx_acc {
                Some(i) => {
                    reader.read(i, Role::Index, &mut scratch)?;
                    // Unsigned integers of at most 32 bits, exact in f64.
                    scratch.iter().map(|&x| x as u32).collect()
                }
                None => (0..vcount).collect(),
            };
            let first_face = mesh.triangles.len();
            for (c, &i) in corners.iter().enumerate() {
                if i >= vcount {
                    let face = match mode {
                        Mode::Triangles => c / 3,
                        _ => c.saturating_sub(2),
                    };
                    return Err(IoError::IndexOutOfRange {
                        face: (first_face + face) as u64,
                        index: i64::from(i),
                        vertex_count: u64::from(vcount),
                    });
                }
            }
            let flip = det < 0.0;
            let mut push = |t: [u32; 3]| {
                let t = t.map(|i| i + base);
                mesh.triangles
                    .push(if flip { [t[0], t[2], t[1]] } else { t });
            };
            match mode {
                Mode::Triangles => corners
                    .chunks_exact(3)
                    .for_each(|t| push([t[0], t[1], t[2]])),
                Mode::TriangleStrip => {
                    for (k, w) in corners.windows(3).enumerate() {
                        // Zero-area joins between strips are not faces.
                        if w[0] != w[1] && w[1] != w[2] && w[0] != w[2] {
                            push(if k % 2 == 0 {
                                [w[0], w[1], w[2]]
                            } else {
                                [w[1], w[0], w[2]]
                            });
                        }
                    }
                }
                _ => {
                    for w in corners.windows(2).skip(1) {
                        let t = [w[0], w[1], corners[0]];
                        if t[0] != t[1] && t[1] != t[2] && t[0] != t[2] {
                            push(t);
                        }
                    }
                }
            }

            let mat = prim.material.map(|i| i.value());
            let next = mesh.labels.len() as u32;
            let label = *labels.entry((instance, mat)).or_insert(next);
            // The fewest sets of any primitive of the label (see Label::texcoord_sets).
            let sets = tex_accs.len() as u32;
            label_sets
                .entry(label)
                .and_modify(|s: &mut u32| *s = (*s).min(sets))
                .or_insert(sets);
            if label == next {
                let material = match mat {
                    Some(i) => {
                        let mut m = to_material(root.materials.get(i).ok_or_else(|| {
                            IoError::parse(format, format!("material {i} does not exist"))
                        })?);
                        m.gltf = look.verbatim_material(i);
                        Some(m)
                    }
                    None => None,
                };
                mesh.labels.push(Label {
                    name: material.as_ref().and_then(|m| m.name.clone()),
                    material,
                    part: Some(instance as u32),
                    texcoord_sets: None,
                });
            }
            mesh.face_labels.resize(mesh.triangles.len(), label);
        }
    }
    let nv = mesh.positions.len();
    for set in &mut mesh.attributes.texcoords {
        set.resize(nv, [0.0; 2]);
    }
    let all_sets = mesh.attributes.texcoords.len() as u32;
    for (&l, &sets) in &label_sets {
        if let Some(label) = mesh.labels.get_mut(l as usize) {
            label.texcoord_sets = (sets < all_sets).then_some(sets);
        }
    }
    if !mesh.attributes.colors.is_empty() {
        mesh.attributes.colors.resize(nv, [1.0; 4]);
    }
    finish_tangents(&mut mesh, any_tangents, &mut dropped);
    mesh.attributes.dropped = dropped;
    mesh.appearance = look
        .appearance(&mut reader.buffers)?
        .map(std::sync::Arc::new);
    if all_normals {
        mesh.normals.resize(mesh.positions.len(), DVec3::ZERO);
    } else {
        mesh.normals.clear();
    }
    mesh.scene = raw_scene.finish(parts, &mut dropped_scene);
    mesh.attributes.dropped.append(&mut dropped_scene);
    if mesh.labels.len() <= 1 && mesh.labels.iter().all(|l| l.material.is_none()) {
        mesh.labels.clear();
        mesh.face_labels.clear();
    }
    Ok(Imported {
        mesh,
        ignored_primitives: ignored,
    })
}

/// Reads the texture coordinate sets `tex` (TEXCOORD_0, 1, …) and the
/// colour `color` of a vertex block of `n` vertices read from accessor
/// `pos`, appending them to `mesh`'s attributes; sets that earlier blocks
/// lacked are padded with zeros (colours with white) first.
fn read_vertex_attributes(
    reader: &mut Reader,
    mesh: &mut TriMesh,
    tex: &[usize],
    color: Option<usize>,
    (pos, n): (usize, usize),
    scratch: &mut Vec<f64>,
) -> Result<(), IoError> {
    let format = reader.format;
    let base = mesh.positions.len() - n;
    let count_err = |what: &str, a: usize, got: usize| {
        IoError::parse(
            format,
            format!("{what} accessor {a} has {got} elements but POSITION accessor {pos} has {n}"),
        )
    };
    for (k, &a) in tex.iter().enumerate() {
        scratch.clear();
        let got = reader.read(a, Role::Vec2, scratch)?;
        let what = format!("TEXCOORD_{k}");
        if got != n {
            return Err(count_err(&what, a, got));
        }
        if scratch.iter().any(|x| !(*x as f32).is_finite()) {
            return Err(IoError::parse(
                format,
                format!("{what} accessor {a} holds a value that is not a finite number"),
            ));
        }
        let sets = &mut mesh.attributes.texcoords;
        if sets.len() <= k {
            sets.resize(k + 1, Vec::new());
        }
        sets[k].resize(base, [0.0; 2]);
        sets[k].extend(scratch.chunks_exact(2).map(|c| [c[0] as f32, c[1] as f32]));
    }
    if let Some(a) = color {
        let rgba = reader.root.accessors.get(a).map(|x| x.type_)
            == Some(Checked::Valid(json::accessor::Type::Vec4));
        scratch.clear();
        let got = reader.read(a, Role::Color, scratch)?;
        if got != n {
            return Err(count_err("COLOR_0", a, got));
        }
        if scratch.iter().any(|x| !(*x as f32).is_finite()) {
            return Err(IoError::parse(
                format,
                format!("COLOR_0 accessor {a} holds a value that is not a finite number"),
            ));
        }
        let colors = &mut mesh.attributes.colors;
        colors.resize(base, [1.0; 4]);
        let w = if rgba { 4 } else { 3 };
        colors.extend(scratch.chunks_exact(w).map(|c| {
            [
                c[0] as f32,
                c[1] as f32,
                c[2] as f32,
                if rgba { c[3] as f32 } else { 1.0 },
            ]
        }));
        mesh.attributes.color_alpha |= rgba;
    }
    Ok(())
}

/// Marks `mesh` as carrying tangents when its input had `TANGENT`: they
/// are generated again on write from the new surface, which needs a first
/// texture coordinate set; without one they are named as dropped.
fn finish_tangents(mesh: &mut TriMesh, any: bool, dropped: &mut Vec<DroppedAttribute>) {
    if !any {
        return;
    }
    if mesh.attributes.texcoords.is_empty() {
        dropped.push(DroppedAttribute {
            name: "TANGENT".into(),
            reason: "without texture coordinates there is no tangent basis to generate".into(),
        });
    } else {
        mesh.attributes.tangents = true;
    }
}

/// Records, once each, the attributes of `prim` that are not carried:
/// further colour sets, joints and weights, texture sets after a gap
/// (`TEXCOORD_2` without `TEXCOORD_1`; the
/// first `sets` are read), morph targets, and attributes glTF does not name.
fn note_dropped(prim: &json::mesh::Primitive, sets: u32, dropped: &mut Vec<DroppedAttribute>) {
    let mut note = |name: String, reason: &str| {
        if !dropped.iter().any(|d| d.name == name) {
            dropped.push(DroppedAttribute {
                name,
                reason: reason.to_string(),
            });
        }
    };
    for key in prim.attributes.keys() {
        match key {
            // Regenerated on write (MikkTSpace) when there are texture
            // coordinates to define them; see `finish_tangents`.
            Checked::Valid(Semantic::Tangents) => {}
            Checked::Valid(Semantic::Colors(n)) if *n > 0 => {
                note(format!("COLOR_{n}"), "only COLOR_0 is carried")
            }
            Checked::Valid(Semantic::Joints(n)) => {
                note(format!("JOINTS_{n}"), "skinning is not carried")
            }
            Checked::Valid(Semantic::Weights(n)) => {
                note(format!("WEIGHTS_{n}"), "skinning is not carried")
            }
            Checked::Valid(Semantic::TexCoords(n)) if *n >= sets => note(
                format!("TEXCOORD_{n}"),
                "texture coordinate sets are read up to the first missing one",
            ),
            Checked::Invalid => note(
                "custom attributes".into(),
                "application-specific attributes (`_NAME`) are not carried",
            ),
            _ => {}
        }
    }
    if prim.targets.as_ref().is_some_and(|t| !t.is_empty()) {
        note(
            "morph targets".into(),
            "morph targets are not carried: the base shape is remeshed",
        );
    }
}
