//! Which mesh format a byte string is: by explicit choice, by file
//! extension, by MIME type, or by sniffing the first bytes (glTF binary
//! header, the `ply` / `OFF` keywords, the `solid` keyword or size rule of
//! STL, JSON with an `"asset"` member, OBJ statement keywords).

use std::fmt;
use std::str::FromStr;

use serde::{Deserialize, Serialize};

use super::IoError;

/// A mesh file format isoremesh reads and writes.
#[derive(Clone, Copy, Debug, PartialEq, Eq, Hash, Serialize, Deserialize)]
#[serde(rename_all = "lowercase")]
pub enum Format {
    /// Wavefront OBJ (text).
    Obj,
    /// glTF 2.0 JSON with embedded or provided buffers.
    Gltf,
    /// glTF 2.0 binary container.
    Glb,
    /// STL, binary or ASCII.
    Stl,
    /// Stanford PLY, ASCII or binary.
    Ply,
    /// Object File Format (Geomview OFF), text.
    Off,
}

/// Size of a binary STL file with `n` triangles: 80-byte header, a u32
/// count, then 50 bytes per triangle.
pub(crate) fn binary_stl_size(bytes: &[u8]) -> Option<u64> {
    let count = bytes.get(80..84)?;
    let n = u32::from_le_bytes([count[0], count[1], count[2], count[3]]);
    Some(84 + 50 * u64::from(n))
}

impl Format {
    /// Every format, in a stable order.
    pub const ALL: [Format; 6] = [
        Format::Obj,
        Format::Gltf,
        Format::Glb,
        Format::Stl,
        Format::Ply,
        Format::Off,
    ];

    /// The format named by a file extension or a whole file name
    /// (case-insensitive): `"glb"`, `".glb"` and `"model.GLB"` all give
    /// [`Format::Glb`].
    pub fn from_extension(ext_or_filename: &str) -> Option<Format> {
        let ext = match ext_or_filename.rfind('.') {
            Some(i) => &ext_or_filename[i + 1..],
            None => ext_or_filename,
        };
        Self::ALL
            .into_iter()
            .find(|f| f.extension().eq_ignore_ascii_case(ext.trim()))
    }

    /// The format a MIME type stands for. Parameters such as `; charset=utf-8`
    /// are ignored; generic types such as `application/octet-stream` give `None`.
    pub fn from_mime(mime: &str) -> Option<Format> {
        let essence = mime.split(';').next().unwrap_or("").trim();
        let known: [(&str, Format); 14] = [
            ("model/gltf-binary", Format::Glb),
            ("model/gltf+json", Format::Gltf),
            ("model/obj", Format::Obj),
            ("text/x-obj", Format::Obj),
            ("application/x-tgif", Format::Obj),
            ("model/stl", Format::Stl),
            ("model/x.stl-binary", Format::Stl),
            ("model/x.stl-ascii", Format::Stl),
            ("application/sla", Format::Stl),
            ("application/vnd.ms-pki.stl", Format::Stl),
            ("model/x-ply", Format::Ply),
            ("application/ply", Format::Ply),
            ("application/x-ply", Format::Ply),
            ("model/x-off", Format::Off),
        ];
        known
            .iter()
            .find(|(m, _)| m.eq_ignore_ascii_case(essence))
            .map(|&(_, f)| f)
            .or_else(|| {
                ["application/off", "application/x-off"]
                    .iter()
                    .any(|m| m.eq_ignore_ascii_case(essence))
                    .then_some(Format::Off)
            })
    }

    /// Guesses the format from the content. Binary signatures are checked
    /// before text heuristics; `None` when nothing matches.
    pub fn from_magic(bytes: &[u8]) -> Option<Format> {
        if bytes.starts_with(b"glTF") {
            return Some(Format::Glb);
        }
        let text = skip_bom_and_space(bytes);
        if text.starts_with(b"ply") && matches!(text.get(3), Some(b'\n' | b'\r')) {
            return Some(Format::Ply);
        }
        if first_word(text).is_some_and(is_off_keyword) {
            return Some(Format::Off);
        }
        // A binary STL header may itself start with "solid", so the size
        // rule wins over the keyword. Some writers append a few bytes.
        let len = bytes.len() as u64;
        let binary_stl = binary_stl_size(bytes).is_some_and(|n| n <= len && len - n <= 1024);
        if binary_stl {
            return Some(Format::Stl);
        }
        if text.starts_with(b"solid") {
            let head = &text[..text.len().min(4096)];
            if contains(head, b"facet") || contains(head, b"endsolid") {
                return Some(Format::Stl);
            }
        }
        if text.starts_with(b"{") && contains(&text[..text.len().min(1 << 20)], b"\"asset\"") {
            return Some(Format::Gltf);
        }
        if looks_like_obj(text) {
            return Some(Format::Obj);
        }
        None
    }

