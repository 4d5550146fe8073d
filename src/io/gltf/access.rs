//! The binary side of a glTF document, validated with checked arithmetic:
//! the GLB container's chunks, buffers (`data:` URIs or passed-in external
//! files), buffer views and typed accessors with their strides.

use std::borrow::Cow;

use ::gltf::json;
use base64::Engine;
use json::accessor::{ComponentType, GenericComponentType, IndexComponentType, Type};
use json::validation::Checked;

use super::super::{Format, IoError, ReadOptions};

pub(crate) const GLB_MAGIC: &[u8; 4] = b"glTF";
pub(crate) const CHUNK_JSON: u32 = 0x4E4F_534A;
pub(crate) const CHUNK_BIN: u32 = 0x004E_4942;

/// Extensions that change how geometry is stored; without a decoder the
/// file cannot be read when they are required.
pub(crate) const GEOMETRY_EXTENSIONS: [&str; 3] = [
    "KHR_draco_mesh_compression",
    "EXT_meshopt_compression",
    "KHR_meshopt_compression",
];

pub(crate) fn u32_at(bytes: &[u8], at: usize) -> Option<u32> {
    let b = bytes.get(at..at.checked_add(4)?)?;
    Some(u32::from_le_bytes([b[0], b[1], b[2], b[3]]))
}

/// The JSON and BIN chunks of a GLB container, validated against the
/// header's declared lengths.
pub(crate) fn split_glb(bytes: &[u8]) -> Result<(&[u8], Option<&[u8]>), IoError> {
    let truncated = |what: &str, needed: u64, available: usize| IoError::Truncated {
        format: Format::Glb,
        what: what.to_string(),
        needed,
        available: available as u64,
    };
    if !bytes.starts_with(GLB_MAGIC) {
        if GLB_MAGIC.starts_with(bytes) {
            return Err(truncated("the 12-byte GLB header", 12, bytes.len()));
        }
        return Err(IoError::BadMagic {
            format: Format::Glb,
            expected: "\"glTF\"",
        });
    }
    let (Some(version), Some(length)) = (u32_at(bytes, 4), u32_at(bytes, 8)) else {
        return Err(truncated("the 12-byte GLB header", 12, bytes.len()));
    };
    if version != 2 {
        return Err(IoError::unsupported(
            Format::Glb,
            format!("GLB container version {version} (only version 2 is read)"),
        ));
    }
    let length = length as usize;
    if length > bytes.len() {
        return Err(truncated(
            "the length declared in the GLB header",
            length as u64,
            bytes.len(),
        ));
    }
    let bytes = &bytes[..length];
    let mut at = 12;
    let mut json = None;
    let mut bin = None;
    while at < bytes.len() {
        let (Some(len), Some(kind)) = (u32_at(bytes, at), u32_at(bytes, at + 4)) else {
            return Err(truncated("a GLB chunk header", at as u64 + 8, bytes.len()));
        };
        let start = at + 8;
        let end = start as u64 + u64::from(len);
        if end > bytes.len() as u64 {
            return Err(truncated("a GLB chunk", end, bytes.len()));
        }
        let end = end as usize;
        match kind {
            CHUNK_JSON if json.is_none() => json = Some(&bytes[start..end]),
            CHUNK_BIN if json.is_some() && bin.is_none() => bin = Some(&bytes[start..end]),
            _ if json.is_none() => {
                return Err(IoError::parse(
                    Format::Glb,
                    "the first GLB chunk is not the JSON chunk",
                ))
            }
            // Unknown chunks must be ignored, per the spec.
            _ => {}
        }
        at = end;
    }
    let json = json.ok_or_else(|| IoError::parse(Format::Glb, "the GLB has no JSON chunk"))?;
    Ok((json, bin))
}

/// Decodes the `%XX` escapes of a relative URI (a glTF buffer or image
/// name); `None` when an escape is malformed or the result is not UTF-8.
pub fn percent_decode(uri: &str) -> Option<String> {
    let b = uri.as_bytes();
    let mut out = Vec::with_capacity(b.len());
    let mut i = 0;
    while i < b.len() {
        if b[i] == b'%' {
            let hex = std::str::from_utf8(b.get(i + 1..i + 3)?).ok()?;
            out.push(u8::from_str_radix(hex, 16).ok()?);
            i += 3;
        } else {
            out.push(b[i]);
            i += 1;
        }
    }
    String::from_utf8(out).ok()
}

