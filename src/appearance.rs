//! What a textured or painted asset carries beside its geometry: the
//! per-vertex surface attributes that the remesh transfers (texture
//! coordinate sets and a colour), and the textures, samplers and images
//! that its materials refer to, which the writers copy through unchanged.
//!
//! Attributes are stored per position of a [`crate::TriMesh`], as glTF
//! does: a vertex where a corner attribute differs (a UV seam) is split into
//! one position per distinct value, so the corners of a face read their
//! values through the face's vertex indices.

use serde::{Deserialize, Serialize};

/// Per-vertex attributes, each list empty or with one entry per position.
#[derive(Clone, Debug, Default, PartialEq, Serialize, Deserialize)]
pub struct VertexAttributes {
    /// Texture coordinate sets: glTF `TEXCOORD_n` (set `n` at index `n`),
    /// OBJ `vt`, PLY `s t` / `u v`. glTF's convention: v grows downwards.
    pub texcoords: Vec<Vec<[f32; 2]>>,
    /// Vertex colour (glTF `COLOR_0`, PLY `red green blue [alpha]`), linear
    /// RGBA in [0, 1], or empty.
    pub colors: Vec<[f32; 4]>,
    /// Whether the colours carry alpha (a vec4 `COLOR_0`, a PLY `alpha`);
    /// writers emit RGB otherwise.
    pub color_alpha: bool,
    /// Whether the mesh should carry `TANGENT` (its input had them): the
    /// glTF writer then generates them with MikkTSpace, as it does for any
    /// mesh whose material has a normal texture. Tangents themselves are
    /// never stored or transferred.
    #[serde(default)]
    pub tangents: bool,
    /// Shading normals carried as an attribute, so that the remesh samples
    /// them like the others (`normals: "transfer"`); empty otherwise.
    /// Readers leave them in [`crate::TriMesh::normals`]: the pipeline
    /// copies them here for a transfer and back after it.
    #[serde(default, skip_serializing_if = "Vec::is_empty")]
    pub normals: Vec<[f32; 3]>,
    /// What the reader found but does not carry (skins, morph targets,
    /// further colour sets), so that a job can name it.
    #[serde(default, skip_serializing_if = "Vec::is_empty")]
    pub dropped: Vec<DroppedAttribute>,
}

/// An attribute of the input that the output will not carry.
#[derive(Clone, Debug, Default, PartialEq, Eq, Serialize, Deserialize)]
pub struct DroppedAttribute {
    /// Its name, as glTF names it (`TANGENT`, `JOINTS_0`, `morph targets`).
    pub name: String,
    /// Why it is dropped.
    pub reason: String,
}

impl VertexAttributes {
    /// Whether there is no attribute at all.
    pub fn is_empty(&self) -> bool {
        self.texcoords.is_empty() && self.colors.is_empty() && self.normals.is_empty()
    }

    /// Number of floats per vertex when every attribute is laid end to end
    /// (two per texture coordinate set, four for a colour, three for
    /// carried normals): the width of [`Self::gather`].
    pub fn width(&self) -> usize {
        Self::width_of(
            self.texcoords.len(),
            !self.colors.is_empty(),
            !self.normals.is_empty(),
        )
    }

    /// The width of `sets` texture coordinate sets, a colour if `color`
    /// and normals if `normals`.
    pub fn width_of(sets: usize, color: bool, normals: bool) -> usize {
        2 * sets + if color { 4 } else { 0 } + if normals { 3 } else { 0 }
    }

    /// Appends the attributes of vertex `v` to `out`, [`Self::width`] floats.
    pub fn gather(&self, v: usize, out: &mut Vec<f32>) {
        for set in &self.texcoords {
            out.extend_from_slice(&set[v]);
        }
        if let Some(c) = self.colors.get(v) {
            out.extend_from_slice(c);
        }
        if let Some(n) = self.normals.get(v) {
            out.extend_from_slice(n);
        }
    }

    /// Empty lists of the same layout (as many sets, a colour if this has one).
    pub fn empty_like(&self) -> Self {
        Self {
            texcoords: vec![Vec::new(); self.texcoords.len()],
            colors: Vec::new(),
            color_alpha: self.color_alpha,
            tangents: self.tangents,
            normals: Vec::new(),
            dropped: Vec::new(),
        }
    }

