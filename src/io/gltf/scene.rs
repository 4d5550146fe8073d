//! The scene side of glTF: the parts read (one per mesh, at its first
//! node), the node hierarchy and scenes kept as JSON, and, on write, the
//! remeshed faces cut back into their meshes, mapped into each mesh's own
//! space and hung from the same nodes.
//!
//! Nodes keep their index, name, transform (matrix or TRS, as written),
//! children, camera and extras; a node's `mesh` points at the remeshed
//! mesh, or is removed when that mesh has no faces left. Skins, morph
//! weights and node extensions (lights, GPU instancing) are not carried
//! and are named in the job's dropped attributes.

use std::ops::Range;

use glam::DMat4;
use serde::Deserialize;
use serde_json::{json, Map, Value};

use crate::appearance::DroppedAttribute;
use crate::io::{Format, IoError};
use crate::scene::{is_invertible, Part, Scene};
use crate::TriMesh;

/// What the document says about a mesh besides its primitives.
#[derive(Deserialize, Default)]
struct MeshHead {
    name: Option<String>,
    extras: Option<Value>,
}

/// The scene graph of the document as JSON.
#[derive(Deserialize, Default)]
pub(super) struct RawScene {
    #[serde(default)]
    nodes: Vec<Value>,
    #[serde(default)]
    scenes: Vec<Value>,
    scene: Option<Value>,
    #[serde(default)]
    cameras: Vec<Value>,
    #[serde(default)]
    meshes: Vec<MeshHead>,
}

impl RawScene {
    /// Reads the scene parts of the document text.
    pub(super) fn parse(json: &[u8], format: Format) -> Result<Self, IoError> {
        serde_json::from_slice(json).map_err(|e| IoError::parse(format, format!("JSON: {e}")))
    }

    /// The part for mesh `m` read under `world`.
    pub(super) fn part(&self, m: usize, world: DMat4, others: &[DMat4]) -> Part {
        let head = self.meshes.get(m);
        Part {
            name: head.and_then(|h| h.name.clone()),
            extras: head.and_then(|h| h.extras.clone()),
            source_mesh: Some(m as u32),
            world: world.to_cols_array(),
            instances: others.iter().map(DMat4::to_cols_array).collect(),
        }
    }

    /// The scene of the mesh read, or `None` when there is nothing to keep
    /// (one unnamed part without nodes) or a part cannot be mapped back
    /// (a singular node transform), in which case the result is written
    /// flattened and `dropped` says so.
    pub(super) fn finish(
        self,
        parts: Vec<Part>,
        dropped: &mut Vec<DroppedAttribute>,
    ) -> Option<std::sync::Arc<Scene>> {
        if parts
            .iter()
            .any(|p| !is_invertible(&DMat4::from_cols_array(&p.world)))
        {
            dropped.push(DroppedAttribute {
                name: "scene".into(),
                reason: "a node's transform is singular, so its mesh cannot be mapped back: \
                         the result is one mesh in world space, each shared mesh once"
                    .into(),
            });
            return None;
        }
        let mut not_carried = |name: &str, reason: &str| {
            if !dropped.iter().any(|d| d.name == name) {
                dropped.push(DroppedAttribute {
                    name: name.into(),
                    reason: reason.into(),
                });
            }
        };
        if self.nodes.iter().any(|n| n.get("extensions").is_some()) {
            not_carried(
                "node extensions",
                "extensions on nodes (lights, GPU instancing) are not carried",
            );
        }
        let gltf = (!self.nodes.is_empty()).then(|| {
            json!({
                "nodes": self.nodes,
                "scenes": self.scenes,
                "scene": self.scene,
                "cameras": self.cameras,
            })
        });
        let scene = Scene { parts, gltf };
        scene.is_structured().then(|| std::sync::Arc::new(scene))
    }
}

/// The part each label's faces belong to ([`TriMesh::label_part`]).
pub(super) fn label_parts(mesh: &TriMesh) -> Vec<Option<usize>> {
    (0..mesh.label_count())
        .map(|l| mesh.label_part(l))
        .collect()
}

/// Maps each label's vertex range (and its faces' winding, under a mirror)
/// from world space into its part's space.
pub(super) fn localize(
    mesh: &mut TriMesh,
    tangents: Option<&mut Vec<[f32; 4]>>,
    ranges: &[(Range<usize>, Range<usize>)],
    parts: &[Option<usize>],
) {
    let Some(scene) = mesh.scene.clone() else {
        return;
    };
    let mut tangents = tangents;
    for ((vr, fr), part) in ranges.iter().zip(parts) {
        let Some(part) = part.and_then(|p| scene.parts.get(p)) else {
            continue;
        };
        let map = part.to_local();
        if map.is_identity() {
            continue;
        }
        for p in &mut mesh.positions[vr.clone()] {
            *p = map.point(*p);
        }
        if !mesh.normals.is_empty() {
            for n in &mut mesh.normals[vr.clone()] {
                *n = map.normal(*n);
            }
        }
        if let Some(t) = tangents.as_deref_mut() {
            for t in &mut t[vr.clone()] {
                *t = map.tangent(*t);
            }
        }
        if map.mirrors() {
            for t in &mut mesh.triangles[fr.clone()] {
                t.swap(1, 2);
            }
        }
    }
}

/// One written mesh: its part (none for faces outside every part) and the
/// indices of its primitives in write order.
pub(super) struct MeshPlan {
    pub part: Option<usize>,
    pub primitives: Vec<usize>,
}

