//! Companion files: the files a model names beside itself (a `.gltf`'s
//! buffers and images, an OBJ's material libraries and the texture maps
//! those name), how a reader finds one among the files the caller handed
//! in, and which names are safe to read from or write to a directory.
//!
//! The io layer never opens a file. A caller that may (the CLI) asks
//! [`companion_names`] what a model needs, reads those files itself from
//! the model's directory after checking them with [`is_plain_relative`],
//! and passes them in through [`super::ReadOptions::external_buffers`].

use std::collections::HashMap;

use super::gltf::percent_decode;
use super::{Format, IoError};

/// A file that a model names.
#[derive(Clone, Debug, PartialEq, Eq)]
pub struct Companion {
    /// The name as the model writes it (a glTF `uri`, an OBJ path).
    pub name: String,
    /// The relative path it stands for (percent-decoded for glTF, with
    /// `\` read as `/`), to be checked with [`is_plain_relative`].
    pub path: String,
    /// Whether the model cannot be read without it. An OBJ material
    /// library is optional: without it the reader keeps the material
    /// names and says what it dropped.
    pub required: bool,
}

/// Whether `path` is a plain relative path inside its directory: not
/// empty, no scheme, not absolute, no drive letter and no `..` component.
pub fn is_plain_relative(path: &str) -> bool {
    !path.is_empty()
        && !path.contains("://")
        && !path.starts_with(['/', '\\'])
        && path.as_bytes().get(1).is_none_or(|&c| c != b':')
        && !path.split(['/', '\\']).any(|c| c == "..")
}

/// The files that a model of `format` names, given the companions already
/// at hand in `have` (an OBJ's texture maps are named inside its material
/// libraries, so they appear once those are in `have`). `data:` URIs are
/// not files. Call again after adding files until nothing new appears.
pub fn companion_names(
    bytes: &[u8],
    format: Format,
    have: &HashMap<String, Vec<u8>>,
) -> Vec<Companion> {
    match format {
        Format::Gltf => gltf_names(bytes),
        Format::Obj => {
            let mut out: Vec<Companion> = Vec::new();
            for name in super::obj::mtllib_names(bytes) {
                if let Some(mtl) = find(have, &name) {
                    for map in super::mtl::map_names(mtl) {
                        push_new(&mut out, map, true);
                    }
                }
                push_new(&mut out, name, false);
            }
            out
        }
        _ => Vec::new(),
    }
}

fn push_new(out: &mut Vec<Companion>, name: String, required: bool) {
    if !out.iter().any(|c| c.name == name) {
        let path = name.replace('\\', "/");
        out.push(Companion {
            name,
            path,
            required,
        });
    }
}

/// The non-`data:` `uri`s of a `.gltf`'s buffers and images.
fn gltf_names(bytes: &[u8]) -> Vec<Companion> {
    let Ok(doc) = serde_json::from_slice::<serde_json::Value>(bytes) else {
        return Vec::new(); // the reader reports the parse error
    };
    let mut out = Vec::new();
    let named = ["buffers", "images"]
        .into_iter()
        .filter_map(|key| doc.get(key)?.as_array())
        .flatten();
    for uri in named.filter_map(|b| b.get("uri")?.as_str()) {
        if uri.starts_with("data:") || out.iter().any(|c: &Companion| c.name == uri) {
            continue;
        }
        // A malformed escape keeps the raw text, which then fails the
        // caller's path check or is reported missing by the reader.
        let path = percent_decode(uri).unwrap_or_else(|| uri.to_string());
        out.push(Companion {
            name: uri.to_string(),
            path: path.replace('\\', "/"),
            required: true,
        });
    }
    out
}

/// The keys under which a companion named `name` by its model may have
/// been handed in: as written, percent-decoded, with `\` read as `/`,
/// without a leading `./`, or by its last path component (the name a
/// browser gives an uploaded file), in that order of preference.
fn keys(name: &str) -> Vec<String> {
    let decoded = percent_decode(name).unwrap_or_else(|| name.to_string());
    let slashed = decoded.replace('\\', "/");
    let base = slashed.rsplit('/').next().unwrap_or(&slashed).to_string();
    let trimmed = slashed.trim_start_matches("./").to_string();
    vec![
        name.to_string(),
        decoded.clone(),
        slashed.clone(),
        trimmed,
        base,
    ]
}

/// A companion by the name the model gives it (see [`keys`]).
pub(crate) fn find<'a>(parts: &'a HashMap<String, Vec<u8>>, name: &str) -> Option<&'a Vec<u8>> {
    keys(name).iter().find_map(|k| parts.get(k))
}

/// Whether a file handed in as `part` is the companion the model names
/// `name`.
pub(crate) fn is_named(part: &str, name: &str) -> bool {
    keys(name).iter().any(|k| k == part)
}

/// [`find`], or the error that names the missing file.
pub(crate) fn require(
    parts: &HashMap<String, Vec<u8>>,
    name: &str,
    format: Format,
) -> Result<Vec<u8>, IoError> {
    find(parts, name)
        .cloned()
        .ok_or_else(|| IoError::ExternalBuffer {
            format,
            uri: name.to_string(),
        })
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn plain_relative_paths() {
        for ok in ["a.png", "tex/a b.png", "./a.mtl", "x..y.png"] {
            assert!(is_plain_relative(ok), "{ok}");
        }
        for bad in [
            "",
            "/etc/passwd",
            "../a.png",
            "a/../../b",
            "C:\\x.png",
            "http://h/a",
            "\\\\srv\\a",
        ] {
            assert!(!is_plain_relative(bad), "{bad}");
        }
    }

    #[test]
    fn found_by_decoded_slashed_or_base_name() {
        let parts = HashMap::from([
            ("tex/a b.png".to_string(), vec![1]),
            ("c.png".to_string(), vec![2]),
        ]);
        assert_eq!(find(&parts, "tex/a%20b.png"), Some(&vec![1]));
        assert_eq!(find(&parts, "tex\\a b.png"), Some(&vec![1]));
        assert_eq!(find(&parts, "maps\\c.png"), Some(&vec![2]));
        assert!(find(&parts, "d.png").is_none());
    }
}
