//! Textured test inputs built in code: a procedural checker texture, and
//! any mesh as a soup carrying per-corner texture coordinates and one
//! base-colour material.

use std::sync::Arc;

use glam::DVec3;
use isoremesh::appearance::{Appearance, Image};
use isoremesh::{Label, Material, TriMesh};
use serde_json::json;

/// A 256² PNG checker of 8×8 squares in four colours.
pub fn checker_png() -> Vec<u8> {
    let img = image::RgbaImage::from_fn(256, 256, |x, y| {
        let (i, j) = (x / 32, y / 32);
        let c = [[230, 40, 40], [40, 200, 60], [40, 60, 220], [240, 220, 40]]
            [((i + 2 * j) % 4) as usize];
        image::Rgba([c[0], c[1], c[2], 255])
    });
    let mut out = std::io::Cursor::new(Vec::new());
    img.write_to(&mut out, image::ImageFormat::Png).unwrap();
    out.into_inner()
}

/// `mesh` as a soup with per-corner texture coordinates from `uv` (given a
/// face's three corner positions) and one base-colour texture.
pub fn textured_soup(
    mesh: &TriMesh,
    uv: impl Fn([DVec3; 3]) -> [[f32; 2]; 3],
    png: &[u8],
) -> TriMesh {
    let mut soup = TriMesh::default();
    let mut coords = Vec::new();
    for t in &mesh.triangles {
        let p = mesh.corner_positions(t);
        let base = soup.positions.len() as u32;
        soup.positions.extend(p);
        coords.extend(uv(p));
        soup.triangles.push([base, base + 1, base + 2]);
    }
    soup.attributes.texcoords = vec![coords];
    soup.face_labels = vec![0; soup.triangles.len()];
    soup.labels = vec![Label {
        name: Some("checker".into()),
        material: Some(Material {
            name: Some("checker".into()),
            gltf: Some(json!({
                "name": "checker",
                "pbrMetallicRoughness": {"baseColorTexture": {"index": 0}, "metallicFactor": 0.0}
            })),
            ..Default::default()
        }),
        part: None,
        texcoord_sets: None,
    }];
    soup.appearance = Some(Arc::new(Appearance {
        textures: vec![json!({"source": 0, "sampler": 0})],
        samplers: vec![json!({"wrapS": 10497, "wrapT": 10497})],
        images: vec![Image {
            mime_type: Some("image/png".into()),
            bytes: png.to_vec(),
            ..Default::default()
        }],
        extensions_used: vec![],
    }));
    soup
}

/// The JSON chunk of a GLB.
pub fn glb_json(glb: &[u8]) -> serde_json::Value {
    let len = u32::from_le_bytes(glb[12..16].try_into().unwrap()) as usize;
    serde_json::from_slice(&glb[20..20 + len]).unwrap()
}

/// `glb` with its JSON chunk changed by `edit`.
pub fn edit_glb(glb: &[u8], edit: impl FnOnce(&mut serde_json::Value)) -> Vec<u8> {
    let json_len = u32::from_le_bytes(glb[12..16].try_into().unwrap()) as usize;
    let mut doc = glb_json(glb);
    edit(&mut doc);
    let mut text = serde_json::to_vec(&doc).unwrap();
    while text.len() % 4 != 0 {
        text.push(b' ');
    }
    let bin = &glb[20 + json_len..];
    let mut out = b"glTF".to_vec();
    out.extend_from_slice(&2u32.to_le_bytes());
    out.extend_from_slice(&((12 + 8 + text.len() + bin.len()) as u32).to_le_bytes());
    out.extend_from_slice(&(text.len() as u32).to_le_bytes());
    out.extend_from_slice(b"JSON");
    out.extend_from_slice(&text);
    out.extend_from_slice(bin);
    out
}
