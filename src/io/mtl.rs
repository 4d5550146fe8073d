//! Wavefront material libraries (`.mtl`), read through `tobj::load_mtl_buf`
//! into the one material form every writer reads ([`crate::Material`] with
//! its glTF JSON, and an [`Appearance`] holding the texture images byte for
//! byte), and written back from that form.
//!
//! The mapping follows the common Phong-to-PBR reading: `Kd` and `d` (or
//! `1 − Tr`) give the base colour, `Ke` the emission, `Pm` and `Pr` (the PBR
//! extension of the format) or else `Ns` through `√(2 / (Ns + 2))` the
//! metallic and roughness factors. `map_Kd` becomes the base-colour
//! texture, `map_Bump`, `bump` or `norm` the normal texture, `map_Ke` the
//! emissive texture. Maps glTF's metallic-roughness model has no slot for
//! (`map_Ks`, `map_Ns`, `map_d`, `map_Ka`, `disp`, `refl`) are named as
//! dropped. Map options (`-s`, `-o`, `-bm`, …) are skipped; the file name is
//! what follows them.

use std::collections::HashMap;
use std::io::Write;

use serde_json::{json, Value};

use super::{companions, Format, IoError};
use crate::appearance::{Appearance, DroppedAttribute, Image};
use crate::{Material, TriMesh};

/// The options a map statement may carry before its file name, with the
/// most numbers each takes (`-o`, `-s` and `-t` take one to three).
const MAP_OPTIONS: [(&str, usize); 13] = [
    ("-blendu", 1),
    ("-blendv", 1),
    ("-boost", 1),
    ("-cc", 1),
    ("-clamp", 1),
    ("-imfchan", 1),
    ("-mm", 2),
    ("-o", 3),
    ("-s", 3),
    ("-t", 3),
    ("-texres", 1),
    ("-bm", 1),
    ("-type", 1),
];

/// The file name of a map statement's argument, after its options.
pub(super) fn map_file(arg: &str) -> Option<String> {
    let words: Vec<&str> = arg.split_whitespace().collect();
    let mut i = 0;
    while i < words.len() {
        let Some(&(_, most)) = MAP_OPTIONS.iter().find(|(o, _)| *o == words[i]) else {
            break;
        };
        i += 1;
        // The first argument is always taken; further ones only if numeric.
        let mut taken = 0;
        while i < words.len() && taken < most && (taken == 0 || words[i].parse::<f64>().is_ok()) {
            i += 1;
            taken += 1;
        }
    }
    let name = words.get(i..)?.join(" ");
    (!name.is_empty()).then_some(name)
}

/// The maps a material can carry, by glTF slot: (slot, statements).
const CARRIED: [(&str, &[&str]); 3] = [
    ("baseColorTexture", &["map_Kd"]),
    ("normalTexture", &["map_Bump", "map_bump", "bump", "norm"]),
    ("emissiveTexture", &["map_Ke"]),
];

/// Map statements glTF's model has no slot for.
const NOT_CARRIED: [&str; 7] = [
    "map_Ks", "map_Ns", "map_d", "map_Ka", "disp", "refl", "map_Pr",
];

/// The raw argument of map statement `key` in material `m`, if present.
fn statement<'a>(m: &'a tobj::Material, key: &str) -> Option<&'a str> {
    match key {
        "map_Kd" => m.diffuse_texture.as_deref(),
        "map_Bump" | "map_bump" | "bump" => m.normal_texture.as_deref(),
        "map_Ks" => m.specular_texture.as_deref(),
        "map_Ns" => m.shininess_texture.as_deref(),
        "map_d" => m.dissolve_texture.as_deref(),
        "map_Ka" => m.ambient_texture.as_deref(),
        other => m.unknown_param.get(other).map(String::as_str),
    }
}

/// Parses a material library, naming it in the error.
pub(super) fn parse(name: &str, bytes: &[u8]) -> Result<Vec<tobj::Material>, IoError> {
    let text = std::str::from_utf8(bytes).map_err(|_| {
        IoError::parse(
            Format::Obj,
            format!("material library {name:?} is not UTF-8 text"),
        )
    })?;
    let mut reader = std::io::BufReader::new(text.as_bytes());
    tobj::load_mtl_buf(&mut reader)
        .map(|(m, _)| m)
        .map_err(|e| IoError::parse(Format::Obj, format!("material library {name:?}: {e}")))
}

