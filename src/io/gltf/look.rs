//! The appearance side of glTF: materials as the file wrote them (texture
//! references and extensions included), and the textures, samplers and
//! images they use, read from the input and written back unchanged. Image
//! bytes are copied, never decoded or re-encoded.

use serde::Deserialize;
use serde_json::Value;

use super::access::{decode_data_uri, percent_decode, Buffers};
use crate::appearance::{Appearance, Image};
use crate::io::{Format, IoError};

/// The parts of a glTF document that the typed reader would lose: kept as
/// JSON so that any extension survives.
#[derive(Deserialize, Default)]
pub(super) struct RawLook {
    #[serde(default)]
    materials: Vec<Value>,
    #[serde(default)]
    textures: Vec<Value>,
    #[serde(default)]
    samplers: Vec<Value>,
    #[serde(default)]
    images: Vec<Value>,
    #[serde(default, rename = "extensionsUsed")]
    extensions_used: Vec<String>,
}

/// Extensions that concern geometry or the scene, which the written file
/// does not use.
const NOT_CARRIED: [&str; 5] = [
    "KHR_draco_mesh_compression",
    "EXT_meshopt_compression",
    "KHR_meshopt_compression",
    "KHR_mesh_quantization",
    "EXT_mesh_gpu_instancing",
];

impl RawLook {
    /// Reads the appearance parts of the document text.
    pub(super) fn parse(json: &[u8], format: Format) -> Result<Self, IoError> {
        serde_json::from_slice(json).map_err(|e| IoError::parse(format, format!("JSON: {e}")))
    }

    /// The material `i` as JSON when it carries more than the factors that
    /// [`crate::Material`] holds: a texture or an extension other than
    /// the emissive strength.
    pub(super) fn verbatim_material(&self, i: usize) -> Option<Value> {
        let m = self.materials.get(i)?;
        let has_texture = ["normalTexture", "occlusionTexture", "emissiveTexture"]
            .iter()
            .any(|k| m.get(k).is_some())
            || m.get("pbrMetallicRoughness").is_some_and(|p| {
                p.get("baseColorTexture").is_some() || p.get("metallicRoughnessTexture").is_some()
            });
        let other_extension = m
            .get("extensions")
            .and_then(Value::as_object)
            .is_some_and(|e| e.keys().any(|k| k != "KHR_materials_emissive_strength"));
        (has_texture || other_extension).then(|| m.clone())
    }

    /// The textures, samplers and images of the document, images read from
    /// their buffer view, `data:` URI or external part. `None` when the
    /// document has no texture.
    pub(super) fn appearance(&self, buffers: &mut Buffers) -> Result<Option<Appearance>, IoError> {
        if self.textures.is_empty() {
            return Ok(None);
        }
        let format = buffers.format;
        let mut images = Vec::with_capacity(self.images.len());
        for (i, img) in self.images.iter().enumerate() {
            let text = |k: &str| img.get(k).and_then(Value::as_str).map(str::to_string);
            let (bytes, uri) = if let Some(v) = img.get("bufferView").and_then(Value::as_u64) {
                (view_bytes(buffers, v as usize, i)?, None)
            } else if let Some(uri) = text("uri") {
                if uri.starts_with("data:") {
                    let b = decode_data_uri(&uri)
                        .map_err(|m| IoError::parse(format, format!("image {i}: {m}")))?;
                    (b, None)
                } else {
                    (
                        crate::io::companions::require(
                            &buffers.opts.external_buffers,
                            &uri,
                            format,
                        )?,
                        Some(uri),
                    )
                }
            } else {
                return Err(IoError::parse(
                    format,
                    format!("image {i} has neither a bufferView nor a uri"),
                ));
            };
            images.push(Image {
                name: text("name"),
                mime_type: text("mimeType"),
                uri: uri.map(|u| percent_decode(&u).unwrap_or(u)),
                bytes,
            });
        }
        Ok(Some(Appearance {
            textures: self.textures.clone(),
            samplers: self.samplers.clone(),
            images,
            extensions_used: self
                .extensions_used
                .iter()
                .filter(|e| !NOT_CARRIED.contains(&e.as_str()))
                .cloned()
                .collect(),
        }))
    }
}

/// The bytes of buffer view `v`, for image `image`.
fn view_bytes(buffers: &mut Buffers, v: usize, image: usize) -> Result<Vec<u8>, IoError> {
    let format = buffers.format;
    let Some(view) = buffers.root.buffer_views.get(v) else {
        return Err(IoError::parse(
            format,
            format!("image {image} uses buffer view {v}, which does not exist"),
        ));
    };
    let b = view.buffer.value();
    let start = view.byte_offset.map_or(0, |o| o.0);
    let end = start.saturating_add(view.byte_length.0);
    let buffer = buffers.get(b)?;
    if end > buffer.len() as u64 {
        return Err(IoError::AccessorOutOfBounds {
            accessor: usize::MAX,
            within: format!("buffer {b} (image {image} through buffer view {v})"),
            needed: end,
            available: buffer.len() as u64,
        });
    }
    Ok(buffer[start as usize..end as usize].to_vec())
}

/// Writes `look` into the serialised document `doc`: textures and samplers
/// as they were, images as `data:` URIs (`.gltf`) or as the buffer views
/// `image_views` (GLB, one per image, already in the binary chunk), and the
/// extensions they use.
pub(super) fn write_look(doc: &mut Value, look: &Appearance, image_views: Option<&[usize]>) {
    use base64::Engine;
    doc["textures"] = Value::Array(look.textures.clone());
    if !look.samplers.is_empty() {
        doc["samplers"] = Value::Array(look.samplers.clone());
    }
    let images = look
        .images
        .iter()
        .enumerate()
        .map(|(i, img)| {
            let mut o = serde_json::Map::new();
            if let Some(n) = &img.name {
                o.insert("name".into(), n.clone().into());
            }
            let mime = img.media_type().unwrap_or("application/octet-stream");
            match image_views {
                Some(views) => {
                    o.insert("bufferView".into(), views[i].into());
                    o.insert("mimeType".into(), mime.into());
                }
                None => {
                    let data = base64::engine::general_purpose::STANDARD.encode(&img.bytes);
                    o.insert("uri".into(), format!("data:{mime};base64,{data}").into());
                }
            }
            Value::Object(o)
        })
        .collect();
    doc["images"] = Value::Array(images);
    if !look.extensions_used.is_empty() {
        let used = doc["extensionsUsed"]
            .as_array()
            .cloned()
            .unwrap_or_default();
        let mut used: Vec<String> = used
            .iter()
            .filter_map(|v| v.as_str().map(str::to_string))
            .collect();
        for e in &look.extensions_used {
            if !used.contains(e) {
                used.push(e.clone());
            }
        }
        doc["extensionsUsed"] = used.into();
    }
}
