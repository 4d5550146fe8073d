//! The `result.mesh` codec: an exact binary form of [`TriMesh`] (positions
//! and normals as f64, triangles, face labels and the label table, vertex
//! attributes, and the textures and images byte for byte) that the
//! service stores next to each result so that it can re-encode it into any
//! format later. glTF would round positions to f32 and STL/OFF would drop
//! labels and normals, so none of the exchange formats serves.

use std::io;

use glam::DVec3;

use crate::appearance::Appearance;
use crate::scene::Scene;
use crate::trimesh::{Label, TriMesh};

/// Magic and version of `result.mesh`.
const MESH_MAGIC: &[u8; 8] = b"IRMESH03";
/// The version without the scene: still read.
const MESH_MAGIC_V2: &[u8; 8] = b"IRMESH02";
/// The version without attributes, appearance and scene: still read.
const MESH_MAGIC_V1: &[u8; 8] = b"IRMESH01";

fn put_u64(out: &mut Vec<u8>, v: u64) {
    out.extend_from_slice(&v.to_le_bytes());
}

/// Serialises a mesh exactly: magic, five u64 counts (positions, triangles,
/// normals, face labels, label-JSON bytes), then the arrays little-endian;
/// then the texture coordinate sets (a count, then per set its pairs), the
/// colours (a count, the alpha flag, RGBA quadruples), the appearance
/// (JSON bytes without the images, then per image its length and bytes),
/// and the scene (JSON bytes). An absent appearance or scene is the length
/// `u64::MAX`.
pub fn encode(m: &TriMesh) -> io::Result<Vec<u8>> {
    let labels = serde_json::to_vec(&m.labels).map_err(io::Error::other)?;
    let mut out =
        Vec::with_capacity(48 + m.positions.len() * 48 + m.triangles.len() * 16 + labels.len());
    out.extend_from_slice(MESH_MAGIC);
    for n in [
        m.positions.len(),
        m.triangles.len(),
        m.normals.len(),
        m.face_labels.len(),
        labels.len(),
    ] {
        put_u64(&mut out, n as u64);
    }
    for p in m.positions.iter().chain(&m.normals) {
        for c in p.to_array() {
            out.extend_from_slice(&c.to_le_bytes());
        }
    }
    for t in &m.triangles {
        for i in t {
            out.extend_from_slice(&i.to_le_bytes());
        }
    }
    for l in &m.face_labels {
        out.extend_from_slice(&l.to_le_bytes());
    }
    out.extend_from_slice(&labels);
    let a = &m.attributes;
    put_u64(&mut out, a.texcoords.len() as u64);
    for set in &a.texcoords {
        put_u64(&mut out, set.len() as u64);
        for x in set.iter().flatten() {
            out.extend_from_slice(&x.to_le_bytes());
        }
    }
    put_u64(&mut out, a.colors.len() as u64);
    // Bit 0: the colours carry alpha; bit 1: the mesh carries tangents.
    out.push(u8::from(a.color_alpha) | (u8::from(a.tangents) << 1));
    for x in a.colors.iter().flatten() {
        out.extend_from_slice(&x.to_le_bytes());
    }
    match &m.appearance {
        None => put_u64(&mut out, u64::MAX),
        Some(look) => {
            let meta = serde_json::to_vec(&**look).map_err(io::Error::other)?;
            put_u64(&mut out, meta.len() as u64);
            out.extend_from_slice(&meta);
            put_u64(&mut out, look.images.len() as u64);
            for img in &look.images {
                put_u64(&mut out, img.bytes.len() as u64);
                out.extend_from_slice(&img.bytes);
            }
        }
    }
    match &m.scene {
        None => put_u64(&mut out, u64::MAX),
        Some(scene) => {
            let meta = serde_json::to_vec(&**scene).map_err(io::Error::other)?;
            put_u64(&mut out, meta.len() as u64);
            out.extend_from_slice(&meta);
        }
    }
    Ok(out)
}

struct Reader<'a>(&'a [u8]);

impl Reader<'_> {
    fn take(&mut self, n: usize) -> io::Result<&[u8]> {
        if n > self.0.len() {
            return Err(io::Error::new(
                io::ErrorKind::InvalidData,
                "result.mesh is truncated",
            ));
        }
        let (a, b) = self.0.split_at(n);
        self.0 = b;
        Ok(a)
    }
    fn u64(&mut self) -> io::Result<u64> {
        let b = self.take(8)?;
        Ok(u64::from_le_bytes(b.try_into().map_err(io::Error::other)?))
    }
    fn count(&mut self, elem: usize) -> io::Result<usize> {
        let n = usize::try_from(self.u64()?).map_err(io::Error::other)?;
        if n.checked_mul(elem).is_none_or(|b| b > self.0.len()) {
            return Err(io::Error::new(
                io::ErrorKind::InvalidData,
                "result.mesh count out of range",
            ));
        }
        Ok(n)
    }
    fn f64(&mut self) -> io::Result<f64> {
        Ok(f64::from_bits(self.u64()?))
    }
    fn u32(&mut self) -> io::Result<u32> {
        let b = self.take(4)?;
        Ok(u32::from_le_bytes(b.try_into().map_err(io::Error::other)?))
    }
    fn f32(&mut self) -> io::Result<f32> {
        Ok(f32::from_bits(self.u32()?))
    }
    fn vec3(&mut self) -> io::Result<DVec3> {
        Ok(DVec3::new(self.f64()?, self.f64()?, self.f64()?))
    }
}