/// The texture files a material library names in the slots that are
/// carried (an unparsable library names none; reading it reports why).
pub(crate) fn map_names(bytes: &[u8]) -> Vec<String> {
    let Ok(mats) = parse("", bytes) else {
        return Vec::new();
    };
    let mut out: Vec<String> = Vec::new();
    for m in &mats {
        for (_, keys) in CARRIED {
            if let Some(file) = keys.iter().find_map(|k| statement(m, k)).and_then(map_file) {
                if !out.contains(&file) {
                    out.push(file);
                }
            }
        }
    }
    out
}

/// Builds the materials and their textures while an OBJ is read.
#[derive(Default)]
pub(super) struct LookBuilder {
    look: Appearance,
    /// Texture index by map file name, so that a shared image is stored once.
    texture_of: HashMap<String, usize>,
    /// What was found but cannot be carried.
    pub dropped: Vec<DroppedAttribute>,
}

impl LookBuilder {
    /// The material for `m`, its maps read from `parts`.
    pub(super) fn material(
        &mut self,
        m: &tobj::Material,
        parts: &HashMap<String, Vec<u8>>,
    ) -> Result<Material, IoError> {
        let param = |k: &str| -> Option<f32> { m.unknown_param.get(k)?.trim().parse().ok() };
        let kd = m.diffuse.map_or([1.0; 3], |c| c.map(|x| x as f32));
        let alpha = m
            .dissolve
            .map(|d| d as f32)
            .or_else(|| param("Tr").map(|t| 1.0 - t))
            .unwrap_or(1.0)
            .clamp(0.0, 1.0);
        let roughness = param("Pr")
            .or_else(|| {
                m.shininess
                    .map(|ns| (2.0 / (ns.max(0.0) as f32 + 2.0)).sqrt())
            })
            .unwrap_or(1.0)
            .clamp(0.0, 1.0);
        let metallic = param("Pm").unwrap_or(0.0).clamp(0.0, 1.0);
        let mut textures: Vec<(&str, usize)> = Vec::new();
        for (slot, keys) in CARRIED {
            if let Some(file) = keys.iter().find_map(|k| statement(m, k)).and_then(map_file) {
                textures.push((slot, self.texture(&file, parts)?));
            }
        }
        for key in NOT_CARRIED {
            if statement(m, key).is_some() {
                self.dropped.push(DroppedAttribute {
                    name: format!("{key} of material {}", m.name),
                    reason: "glTF's metallic-roughness material has no slot for it".into(),
                });
            }
        }
        let has = |slot: &str| textures.iter().any(|(s, _)| *s == slot);
        let emissive =
            m.emissive
                .map(|c| c.map(|x| x as f32))
                .unwrap_or(if has("emissiveTexture") {
                    [1.0; 3]
                } else {
                    [0.0; 3]
                });
        let base = [kd[0], kd[1], kd[2], alpha];
        let gltf = (!textures.is_empty() || alpha < 1.0).then(|| {
            let mut pbr = json!({
                "baseColorFactor": base,
                "metallicFactor": metallic,
                "roughnessFactor": roughness,
            });
            let mut doc = json!({ "name": m.name, "emissiveFactor": emissive });
            for (slot, index) in &textures {
                if *slot == "baseColorTexture" {
                    pbr[*slot] = json!({ "index": index });
                } else {
                    doc[*slot] = json!({ "index": index });
                }
            }
            doc["pbrMetallicRoughness"] = pbr;
            if alpha < 1.0 {
                doc["alphaMode"] = "BLEND".into();
            }
            doc
        });
        Ok(Material {
            name: Some(m.name.clone()),
            base_color_factor: base,
            metallic_factor: metallic,
            roughness_factor: roughness,
            emissive_factor: emissive,
            double_sided: false,
            gltf,
        })
    }

    /// The texture index of map `file`, reading its image on first use.
    fn texture(&mut self, file: &str, parts: &HashMap<String, Vec<u8>>) -> Result<usize, IoError> {
        if let Some(&t) = self.texture_of.get(file) {
            return Ok(t);
        }
        let bytes = companions::require(parts, file, Format::Obj)?;
        let t = self.look.images.len();
        self.look.images.push(Image {
            name: None,
            mime_type: crate::appearance::sniff_image(&bytes).map(str::to_string),
            uri: Some(file.replace('\\', "/")),
            bytes,
        });
        self.look.textures.push(json!({ "source": t }));
        self.texture_of.insert(file.to_string(), t);
        Ok(t)
    }

    /// The appearance built, if any material had a texture.
    pub(super) fn finish(self) -> Option<Appearance> {
        (!self.look.is_empty()).then_some(self.look)
    }
}