/// The buffers of a document, decoded on first use so that buffers the
/// geometry does not need (images, animations) are never required.
pub(crate) struct Buffers<'a> {
    pub(crate) format: Format,
    pub(crate) root: &'a json::Root,
    pub(crate) bin: Option<&'a [u8]>,
    pub(crate) opts: &'a ReadOptions,
    pub(crate) data: Vec<Option<Cow<'a, [u8]>>>,
}

impl<'a> Buffers<'a> {
    pub(crate) fn new(
        format: Format,
        root: &'a json::Root,
        bin: Option<&'a [u8]>,
        opts: &'a ReadOptions,
    ) -> Self {
        Buffers {
            format,
            root,
            bin,
            opts,
            data: vec![None; root.buffers.len()],
        }
    }

    pub(crate) fn get(&mut self, index: usize) -> Result<&[u8], IoError> {
        let format = self.format;
        let Some(buffer) = self.root.buffers.get(index) else {
            return Err(IoError::parse(
                format,
                format!("buffer {index} does not exist"),
            ));
        };
        if self.data[index].is_none() {
            let raw: Cow<'a, [u8]> = match buffer.uri.as_deref() {
                None if index == 0 && self.bin.is_some() => {
                    Cow::Borrowed(self.bin.unwrap_or_default())
                }
                None => {
                    return Err(IoError::parse(
                        format,
                        format!("buffer {index} has no uri and there is no GLB binary chunk"),
                    ))
                }
                Some(uri) if uri.starts_with("data:") => Cow::Owned(
                    decode_data_uri(uri)
                        .map_err(|m| IoError::parse(format, format!("buffer {index}: {m}")))?,
                ),
                Some(uri) => match crate::io::companions::find(&self.opts.external_buffers, uri) {
                    Some(b) => Cow::Borrowed(b.as_slice()),
                    None => {
                        return Err(IoError::ExternalBuffer {
                            format,
                            uri: uri.to_string(),
                        })
                    }
                },
            };
            let declared = buffer.byte_length.0;
            if (raw.len() as u64) < declared {
                return Err(IoError::Truncated {
                    format,
                    what: format!("buffer {index} (declared byteLength)"),
                    needed: declared,
                    available: raw.len() as u64,
                });
            }
            // The declared length fits in the data, so in usize.
            let raw = match raw {
                Cow::Borrowed(b) => Cow::Borrowed(&b[..declared as usize]),
                Cow::Owned(mut v) => {
                    v.truncate(declared as usize);
                    Cow::Owned(v)
                }
            };
            self.data[index] = Some(raw);
        }
        Ok(self.data[index].as_deref().unwrap_or_default())
    }
}

/// Bytes of a `data:[<mediatype>];base64,<data>` URI.
pub(crate) fn decode_data_uri(uri: &str) -> Result<Vec<u8>, String> {
    let Some((head, payload)) = uri.split_once(',') else {
        return Err("the data URI has no ','".to_string());
    };
    if !head.ends_with(";base64") {
        return Err("the data URI is not base64-encoded".to_string());
    }
    let engine = base64::engine::GeneralPurpose::new(
        &base64::alphabet::STANDARD,
        base64::engine::GeneralPurposeConfig::new()
            .with_decode_padding_mode(base64::engine::DecodePaddingMode::Indifferent),
    );
    engine
        .decode(payload.trim())
        .map_err(|e| format!("invalid base64 in the data URI: {e}"))
}

/// A validated accessor: every element `e < count` lies at
/// `data[e * stride .. e * stride + elem]`.
pub(crate) struct Layout<'d> {
    pub(crate) data: &'d [u8],
    pub(crate) stride: usize,
    pub(crate) count: usize,
    pub(crate) component: ComponentType,
    pub(crate) components: usize,
    pub(crate) normalized: bool,
}

pub(crate) fn component_size(c: ComponentType) -> usize {
    match c {
        ComponentType::I8 | ComponentType::U8 => 1,
        ComponentType::I16 | ComponentType::U16 => 2,
        ComponentType::U32 | ComponentType::F32 => 4,
    }
}