/// Reads [`encode`]'s format back, checking every count and the mesh's
/// invariants.
pub fn decode(bytes: &[u8]) -> io::Result<TriMesh> {
    let mut r = Reader(bytes);
    let magic = r.take(8)?;
    let v3 = magic == MESH_MAGIC;
    let v2 = v3 || magic == MESH_MAGIC_V2;
    if !v2 && magic != MESH_MAGIC_V1 {
        return Err(io::Error::new(
            io::ErrorKind::InvalidData,
            "not a result.mesh file",
        ));
    }
    let np = r.count(24)?;
    let nt = r.count(12)?;
    let nn = r.count(24)?;
    let nl = r.count(4)?;
    let nj = r.count(1)?;
    let positions = (0..np).map(|_| r.vec3()).collect::<io::Result<_>>()?;
    let normals = (0..nn).map(|_| r.vec3()).collect::<io::Result<_>>()?;
    let triangles = (0..nt)
        .map(|_| Ok([r.u32()?, r.u32()?, r.u32()?]))
        .collect::<io::Result<_>>()?;
    let face_labels = (0..nl).map(|_| r.u32()).collect::<io::Result<_>>()?;
    let labels = serde_json::from_slice::<Vec<Label>>(r.take(nj)?).map_err(io::Error::other)?;
    let mut m = TriMesh {
        positions,
        triangles,
        normals,
        face_labels,
        labels,
        ..Default::default()
    };
    if v2 {
        let sets = r.count(8)?;
        for _ in 0..sets {
            let n = r.count(8)?;
            let set = (0..n)
                .map(|_| Ok([r.f32()?, r.f32()?]))
                .collect::<io::Result<_>>()?;
            m.attributes.texcoords.push(set);
        }
        let nc = r.count(16)?;
        let flags = r.take(1)?[0];
        m.attributes.color_alpha = flags & 1 != 0;
        m.attributes.tangents = flags & 2 != 0;
        m.attributes.colors = (0..nc)
            .map(|_| Ok([r.f32()?, r.f32()?, r.f32()?, r.f32()?]))
            .collect::<io::Result<_>>()?;
        let meta_len = r.u64()?;
        if meta_len != u64::MAX {
            let meta = r.take(usize::try_from(meta_len).map_err(io::Error::other)?)?;
            let mut look: Appearance = serde_json::from_slice(meta).map_err(io::Error::other)?;
            let ni = r.count(8)?;
            if ni != look.images.len() {
                return Err(io::Error::new(
                    io::ErrorKind::InvalidData,
                    "result.mesh image count differs from its metadata",
                ));
            }
            for img in &mut look.images {
                let n = r.count(1)?;
                img.bytes = r.take(n)?.to_vec();
            }
            m.appearance = Some(std::sync::Arc::new(look));
        }
    }
    if v3 {
        let len = r.u64()?;
        if len != u64::MAX {
            let meta = r.take(usize::try_from(len).map_err(io::Error::other)?)?;
            let scene: Scene = serde_json::from_slice(meta).map_err(io::Error::other)?;
            m.scene = Some(std::sync::Arc::new(scene));
        }
    }
    m.check()
        .map_err(|e| io::Error::new(io::ErrorKind::InvalidData, e))?;
    Ok(m)
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::appearance::Image;
    use crate::trimesh::Material;

    #[test]
    fn result_mesh_round_trips_exactly() {
        let mut m = crate::shapes::icosphere(1);
        m.positions[0].x += 1e-13;
        m.normals = m.positions.iter().map(|p| p.normalize()).collect();
        m.face_labels = (0..m.triangles.len() as u32).map(|f| f % 2).collect();
        m.labels = vec![
            Label::default(),
            Label {
                name: Some("red".into()),
                material: Some(Material {
                    base_color_factor: [1.0, 0.0, 0.0, 1.0],
                    ..Default::default()
                }),
                part: Some(1),
                texcoord_sets: Some(0),
            },
        ];
        m.scene = Some(std::sync::Arc::new(Scene {
            parts: vec![
                crate::scene::Part::named(None),
                crate::scene::Part::named(Some("lid".into())),
            ],
            gltf: Some(serde_json::json!({"nodes": [{"name": "lid", "mesh": 1}]})),
        }));
        m.attributes.texcoords = vec![m
            .positions
            .iter()
            .map(|p| [p.x as f32, p.y as f32])
            .collect()];
        m.attributes.colors = vec![[0.5, 0.25, 1.0, 0.75]; m.positions.len()];
        m.attributes.color_alpha = true;
        m.appearance = Some(std::sync::Arc::new(Appearance {
            textures: vec![serde_json::json!({"source": 0})],
            images: vec![Image {
                mime_type: Some("image/png".into()),
                bytes: vec![1, 2, 3, 0, 255],
                ..Default::default()
            }],
            ..Default::default()
        }));
        let bytes = encode(&m).unwrap();
        assert_eq!(decode(&bytes).unwrap(), m);
        for cut in [0, 7, 20, bytes.len() / 2, bytes.len() - 1] {
            assert!(decode(&bytes[..cut]).is_err(), "cut at {cut}");
        }
    }
}