    /// Appends one vertex from `values`, laid out as [`Self::gather`] writes
    /// them for a mesh of this layout with a colour if `has_color` and
    /// normals if `has_normals`.
    pub fn push(&mut self, values: &[f32], has_color: bool, has_normals: bool) {
        for (k, set) in self.texcoords.iter_mut().enumerate() {
            set.push([values[2 * k], values[2 * k + 1]]);
        }
        let mut at = 2 * self.texcoords.len();
        if has_color {
            self.colors
                .push([values[at], values[at + 1], values[at + 2], values[at + 3]]);
            at += 4;
        }
        if has_normals {
            self.normals
                .push([values[at], values[at + 1], values[at + 2]]);
        }
    }

    /// The attributes of the vertices `order` (e.g. the first source vertex
    /// of each welded vertex), in that order.
    pub fn select(&self, order: &[u32]) -> Self {
        Self {
            texcoords: self
                .texcoords
                .iter()
                .map(|set| order.iter().map(|&i| set[i as usize]).collect())
                .collect(),
            colors: if self.colors.is_empty() {
                Vec::new()
            } else {
                order.iter().map(|&i| self.colors[i as usize]).collect()
            },
            color_alpha: self.color_alpha,
            tangents: self.tangents,
            normals: if self.normals.is_empty() {
                Vec::new()
            } else {
                order.iter().map(|&i| self.normals[i as usize]).collect()
            },
            dropped: Vec::new(),
        }
    }

    /// Fails unless every list has `n` entries and every value is finite,
    /// naming the attribute.
    pub fn check(&self, n: usize) -> Result<(), String> {
        for (k, set) in self.texcoords.iter().enumerate() {
            if set.len() != n {
                return Err(format!(
                    "TEXCOORD_{k} has {} entries for {n} vertices",
                    set.len()
                ));
            }
            if let Some(v) = set.iter().position(|t| !t.iter().all(|c| c.is_finite())) {
                return Err(format!("TEXCOORD_{k} of vertex {v} is not finite"));
            }
        }
        if !self.colors.is_empty() {
            if self.colors.len() != n {
                return Err(format!(
                    "COLOR_0 has {} entries for {n} vertices",
                    self.colors.len()
                ));
            }
            if let Some(v) = self
                .colors
                .iter()
                .position(|c| !c.iter().all(|x| x.is_finite()))
            {
                return Err(format!("COLOR_0 of vertex {v} is not finite"));
            }
        }
        if !self.normals.is_empty() && self.normals.len() != n {
            return Err(format!(
                "NORMAL has {} entries for {n} vertices",
                self.normals.len()
            ));
        }
        Ok(())
    }

    /// The names of the attributes present, as glTF names them.
    pub fn names(&self) -> Vec<String> {
        let mut names: Vec<String> = (0..self.texcoords.len())
            .map(|k| format!("TEXCOORD_{k}"))
            .collect();
        if !self.colors.is_empty() {
            names.push("COLOR_0".to_string());
        }
        if self.tangents {
            names.push("TANGENT".to_string());
        }
        names
    }
}

/// The linear value of an sRGB-encoded colour channel in [0, 1] (IEC
/// 61966-2-1). PLY and OBJ colours are sRGB; glTF's `COLOR_0` is linear.
pub fn srgb_to_linear(c: f32) -> f32 {
    let c = c.clamp(0.0, 1.0);
    if c <= 0.04045 {
        c / 12.92
    } else {
        ((c + 0.055) / 1.055).powf(2.4)
    }
}

/// The sRGB encoding of a linear colour channel in [0, 1], the inverse of
/// [`srgb_to_linear`].
pub fn linear_to_srgb(c: f32) -> f32 {
    let c = c.clamp(0.0, 1.0);
    if c <= 0.003_130_8 {
        c * 12.92
    } else {
        1.055 * c.powf(1.0 / 2.4) - 0.055
    }
}