/// Reads one component of type `c` from exactly `b.len() == size(c)` bytes.
pub(crate) fn decode(c: ComponentType, normalized: bool, b: &[u8]) -> f64 {
    let v = match c {
        ComponentType::I8 => f64::from(b[0] as i8),
        ComponentType::U8 => f64::from(b[0]),
        ComponentType::I16 => f64::from(i16::from_le_bytes([b[0], b[1]])),
        ComponentType::U16 => f64::from(u16::from_le_bytes([b[0], b[1]])),
        ComponentType::U32 => f64::from(u32::from_le_bytes([b[0], b[1], b[2], b[3]])),
        ComponentType::F32 => return f64::from(f32::from_le_bytes([b[0], b[1], b[2], b[3]])),
    };
    if !normalized {
        return v;
    }
    // Normalized integers map to [-1, 1] or [0, 1] (spec 3.11).
    match c {
        ComponentType::I8 => (v / 127.0).max(-1.0),
        ComponentType::U8 => v / 255.0,
        ComponentType::I16 => (v / 32767.0).max(-1.0),
        ComponentType::U16 => v / 65535.0,
        _ => v / f64::from(u32::MAX),
    }
}

impl Layout<'_> {
    pub(crate) fn get(&self, e: usize, k: usize) -> f64 {
        let size = component_size(self.component);
        let at = e * self.stride + k * size;
        decode(self.component, self.normalized, &self.data[at..at + size])
    }
}

/// What an accessor is read as.
#[derive(Clone, Copy, PartialEq)]
pub(crate) enum Role {
    Vec3,
    Index,
    /// Texture coordinates: vec2.
    Vec2,
    /// A colour: vec3 or vec4, read as given (3 or 4 values per element).
    Color,
}

pub(crate) struct Reader<'a> {
    pub(crate) format: Format,
    pub(crate) root: &'a json::Root,
    pub(crate) buffers: Buffers<'a>,
    pub(crate) max_elements: u64,
}

impl<'a> Reader<'a> {
    pub(crate) fn parse_err(&self, message: impl AsRef<str>) -> IoError {
        IoError::parse(self.format, message)
    }

    /// The bytes of buffer view `v` as read by accessor `a`, with the
    /// view's stride, after checking the view against its buffer.
    pub(crate) fn view(&mut self, a: usize, v: usize) -> Result<(&[u8], Option<usize>), IoError> {
        let root = self.root;
        let Some(view) = root.buffer_views.get(v) else {
            return Err(self.parse_err(format!(
                "accessor {a} uses buffer view {v}, which does not exist"
            )));
        };
        let b = view.buffer.value();
        let buffer = self.buffers.get(b)?;
        let start = view.byte_offset.map_or(0, |o| o.0);
        let end = start.saturating_add(view.byte_length.0);
        if end > buffer.len() as u64 {
            return Err(IoError::AccessorOutOfBounds {
                accessor: a,
                within: format!("buffer {b} (through buffer view {v})"),
                needed: end,
                available: buffer.len() as u64,
            });
        }
        Ok((
            &buffer[start as usize..end as usize],
            view.byte_stride.map(|s| s.0),
        ))
    }

