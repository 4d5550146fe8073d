//! The structure a mesh came from: its parts (a glTF mesh, an OBJ object
//! or group) with their names and the world transform their faces were
//! read under, and, for glTF, the node hierarchy and scenes as the file
//! wrote them. The remesh works on one surface in world space; each face's
//! label names its part ([`crate::Label::part`]), so a writer can cut the
//! result back into its parts, map each into its own space and hang it
//! from the same nodes.
//!
//! A glTF mesh that several nodes use is read once, under the world
//! transform of its first node in document order, and written once: the
//! other nodes keep using it. Edge lengths are therefore in the world
//! units of that first instance.

use glam::{DMat3, DMat4, DVec3};
use serde::{Deserialize, Serialize};

/// One part of the input.
#[derive(Clone, Debug, PartialEq, Serialize, Deserialize)]
pub struct Part {
    /// The part's name (glTF mesh name, OBJ `o`/`g` name), if it had one.
    pub name: Option<String>,
    /// The glTF mesh's `extras`, verbatim.
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub extras: Option<serde_json::Value>,
    /// The index of the glTF mesh this part was read from.
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub source_mesh: Option<u32>,
    /// The world matrix (column-major) the part's faces were read under;
    /// its inverse maps the remeshed faces back into the part's space.
    pub world: [f64; 16],
    /// The world matrices of the other nodes that use the same glTF mesh:
    /// glTF keeps the instancing, formats without it get one copy per node
    /// ([`crate::io`] expands them).
    #[serde(default, skip_serializing_if = "Vec::is_empty")]
    pub instances: Vec<[f64; 16]>,
}

impl Part {
    /// A part read without a transform.
    pub fn named(name: Option<String>) -> Self {
        Self {
            name,
            extras: None,
            source_mesh: None,
            world: DMat4::IDENTITY.to_cols_array(),
            instances: Vec::new(),
        }
    }

    /// The map from world space back into the part's own space.
    pub fn to_local(&self) -> LocalMap {
        LocalMap::new(DMat4::from_cols_array(&self.world))
    }
}

/// The scene of a mesh: its parts, and the glTF document's scene graph.
#[derive(Clone, Debug, Default, PartialEq, Serialize, Deserialize)]
pub struct Scene {
    /// The parts, indexed by [`crate::Label::part`].
    pub parts: Vec<Part>,
    /// glTF only: the document's `nodes`, `scenes`, `scene` and `cameras`
    /// as read (a node's `mesh` is the index of the input mesh, which
    /// [`Part::source_mesh`] names).
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub gltf: Option<serde_json::Value>,
}

impl Scene {
    /// Whether any part is used by more than one node.
    pub fn has_instances(&self) -> bool {
        self.parts.iter().any(|p| !p.instances.is_empty())
    }

    /// Whether a writer has structure to keep: more than one part, a named
    /// part, or a node hierarchy.
    pub fn is_structured(&self) -> bool {
        self.gltf.is_some() || self.parts.len() > 1 || self.parts.iter().any(|p| p.name.is_some())
    }
}

/// The inverse of a part's world transform, applied to what the remesh
/// produced in world space: points, normals and tangents, and whether the
/// transform mirrors (so that the winding must be flipped back).
#[derive(Clone, Copy, Debug)]
pub struct LocalMap {
    inverse: DMat4,
    /// The transpose of the world matrix's linear part: normals map by it.
    normal: DMat3,
    /// The inverse of the linear part: tangent directions map by it.
    tangent: DMat3,
    mirrors: bool,
    identity: bool,
}

impl LocalMap {
    fn new(world: DMat4) -> Self {
        let linear = DMat3::from_mat4(world);
        Self {
            inverse: world.inverse(),
            normal: linear.transpose(),
            tangent: linear.inverse(),
            mirrors: world.determinant() < 0.0,
            identity: world == DMat4::IDENTITY,
        }
    }

    /// Whether the map changes nothing.
    pub fn is_identity(&self) -> bool {
        self.identity
    }

    /// Whether the world transform mirrors, so that triangles read under it
    /// had their winding flipped.
    pub fn mirrors(&self) -> bool {
        self.mirrors
    }

    /// A world-space point in the part's space.
    pub fn point(&self, p: DVec3) -> DVec3 {
        self.inverse.transform_point3(p)
    }

    /// A world-space unit normal in the part's space, unit length again.
    pub fn normal(&self, n: DVec3) -> DVec3 {
        (self.normal * n).normalize_or_zero()
    }

    /// A world-space tangent (xyz direction, w handedness) in the part's
    /// space: a mirror flips the handedness, as it flips the winding.
    pub fn tangent(&self, t: [f32; 4]) -> [f32; 4] {
        let d = DVec3::new(f64::from(t[0]), f64::from(t[1]), f64::from(t[2]));
        let d = (self.tangent * d).normalize_or_zero();
        let w = if self.mirrors { -t[3] } else { t[3] };
        [d.x as f32, d.y as f32, d.z as f32, w]
    }
}

/// Whether `world` can be mapped back: finite, and far from singular
/// relative to its own scale.
pub fn is_invertible(world: &DMat4) -> bool {
    let linear = DMat3::from_mat4(*world);
    let scale = linear.x_axis.length() * linear.y_axis.length() * linear.z_axis.length();
    world.is_finite() && scale > 0.0 && linear.determinant().abs() > 1e-9 * scale
}

#[cfg(test)]
mod tests {
    use super::*;
    use glam::DQuat;

    #[test]
    fn the_local_map_inverts_a_non_uniform_mirroring_transform() {
        let world = DMat4::from_scale_rotation_translation(
            DVec3::new(2.0, -0.5, 3.0),
            DQuat::from_rotation_z(0.7),
            DVec3::new(1.0, 2.0, 3.0),
        );
        assert!(is_invertible(&world));
        let map = LocalMap::new(world);
        assert!(map.mirrors() && !map.is_identity());
        let p = DVec3::new(0.3, -1.0, 2.0);
        assert!((map.point(world.transform_point3(p)) - p).length() < 1e-12);
        // A normal read through the inverse transpose comes back.
        let n = DVec3::new(0.0, 0.6, 0.8);
        let world_n = (DMat3::from_mat4(world).inverse().transpose() * n).normalize();
        assert!((map.normal(world_n) - n).length() < 1e-12);
        let t = map.tangent([1.0, 0.0, 0.0, 1.0]);
        assert_eq!(t[3], -1.0);
    }

    #[test]
    fn a_flattening_scale_is_not_invertible() {
        let world = DMat4::from_scale(DVec3::new(1.0, 0.0, 1.0));
        assert!(!is_invertible(&world));
        assert!(!is_invertible(&DMat4::from_scale(DVec3::splat(f64::NAN))));
        assert!(is_invertible(&DMat4::from_scale(DVec3::splat(1e-6))));
    }
}