/// An image as the input stored it: its bytes are written back unchanged.
#[derive(Clone, Debug, Default, PartialEq, Serialize, Deserialize)]
pub struct Image {
    /// The image's name, if any.
    pub name: Option<String>,
    /// Its media type (`image/png`, `image/jpeg`, …), declared or sniffed.
    pub mime_type: Option<String>,
    /// The relative file name it was read from (an external glTF image, an
    /// OBJ map); writers of multi-file formats use it again.
    pub uri: Option<String>,
    /// The encoded image, byte for byte.
    #[serde(skip)]
    pub bytes: Vec<u8>,
}

impl Image {
    /// The media type: the declared one, else sniffed from the signature.
    pub fn media_type(&self) -> Option<&str> {
        self.mime_type
            .as_deref()
            .or_else(|| sniff_image(&self.bytes))
    }
}

/// The media type of encoded image bytes from their signature.
pub fn sniff_image(bytes: &[u8]) -> Option<&'static str> {
    if bytes.starts_with(b"\x89PNG\r\n\x1a\n") {
        Some("image/png")
    } else if bytes.starts_with(&[0xFF, 0xD8, 0xFF]) {
        Some("image/jpeg")
    } else if bytes.len() >= 12 && &bytes[..4] == b"RIFF" && &bytes[8..12] == b"WEBP" {
        Some("image/webp")
    } else if bytes.starts_with(b"\xABKTX 20\xBB") {
        Some("image/ktx2")
    } else {
        None
    }
}

/// The texture side of a mesh's materials. A material's texture references
/// ([`crate::Material::gltf`]) index [`Self::textures`], whose `source` and
/// `sampler` index [`Self::images`] and [`Self::samplers`], exactly as in a
/// glTF document, so readers of every format build this one form and every
/// writer reads it.
#[derive(Clone, Debug, Default, PartialEq, Serialize, Deserialize)]
pub struct Appearance {
    /// glTF `textures` objects, as JSON.
    pub textures: Vec<serde_json::Value>,
    /// glTF `samplers` objects, as JSON.
    pub samplers: Vec<serde_json::Value>,
    /// The images, in glTF image order.
    pub images: Vec<Image>,
    /// glTF extensions that the materials and textures use
    /// (`KHR_texture_transform`, `KHR_materials_*`), declared again on write.
    pub extensions_used: Vec<String>,
}

impl Appearance {
    /// Whether there is nothing to carry.
    pub fn is_empty(&self) -> bool {
        self.textures.is_empty() && self.images.is_empty()
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn gather_and_push_agree() {
        let a = VertexAttributes {
            texcoords: vec![vec![[0.0, 1.0], [2.0, 3.0]], vec![[4.0, 5.0], [6.0, 7.0]]],
            colors: vec![[0.1, 0.2, 0.3, 1.0], [0.4, 0.5, 0.6, 0.5]],
            color_alpha: true,
            tangents: false,
            normals: vec![[0.0, 0.0, 1.0], [1.0, 0.0, 0.0]],
            dropped: Vec::new(),
        };
        assert_eq!(a.width(), 11);
        let mut b = a.empty_like();
        let mut buf = Vec::new();
        for v in 0..2 {
            buf.clear();
            a.gather(v, &mut buf);
            b.push(&buf, true, true);
        }
        assert_eq!(a, b);
        assert_eq!(a.select(&[1, 0]).texcoords[0], vec![[2.0, 3.0], [0.0, 1.0]]);
        assert!(a.check(2).is_ok());
        assert!(a.check(3).unwrap_err().contains("TEXCOORD_0"));
        assert_eq!(a.select(&[1]).normals, vec![[1.0, 0.0, 0.0]]);
    }

    #[test]
    fn srgb_round_trips_every_byte() {
        for b in 0..=255u8 {
            let lin = srgb_to_linear(f32::from(b) / 255.0);
            assert_eq!((linear_to_srgb(lin) * 255.0).round() as u8, b);
        }
    }

    #[test]
    fn images_are_sniffed() {
        assert_eq!(sniff_image(b"\x89PNG\r\n\x1a\n...."), Some("image/png"));
        assert_eq!(sniff_image(&[0xFF, 0xD8, 0xFF, 0xE0]), Some("image/jpeg"));
        assert_eq!(sniff_image(b"GIF89a"), None);
    }
}