/// Groups the written primitives (each with its label's part) into meshes:
/// one per part that kept faces, in part order, then one for faces of no
/// part.
pub(super) fn plan(primitive_parts: &[Option<usize>], part_count: usize) -> Vec<MeshPlan> {
    let mut plans: Vec<MeshPlan> = (0..part_count)
        .map(|p| MeshPlan {
            part: Some(p),
            primitives: Vec::new(),
        })
        .collect();
    let mut orphans = Vec::new();
    for (i, p) in primitive_parts.iter().enumerate() {
        match p {
            Some(p) if *p < part_count => plans[*p].primitives.push(i),
            _ => orphans.push(i),
        }
    }
    if !orphans.is_empty() {
        plans.push(MeshPlan {
            part: None,
            primitives: orphans,
        });
    }
    plans.retain(|p| !p.primitives.is_empty());
    plans
}

/// Writes the meshes' names and extras and the scene graph into `doc`:
/// the document's own nodes and scenes when it had them (each node's mesh
/// remapped), else one node per mesh in one scene.
pub(super) fn write_graph(doc: &mut Value, scene: Option<&Scene>, plans: &[MeshPlan]) {
    let part = |p: Option<usize>| p.and_then(|p| scene?.parts.get(p));
    if let Some(meshes) = doc["meshes"].as_array_mut() {
        for (m, plan) in meshes.iter_mut().zip(plans) {
            match part(plan.part) {
                Some(p) => {
                    match &p.name {
                        Some(n) => m["name"] = json!(n),
                        None => drop(m.as_object_mut().map(|o| o.remove("name"))),
                    }
                    if let Some(x) = &p.extras {
                        m["extras"] = x.clone();
                    }
                }
                None => m["name"] = json!("isoremesh"),
            }
        }
    }
    let graph = scene.and_then(|s| s.gltf.as_ref());
    let (mut nodes, mut scenes, default) = match graph {
        Some(g) => (
            g["nodes"].as_array().cloned().unwrap_or_default(),
            g["scenes"].as_array().cloned().unwrap_or_default(),
            g["scene"].as_u64(),
        ),
        None => (Vec::new(), Vec::new(), None),
    };
    // The output mesh of each input mesh.
    let mut written_as = std::collections::HashMap::new();
    for (i, plan) in plans.iter().enumerate() {
        if let Some(src) = part(plan.part).and_then(|p| p.source_mesh) {
            written_as.insert(u64::from(src), i);
        }
    }
    for node in &mut nodes {
        let Some(o) = node.as_object_mut() else {
            continue;
        };
        let mesh = o.remove("mesh").and_then(|m| m.as_u64());
        if let Some(out) = mesh.and_then(|m| written_as.get(&m)) {
            o.insert("mesh".into(), json!(out));
        }
        for key in ["skin", "weights", "extensions"] {
            o.remove(key);
        }
    }
    // Meshes that no kept node uses hang from new root nodes.
    let used: std::collections::HashSet<u64> = nodes
        .iter()
        .filter_map(|n| n.get("mesh").and_then(Value::as_u64))
        .collect();
    let mut new_roots = Vec::new();
    for (i, plan) in plans.iter().enumerate() {
        if used.contains(&(i as u64)) {
            continue;
        }
        let mut node = Map::new();
        if let Some(n) = part(plan.part).and_then(|p| p.name.clone()) {
            node.insert("name".into(), json!(n));
        }
        node.insert("mesh".into(), json!(i));
        new_roots.push(nodes.len());
        nodes.push(Value::Object(node));
    }
    if scenes.is_empty() {
        // Without scenes the reader took every root node; so does the file.
        let mut is_child = vec![false; nodes.len()];
        for c in nodes.iter().filter_map(|n| n.get("children")?.as_array()) {
            for i in c.iter().filter_map(Value::as_u64) {
                if let Some(flag) = is_child.get_mut(i as usize) {
                    *flag = true;
                }
            }
        }
        let roots: Vec<usize> = (0..nodes.len())
            .filter(|&i| !is_child[i] && !new_roots.contains(&i))
            .collect();
        scenes.push(json!({ "nodes": roots }));
    }
    let target = default
        .map(|d| d as usize)
        .filter(|&d| d < scenes.len())
        .unwrap_or(0);
    if let Some(list) = scenes[target]["nodes"].as_array_mut() {
        list.extend(new_roots.iter().map(|&n| json!(n)));
    } else {
        scenes[target]["nodes"] = json!(new_roots);
    }
    doc["nodes"] = Value::Array(nodes);
    doc["scenes"] = Value::Array(scenes);
    doc["scene"] = json!(target);
    let cameras = graph.and_then(|g| g["cameras"].as_array()).cloned();
    match cameras.filter(|c| !c.is_empty()) {
        Some(c) => doc["cameras"] = Value::Array(c),
        None => {
            if let Some(o) = doc.as_object_mut() {
                o.remove("cameras");
            }
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn meshes_follow_their_parts_and_orphans_come_last() {
        let plans = plan(&[Some(1), None, Some(1), Some(0)], 3);
        let got: Vec<_> = plans
            .iter()
            .map(|p| (p.part, p.primitives.clone()))
            .collect();
        assert_eq!(
            got,
            [(Some(0), vec![3]), (Some(1), vec![0, 2]), (None, vec![1])]
        );
    }
}