    /// Reads accessor `a` into `out` as `components`-wide f64 tuples, after
    /// validating count, types, stride and bounds; applies sparse
    /// substitution.
    pub(crate) fn read(
        &mut self,
        a: usize,
        role: Role,
        out: &mut Vec<f64>,
    ) -> Result<usize, IoError> {
        let root = self.root;
        let Some(acc) = root.accessors.get(a) else {
            return Err(self.parse_err(format!("accessor {a} does not exist")));
        };
        let count = acc.count.0;
        if count == 0 {
            return Err(IoError::ZeroCount { accessor: a });
        }
        let component = match acc.component_type {
            Checked::Valid(GenericComponentType(c)) => c,
            Checked::Invalid => {
                return Err(self.parse_err(format!("accessor {a} has an invalid componentType")))
            }
        };
        let (want, components) = match role {
            Role::Vec3 => (Type::Vec3, 3),
            Role::Index => (Type::Scalar, 1),
            Role::Vec2 => (Type::Vec2, 2),
            Role::Color if acc.type_ == Checked::Valid(Type::Vec4) => (Type::Vec4, 4),
            Role::Color => (Type::Vec3, 3),
        };
        if acc.type_ != Checked::Valid(want) {
            return Err(self.parse_err(format!(
                "accessor {a} has type {:?} where {want:?} is required",
                acc.type_
            )));
        }
        if role == Role::Index
            && !matches!(
                component,
                ComponentType::U8 | ComponentType::U16 | ComponentType::U32
            )
        {
            return Err(self.parse_err(format!(
                "index accessor {a} has component type {component:?} (unsigned byte, short or int required)"
            )));
        }
        let size = component_size(component);
        let elem = (size * components) as u64;
        let first = out.len();
        let n = match acc.buffer_view {
            None => {
                // Zero-filled: no data bounds the count, so the size limit does.
                if count > self.max_elements {
                    return Err(IoError::TooLarge {
                        message: format!(
                            "accessor {a} declares {count} elements, more than the limit of {}",
                            self.max_elements
                        ),
                    });
                }
                let n = count as usize;
                out.resize(first + n * components, 0.0);
                n
            }
            Some(v) => {
                let v = v.value();
                let offset = acc.byte_offset.map_or(0, |o| o.0);
                let (data, stride) = self.view(a, v)?;
                let stride = stride.map_or(elem, |s| s as u64);
                if stride < elem {
                    return Err(IoError::BadStride {
                        accessor: a,
                        view: v,
                        stride,
                        element_size: elem,
                    });
                }
                let needed = (count - 1)
                    .checked_mul(stride)
                    .and_then(|x| x.checked_add(elem))
                    .and_then(|x| x.checked_add(offset))
                    .unwrap_or(u64::MAX);
                if needed > data.len() as u64 {
                    return Err(IoError::AccessorOutOfBounds {
                        accessor: a,
                        within: format!("buffer view {v}"),
                        needed,
                        available: data.len() as u64,
                    });
                }
                // In bounds, so count <= data.len() and fits in usize.
                let n = count as usize;
                let layout = Layout {
                    data: &data[offset as usize..],
                    stride: stride as usize,
                    count: n,
                    component,
                    components,
                    normalized: acc.normalized,
                };
                out.reserve(n * components);
                for e in 0..layout.count {
                    for k in 0..layout.components {
                        out.push(layout.get(e, k));
                    }
                }
                n
            }
        };
        if let Some(sparse) = &acc.sparse {
            self.apply_sparse(
                a,
                sparse,
                component,
                components,
                acc.normalized,
                n,
                first,
                out,
            )?;
        }
        Ok(n)
    }

    #[allow(clippy::too_many_arguments)]
    pub(crate) fn apply_sparse(
        &mut self,
        a: usize,
        sparse: &json::accessor::sparse::Sparse,
        component: ComponentType,
        components: usize,
        normalized: bool,
        n: usize,
        first: usize,
        out: &mut [f64],
    ) -> Result<(), IoError> {
        let k = sparse.count.0;
        if k == 0 || k > n as u64 {
            return Err(self.parse_err(format!(
                "accessor {a} has a sparse count of {k} for {n} elements"
            )));
        }
        let k = k as usize;
        let index_type = match sparse.indices.component_type {
            Checked::Valid(IndexComponentType(c)) => c,
            Checked::Invalid => {
                return Err(self.parse_err(format!(
                    "accessor {a} has an invalid sparse index componentType"
                )))
            }
        };
        let index_size = component_size(index_type);
        let value_size = component_size(component) * components;
        let read_run =
            |me: &mut Self, view: usize, offset: u64, size: usize| -> Result<Vec<u8>, IoError> {
                let (data, _) = me.view(a, view)?;
                let needed = offset.saturating_add((k * size) as u64);
                if needed > data.len() as u64 {
                    return Err(IoError::AccessorOutOfBounds {
                        accessor: a,
                        within: format!("buffer view {view} (sparse storage)"),
                        needed,
                        available: data.len() as u64,
                    });
                }
                Ok(data[offset as usize..needed as usize].to_vec())
            };
        let indices = read_run(
            self,
            sparse.indices.buffer_view.value(),
            sparse.indices.byte_offset.0,
            index_size,
        )?;
        let values = read_run(
            self,
            sparse.values.buffer_view.value(),
            sparse.values.byte_offset.0,
            value_size,
        )?;
        let size = component_size(component);
        for j in 0..k {
            let i = decode(
                index_type,
                false,
                &indices[j * index_size..(j + 1) * index_size],
            ) as usize;
            if i >= n {
                return Err(self.parse_err(format!(
                    "accessor {a} has sparse index {i} for {n} elements"
                )));
            }
            for c in 0..components {
                let at = j * value_size + c * size;
                out[first + i * components + c] =
                    decode(component, normalized, &values[at..at + size]);
            }
        }
        Ok(())
    }
}