/// The file name each image of `look` is written under next to `stem.obj`:
/// its own relative name when it has a plain one, else `stem_<i>.<ext>`;
/// distinct in any case.
pub(crate) fn image_file_names(look: &Appearance, stem: &str) -> Vec<String> {
    let mut names: Vec<String> = Vec::with_capacity(look.images.len());
    for (i, img) in look.images.iter().enumerate() {
        let ext = match img.media_type() {
            Some("image/png") => "png",
            Some("image/jpeg") => "jpg",
            Some("image/webp") => "webp",
            Some("image/ktx2") => "ktx2",
            _ => "bin",
        };
        let own = img
            .uri
            .as_deref()
            .filter(|u| companions::is_plain_relative(u) && !u.contains(char::is_control));
        let mut name = own.map_or_else(|| format!("{stem}_{i}.{ext}"), str::to_string);
        if names.contains(&name) {
            name = format!("{stem}_{i}.{ext}");
        }
        names.push(name);
    }
    names
}

/// A texture reference's image file: `textures[index].source` of `look`.
fn image_of(look: &Appearance, reference: &Value, files: &[String]) -> Option<String> {
    let t = reference.get("index")?.as_u64()? as usize;
    let source = look.textures.get(t)?.get("source")?.as_u64()? as usize;
    files.get(source).cloned()
}

/// Writes the material library of `mesh`: one `newmtl` per entry of
/// `names` (the `usemtl` names of its labels), texture maps naming
/// `image_files`.
pub(super) fn write(mesh: &TriMesh, names: &[String], image_files: &[String]) -> Vec<u8> {
    let mut out = Vec::new();
    let _ = writeln!(out, "# isoremesh {}", env!("CARGO_PKG_VERSION"));
    let look = mesh.appearance.as_deref();
    for (label, name) in mesh.labels.iter().zip(names) {
        let m = label.material.clone().unwrap_or_default();
        let g = m.gltf.as_ref();
        let pbr = g.and_then(|g| g.get("pbrMetallicRoughness"));
        let floats = |v: Option<&Value>, n: usize| -> Option<Vec<f64>> {
            let a = v?.as_array()?;
            let f: Vec<f64> = a.iter().filter_map(Value::as_f64).collect();
            (f.len() == n).then_some(f)
        };
        let base = floats(pbr.and_then(|p| p.get("baseColorFactor")), 4)
            .unwrap_or_else(|| m.base_color_factor.iter().map(|&x| f64::from(x)).collect());
        let emissive = floats(g.and_then(|g| g.get("emissiveFactor")), 3)
            .unwrap_or_else(|| m.emissive_factor.iter().map(|&x| f64::from(x)).collect());
        let scalar = |k: &str, d: f32| pbr.and_then(|p| p.get(k)?.as_f64()).unwrap_or(f64::from(d));
        let roughness = scalar("roughnessFactor", m.roughness_factor).clamp(0.0, 1.0);
        let metallic = scalar("metallicFactor", m.metallic_factor).clamp(0.0, 1.0);
        let _ = writeln!(out, "\nnewmtl {name}");
        let _ = writeln!(out, "Kd {} {} {}", base[0], base[1], base[2]);
        let _ = writeln!(out, "d {}", base[3]);
        let _ = writeln!(out, "Ke {} {} {}", emissive[0], emissive[1], emissive[2]);
        // Inverse of the reading's √(2 / (Ns + 2)), bounded for rough = 0.
        let ns = (2.0 / (roughness * roughness).max(1e-4) - 2.0).clamp(0.0, 1000.0);
        let _ = writeln!(out, "Ns {ns}");
        let _ = writeln!(out, "Pr {roughness}\nPm {metallic}");
        let _ = writeln!(out, "illum 2");
        if let (Some(look), Some(g)) = (look, g) {
            let maps = [
                ("map_Kd", pbr.and_then(|p| p.get("baseColorTexture"))),
                ("map_Bump", g.get("normalTexture")),
                ("map_Ke", g.get("emissiveTexture")),
            ];
            for (key, reference) in maps {
                if let Some(file) = reference.and_then(|r| image_of(look, r, image_files)) {
                    let _ = writeln!(out, "{key} {file}");
                }
            }
        }
    }
    out
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn map_options_are_skipped() {
        assert_eq!(map_file("tex.png").as_deref(), Some("tex.png"));
        assert_eq!(
            map_file("-s 2 2 1 -o 0.5 tex.png").as_deref(),
            Some("tex.png")
        );
        assert_eq!(
            map_file("-bm 0.3 my normal.png").as_deref(),
            Some("my normal.png")
        );
        assert_eq!(map_file("-clamp on").as_deref(), None);
    }
}