    /// Picks the format: an explicit choice wins, then the file name's
    /// extension, then the content.
    pub fn detect(
        file_name: Option<&str>,
        bytes: &[u8],
        explicit: Option<Format>,
    ) -> Result<Format, IoError> {
        if let Some(f) = explicit {
            return Ok(f);
        }
        if let Some(f) = file_name.and_then(Format::from_extension) {
            return Ok(f);
        }
        Format::from_magic(bytes).ok_or_else(|| IoError::UnknownFormat {
            hint: match file_name {
                Some(name) => format!("neither the name {name:?} nor the content identifies it"),
                None => "the content does not identify it".to_string(),
            },
        })
    }

    /// Whether the format can carry per-element attributes (see
    /// [`super::Attributes`]): glTF, GLB and PLY.
    pub fn stores_attributes(self) -> bool {
        matches!(self, Format::Gltf | Format::Glb | Format::Ply)
    }

    /// The usual file extension, without the dot.
    pub fn extension(self) -> &'static str {
        match self {
            Format::Obj => "obj",
            Format::Gltf => "gltf",
            Format::Glb => "glb",
            Format::Stl => "stl",
            Format::Ply => "ply",
            Format::Off => "off",
        }
    }

    /// The MIME type used when serving this format.
    pub fn mime(self) -> &'static str {
        match self {
            Format::Obj => "model/obj",
            Format::Gltf => "model/gltf+json",
            Format::Glb => "model/gltf-binary",
            Format::Stl => "model/stl",
            Format::Ply => "model/x-ply",
            Format::Off => "model/x-off",
        }
    }
}

impl fmt::Display for Format {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        f.write_str(self.extension())
    }
}

impl FromStr for Format {
    type Err = IoError;

    /// Parses a format name (`"obj"`, `"GLB"`, ...), case-insensitively.
    fn from_str(s: &str) -> Result<Self, Self::Err> {
        Format::ALL
            .into_iter()
            .find(|f| f.extension().eq_ignore_ascii_case(s.trim()))
            .ok_or_else(|| IoError::UnknownFormat {
                hint: format!("{s:?} is not a format name"),
            })
    }
}

fn skip_bom_and_space(bytes: &[u8]) -> &[u8] {
    let b = bytes.strip_prefix(b"\xEF\xBB\xBF").unwrap_or(bytes);
    let start = b
        .iter()
        .position(|c| !c.is_ascii_whitespace())
        .unwrap_or(b.len());
    &b[start..]
}

fn contains(hay: &[u8], needle: &[u8]) -> bool {
    hay.windows(needle.len()).any(|w| w == needle)
}

/// The first whitespace-delimited word after skipping `#` comment lines.
fn first_word(text: &[u8]) -> Option<&[u8]> {
    text.split(|&c| c == b'\n')
        .map(|l| {
            let l = l.split(|&c| c == b'#').next().unwrap_or(l);
            l.split(|c| c.is_ascii_whitespace()).find(|w| !w.is_empty())
        })
        .take(64)
        .find_map(|w| w)
}

/// `OFF` and its variants that prefix letters (`C`, `N`, `ST`, `4`, `n`),
/// as in Geomview's OFF description.
pub(crate) fn is_off_keyword(word: &[u8]) -> bool {
    let Some(prefix) = word.strip_suffix(b"OFF") else {
        return false;
    };
    prefix
        .iter()
        .all(|c| matches!(c, b'S' | b'T' | b'C' | b'N' | b'4' | b'n'))
}

/// OBJ has no signature: accept text whose first statements are OBJ
/// keywords and that contains at least one vertex statement.
fn looks_like_obj(text: &[u8]) -> bool {
    const KEYWORDS: [&[u8]; 14] = [
        b"v", b"vt", b"vn", b"vp", b"f", b"l", b"p", b"o", b"g", b"s", b"mtllib", b"usemtl",
        b"cstype", b"deg",
    ];
    let mut statements = 0;
    let mut vertices = 0;
    for line in text.split(|&c| c == b'\n').take(200) {
        let line = skip_bom_and_space(line);
        if line.is_empty() || line[0] == b'#' {
            continue;
        }
        let word = line
            .split(|c| c.is_ascii_whitespace())
            .next()
            .unwrap_or(line);
        if !KEYWORDS.contains(&word) {
            return false;
        }
        statements += 1;
        if word == b"v" {
            vertices += 1;
        }
    }
    statements > 0 && vertices > 0
}
