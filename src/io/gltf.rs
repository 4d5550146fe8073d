//! glTF 2.0 (Khronos specification 2.0.1): `.gltf` JSON with `data:` base64
//! buffers or caller-provided external buffers, and the `.glb` container.
//!
//! Reading uses `gltf::json` only to deserialize the document; the GLB
//! header and chunks, buffer views, accessors, strides and indices are
//! validated here with checked arithmetic and read by this module, because
//! the `gltf` crate's reader panics on hostile counts and strides. Every
//! triangle primitive of every mesh reachable from the default scene (else
//! scene 0, else all root nodes, else every mesh when there are no nodes)
//! is read in world space: node matrices / TRS are composed down the
//! hierarchy (each node is visited once, so cycles terminate), normals use
//! the inverse-transpose, and mirroring transforms flip the winding.
//! Strips and fans become triangle lists; points and lines are counted in
//! [`Imported::ignored_primitives`]. Morph targets and skins are ignored
//! (the rest pose is read).
//!
//! Labels: one label per material index, so primitives that share a
//! material share a label; primitives without a material share one label
//! without material. Primitives of one node instance that share their
//! POSITION/NORMAL accessors share vertices, which is what [`write`] emits
//! (one vertex array, one index accessor per label), so a round trip keeps
//! the topology.

use std::borrow::Cow;
use std::collections::{BTreeMap, HashMap};

use ::gltf::json;
use base64::Engine;
use glam::{DMat3, DMat4, DQuat, DVec3};
use json::accessor::{ComponentType, GenericComponentType, IndexComponentType, Type};
use json::mesh::{Mode, Semantic};
use json::validation::{Checked, USize64};

use super::{check_triangle_budget, Attribute, Format, Imported, IoError, ReadOptions};
use crate::{Label, Material, TriMesh};

const GLB_MAGIC: &[u8; 4] = b"glTF";
const CHUNK_JSON: u32 = 0x4E4F_534A;
const CHUNK_BIN: u32 = 0x004E_4942;

/// Extensions that change how geometry is stored; without a decoder the
/// file cannot be read when they are required.
const GEOMETRY_EXTENSIONS: [&str; 3] = [
    "KHR_draco_mesh_compression",
    "EXT_meshopt_compression",
    "KHR_meshopt_compression",
];

fn u32_at(bytes: &[u8], at: usize) -> Option<u32> {
    let b = bytes.get(at..at.checked_add(4)?)?;
    Some(u32::from_le_bytes([b[0], b[1], b[2], b[3]]))
}

/// The JSON and BIN chunks of a GLB container, validated against the
/// header's declared lengths.
fn split_glb(bytes: &[u8]) -> Result<(&[u8], Option<&[u8]>), IoError> {
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

/// Decodes `%XX` escapes of a relative URI; `None` when malformed.
fn percent_decode(uri: &str) -> Option<String> {
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
struct Buffers<'a> {
    format: Format,
    root: &'a json::Root,
    bin: Option<&'a [u8]>,
    opts: &'a ReadOptions,
    data: Vec<Option<Cow<'a, [u8]>>>,
}

impl<'a> Buffers<'a> {
    fn new(
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

    fn get(&mut self, index: usize) -> Result<&[u8], IoError> {
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
                Some(uri) => {
                    let ext = &self.opts.external_buffers;
                    let found = ext.get(uri).or_else(|| {
                        let decoded = percent_decode(uri)?;
                        ext.get(&decoded)
                            .or_else(|| ext.get(decoded.trim_start_matches("./")))
                    });
                    match found {
                        Some(b) => Cow::Borrowed(b.as_slice()),
                        None => {
                            return Err(IoError::ExternalBuffer {
                                uri: uri.to_string(),
                            })
                        }
                    }
                }
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
fn decode_data_uri(uri: &str) -> Result<Vec<u8>, String> {
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
struct Layout<'d> {
    data: &'d [u8],
    stride: usize,
    count: usize,
    component: ComponentType,
    components: usize,
    normalized: bool,
}

fn component_size(c: ComponentType) -> usize {
    match c {
        ComponentType::I8 | ComponentType::U8 => 1,
        ComponentType::I16 | ComponentType::U16 => 2,
        ComponentType::U32 | ComponentType::F32 => 4,
    }
}

/// Reads one component of type `c` from exactly `b.len() == size(c)` bytes.
fn decode(c: ComponentType, normalized: bool, b: &[u8]) -> f64 {
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
    fn get(&self, e: usize, k: usize) -> f64 {
        let size = component_size(self.component);
        let at = e * self.stride + k * size;
        decode(self.component, self.normalized, &self.data[at..at + size])
    }
}

/// What an accessor is read as.
#[derive(Clone, Copy, PartialEq)]
enum Role {
    Vec3,
    Index,
}

struct Reader<'a> {
    format: Format,
    root: &'a json::Root,
    buffers: Buffers<'a>,
    max_elements: u64,
}

impl<'a> Reader<'a> {
    fn parse_err(&self, message: impl AsRef<str>) -> IoError {
        IoError::parse(self.format, message)
    }

    /// The bytes of buffer view `v` as read by accessor `a`, with the
    /// view's stride, after checking the view against its buffer.
    fn view(&mut self, a: usize, v: usize) -> Result<(&[u8], Option<usize>), IoError> {
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
    fn read(&mut self, a: usize, role: Role, out: &mut Vec<f64>) -> Result<usize, IoError> {
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
    fn apply_sparse(
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

fn to_material(m: &json::Material) -> Material {
    let pbr = &m.pbr_metallic_roughness;
    let strength = m
        .extensions
        .as_ref()
        .and_then(|e| e.emissive_strength.as_ref())
        .map_or(1.0, |s| s.emissive_strength.0);
    Material {
        name: m.name.clone(),
        base_color_factor: pbr.base_color_factor.0,
        metallic_factor: pbr.metallic_factor.0,
        roughness_factor: pbr.roughness_factor.0,
        emissive_factor: m.emissive_factor.0.map(|c| c * strength),
        double_sided: m.double_sided,
    }
}

fn local_matrix(node: &json::Node) -> DMat4 {
    if let Some(m) = node.matrix {
        return DMat4::from_cols_array(&m.map(f64::from));
    }
    let t = node.translation.map_or(DVec3::ZERO, |t| {
        DVec3::new(f64::from(t[0]), f64::from(t[1]), f64::from(t[2]))
    });
    let s = node.scale.map_or(DVec3::ONE, |s| {
        DVec3::new(f64::from(s[0]), f64::from(s[1]), f64::from(s[2]))
    });
    let r = node
        .rotation
        .map(|q| {
            let [x, y, z, w] = q.0.map(f64::from);
            DQuat::from_xyzw(x, y, z, w)
        })
        .filter(|q| q.length() > 1e-12 && q.is_finite())
        .map_or(DQuat::IDENTITY, DQuat::normalize);
    DMat4::from_scale_rotation_translation(s, r, t)
}

/// The meshes to read with their world matrices, in the document order of
/// their nodes (the order trimesh, and so the benchmark, concatenates them),
/// whatever the hierarchy's shape.
fn instances(root: &json::Root, format: Format) -> Result<Vec<(usize, DMat4)>, IoError> {
    let nodes = &root.nodes;
    let roots: Vec<usize> = if let Some(s) = root
        .scene
        .map(|s| s.value())
        .or_else(|| (!root.scenes.is_empty()).then_some(0))
    {
        let scene = root.scenes.get(s).ok_or_else(|| {
            IoError::parse(format, format!("the default scene {s} does not exist"))
        })?;
        scene.nodes.iter().map(|n| n.value()).collect()
    } else if !nodes.is_empty() {
        let mut is_child = vec![false; nodes.len()];
        for c in nodes.iter().flat_map(|n| n.children.iter().flatten()) {
            if let Some(flag) = is_child.get_mut(c.value()) {
                *flag = true;
            }
        }
        (0..nodes.len()).filter(|&i| !is_child[i]).collect()
    } else {
        return Ok((0..root.meshes.len())
            .map(|m| (m, DMat4::IDENTITY))
            .collect());
    };
    let mut visited = vec![false; nodes.len()];
    let mut stack: Vec<(usize, DMat4)> =
        roots.iter().rev().map(|&n| (n, DMat4::IDENTITY)).collect();
    let mut out = Vec::new();
    while let Some((n, parent)) = stack.pop() {
        let Some(node) = nodes.get(n) else {
            return Err(IoError::parse(format, format!("node {n} does not exist")));
        };
        // The hierarchy must be a forest; visiting each node once makes
        // cycles and shared children terminate.
        if std::mem::replace(&mut visited[n], true) {
            continue;
        }
        let world = parent * local_matrix(node);
        if let Some(m) = node.mesh {
            if m.value() >= root.meshes.len() {
                return Err(IoError::parse(
                    format,
                    format!("node {n} uses mesh {}, which does not exist", m.value()),
                ));
            }
            out.push((n, m.value(), world));
        }
        for c in node.children.iter().flatten().rev() {
            stack.push((c.value(), world));
        }
    }
    // Each node is visited once, so node indices are unique keys.
    out.sort_unstable_by_key(|&(n, _, _)| n);
    Ok(out.into_iter().map(|(_, m, w)| (m, w)).collect())
}

pub(super) fn read(bytes: &[u8], format: Format, opts: &ReadOptions) -> Result<Imported, IoError> {
    let is_glb = bytes.starts_with(GLB_MAGIC) || format == Format::Glb;
    let format = if is_glb { Format::Glb } else { Format::Gltf };
    let (json_bytes, bin) = if is_glb {
        split_glb(bytes)?
    } else {
        // A byte order mark is tolerated in .gltf text (not in GLB).
        (bytes.strip_prefix(b"\xEF\xBB\xBF").unwrap_or(bytes), None)
    };
    let root: json::Root = serde_json::from_slice(json_bytes)
        .map_err(|e| IoError::parse(format, format!("JSON: {e}")))?;
    let major = root.asset.version.split('.').next().unwrap_or("");
    if major != "2" {
        return Err(IoError::unsupported(
            format,
            format!("glTF version {:?} (only 2.x is read)", root.asset.version),
        ));
    }
    if let Some(ext) = root
        .extensions_required
        .iter()
        .find(|e| GEOMETRY_EXTENSIONS.contains(&e.as_str()))
    {
        return Err(IoError::unsupported(
            format,
            format!("the file requires {ext}, which isoremesh cannot decode"),
        ));
    }
    let instances = instances(&root, format)?;
    let max_vertices = opts
        .max_triangles
        .saturating_mul(3)
        .min(u64::from(u32::MAX));
    let mut reader = Reader {
        format,
        root: &root,
        buffers: Buffers::new(format, &root, bin, opts),
        max_elements: max_vertices,
    };

    let mut mesh = TriMesh::default();
    let mut ignored = 0u64;
    let mut all_normals = true;
    let mut labels: HashMap<Option<usize>, u32> = HashMap::new();
    let mut shared: HashMap<(usize, usize, Option<usize>), (u32, u32)> = HashMap::new();
    let mut scratch: Vec<f64> = Vec::new();
    for (instance, &(m, world)) in instances.iter().enumerate() {
        let det = world.determinant();
        let normal_matrix = if det.abs() > 1e-300 {
            DMat3::from_mat4(world).inverse().transpose()
        } else {
            DMat3::from_mat4(world)
        };
        for prim in &root.meshes[m].primitives {
            let mode = match prim.mode {
                Checked::Valid(mode) => mode,
                Checked::Invalid => {
                    return Err(IoError::parse(
                        format,
                        format!("a primitive of mesh {m} has an invalid mode"),
                    ))
                }
            };
            if !matches!(
                mode,
                Mode::Triangles | Mode::TriangleStrip | Mode::TriangleFan
            ) {
                ignored += 1;
                continue;
            }
            let Some(pos_acc) = prim
                .attributes
                .get(&Checked::Valid(Semantic::Positions))
                .map(|i| i.value())
            else {
                // The spec lets clients skip primitives without positions.
                ignored += 1;
                continue;
            };
            let nrm_acc = prim
                .attributes
                .get(&Checked::Valid(Semantic::Normals))
                .map(|i| i.value());
            let idx_acc = prim.indices.map(|i| i.value());

            // Bound the output before reading anything.
            let corner_count = match idx_acc {
                Some(i) => root.accessors.get(i).map_or(0, |a| a.count.0),
                None => root.accessors.get(pos_acc).map_or(0, |a| a.count.0),
            };
            let new_triangles = match mode {
                Mode::Triangles => corner_count / 3,
                _ => corner_count.saturating_sub(2),
            };
            check_triangle_budget(mesh.triangles.len() as u64 + new_triangles, opts)?;

            let key = (instance, pos_acc, nrm_acc);
            let (base, vcount) = match shared.get(&key) {
                Some(&b) => b,
                None => {
                    let base = super::vertex_index(mesh.positions.len())?;
                    scratch.clear();
                    let n = reader.read(pos_acc, Role::Vec3, &mut scratch)?;
                    if mesh.positions.len() as u64 + n as u64 > max_vertices {
                        return Err(IoError::TooLarge {
                            message: format!(
                                "more than {max_vertices} vertices (3 per allowed triangle)"
                            ),
                        });
                    }
                    mesh.positions.extend(
                        scratch
                            .chunks_exact(3)
                            .map(|c| world.transform_point3(DVec3::new(c[0], c[1], c[2]))),
                    );
                    match nrm_acc {
                        Some(na) => {
                            scratch.clear();
                            let nn = reader.read(na, Role::Vec3, &mut scratch)?;
                            if nn != n {
                                return Err(IoError::parse(
                                    format,
                                    format!(
                                        "NORMAL accessor {na} has {nn} elements but POSITION accessor {pos_acc} has {n}"
                                    ),
                                ));
                            }
                            mesh.normals.resize(base as usize, DVec3::ZERO);
                            mesh.normals.extend(scratch.chunks_exact(3).map(|c| {
                                (normal_matrix * DVec3::new(c[0], c[1], c[2])).normalize_or_zero()
                            }));
                        }
                        None => all_normals = false,
                    }
                    let entry = (base, super::vertex_index(n)?);
                    shared.insert(key, entry);
                    entry
                }
            };

            scratch.clear();
            let corners: Vec<u32> = match idx_acc {
                Some(i) => {
                    reader.read(i, Role::Index, &mut scratch)?;
                    // Unsigned integers of at most 32 bits, exact in f64.
                    scratch.iter().map(|&x| x as u32).collect()
                }
                None => (0..vcount).collect(),
            };
            let first_face = mesh.triangles.len();
            for (c, &i) in corners.iter().enumerate() {
                if i >= vcount {
                    let face = match mode {
                        Mode::Triangles => c / 3,
                        _ => c.saturating_sub(2),
                    };
                    return Err(IoError::IndexOutOfRange {
                        face: (first_face + face) as u64,
                        index: i64::from(i),
                        vertex_count: u64::from(vcount),
                    });
                }
            }
            let flip = det < 0.0;
            let mut push = |t: [u32; 3]| {
                let t = t.map(|i| i + base);
                mesh.triangles
                    .push(if flip { [t[0], t[2], t[1]] } else { t });
            };
            match mode {
                Mode::Triangles => corners
                    .chunks_exact(3)
                    .for_each(|t| push([t[0], t[1], t[2]])),
                Mode::TriangleStrip => {
                    for (k, w) in corners.windows(3).enumerate() {
                        // Zero-area joins between strips are not faces.
                        if w[0] != w[1] && w[1] != w[2] && w[0] != w[2] {
                            push(if k % 2 == 0 {
                                [w[0], w[1], w[2]]
                            } else {
                                [w[1], w[0], w[2]]
                            });
                        }
                    }
                }
                _ => {
                    for w in corners.windows(2).skip(1) {
                        let t = [w[0], w[1], corners[0]];
                        if t[0] != t[1] && t[1] != t[2] && t[0] != t[2] {
                            push(t);
                        }
                    }
                }
            }

            let mat = prim.material.map(|i| i.value());
            let next = mesh.labels.len() as u32;
            let label = *labels.entry(mat).or_insert(next);
            if label == next {
                let material = match mat {
                    Some(i) => Some(to_material(root.materials.get(i).ok_or_else(|| {
                        IoError::parse(format, format!("material {i} does not exist"))
                    })?)),
                    None => None,
                };
                mesh.labels.push(Label {
                    name: material.as_ref().and_then(|m| m.name.clone()),
                    material,
                });
            }
            mesh.face_labels.resize(mesh.triangles.len(), label);
        }
    }
    if all_normals {
        mesh.normals.resize(mesh.positions.len(), DVec3::ZERO);
    } else {
        mesh.normals.clear();
    }
    if mesh.labels.len() <= 1 && mesh.labels.iter().all(|l| l.material.is_none()) {
        mesh.labels.clear();
        mesh.face_labels.clear();
    }
    Ok(Imported {
        mesh,
        ignored_primitives: ignored,
    })
}

fn buffer_view(
    root: &mut json::Root,
    offset: usize,
    length: usize,
    target: json::buffer::Target,
) -> json::Index<json::buffer::View> {
    root.push(json::buffer::View {
        buffer: json::Index::new(0),
        byte_length: USize64::from(length),
        byte_offset: Some(USize64::from(offset)),
        byte_stride: None,
        name: None,
        target: Some(Checked::Valid(target)),
        extensions: None,
        extras: Default::default(),
    })
}

#[allow(clippy::too_many_arguments)]
fn accessor(
    root: &mut json::Root,
    view: json::Index<json::buffer::View>,
    offset: usize,
    count: usize,
    component: ComponentType,
    type_: Type,
    min: Option<serde_json::Value>,
    max: Option<serde_json::Value>,
) -> json::Index<json::Accessor> {
    root.push(json::Accessor {
        buffer_view: Some(view),
        byte_offset: Some(USize64::from(offset)),
        count: USize64::from(count),
        component_type: Checked::Valid(GenericComponentType(component)),
        extensions: None,
        extras: Default::default(),
        type_: Checked::Valid(type_),
        min,
        max,
        name: None,
        normalized: false,
        sparse: None,
    })
}

fn to_json_material(m: &Material) -> (json::Material, bool) {
    // Emissive factors above 1 are stored as a strength, as glTF requires
    // the factor itself to stay within [0, 1].
    let peak = m.emissive_factor.iter().copied().fold(0.0f32, f32::max);
    let strength = (peak > 1.0).then_some(peak);
    let emissive = match strength {
        Some(s) => m.emissive_factor.map(|c| c / s),
        None => m.emissive_factor,
    };
    let material = json::Material {
        name: m.name.clone(),
        double_sided: m.double_sided,
        emissive_factor: json::material::EmissiveFactor(emissive),
        pbr_metallic_roughness: json::material::PbrMetallicRoughness {
            base_color_factor: json::material::PbrBaseColorFactor(m.base_color_factor),
            metallic_factor: json::material::StrengthFactor(m.metallic_factor),
            roughness_factor: json::material::StrengthFactor(m.roughness_factor),
            ..Default::default()
        },
        extensions: strength.map(|s| json::extensions::material::Material {
            emissive_strength: Some(json::extensions::material::EmissiveStrength {
                emissive_strength: json::extensions::material::EmissiveStrengthFactor(s),
            }),
        }),
        ..Default::default()
    };
    (material, strength.is_some())
}

/// Writes `mesh` as glTF or GLB; `extra` are per-vertex float attributes
/// with their glTF names (`_NAME`), added to every primitive.
pub(super) fn write(
    mesh: &TriMesh,
    format: Format,
    normals: bool,
    extra: &[Attribute],
) -> Result<Vec<u8>, IoError> {
    let nv = mesh.positions.len();
    let f32s = |v: DVec3| [v.x as f32, v.y as f32, v.z as f32];
    let positions: Vec<[f32; 3]> = mesh.positions.iter().map(|&p| f32s(p)).collect();
    if let Some(v) = positions
        .iter()
        .position(|p| !p.iter().all(|c| c.is_finite()))
    {
        // Finite in f64 but beyond the f32 range that glTF stores.
        return Err(IoError::NonFinite { vertex: v as u64 });
    }
    let (mut lo, mut hi) = ([f32::INFINITY; 3], [f32::NEG_INFINITY; 3]);
    for p in &positions {
        for k in 0..3 {
            lo[k] = lo[k].min(p[k]);
            hi[k] = hi[k].max(p[k]);
        }
    }

    // Faces grouped by label (stable within a label), one primitive each.
    let nl = mesh.label_count();
    let mut per_label: Vec<Vec<u32>> = vec![Vec::new(); nl];
    for (f, t) in mesh.triangles.iter().enumerate() {
        per_label[mesh.face_label(f) as usize].extend_from_slice(t);
    }

    let mut bin: Vec<u8> =
        Vec::with_capacity(nv * if normals { 24 } else { 12 } + mesh.triangles.len() * 12);
    for p in &positions {
        p.iter()
            .for_each(|c| bin.extend_from_slice(&c.to_le_bytes()));
    }
    let normals_at = bin.len();
    if normals {
        for &n in &mesh.normals {
            f32s(n.normalize_or_zero())
                .iter()
                .for_each(|c| bin.extend_from_slice(&c.to_le_bytes()));
        }
    }
    let indices_at = bin.len();
    for list in &per_label {
        list.iter()
            .for_each(|i| bin.extend_from_slice(&i.to_le_bytes()));
    }
    let extra_at = bin.len();
    for a in extra {
        a.values
            .iter()
            .for_each(|x| bin.extend_from_slice(&x.to_le_bytes()));
    }

    let mut root = json::Root {
        asset: json::Asset {
            version: "2.0".to_string(),
            generator: Some(format!("isoremesh {}", env!("CARGO_PKG_VERSION"))),
            copyright: None,
            min_version: None,
            extensions: None,
            extras: Default::default(),
        },
        ..Default::default()
    };
    let uri = (format == Format::Gltf).then(|| {
        format!(
            "data:application/octet-stream;base64,{}",
            base64::engine::general_purpose::STANDARD.encode(&bin)
        )
    });
    root.push(json::Buffer {
        byte_length: USize64::from(bin.len()),
        name: None,
        uri,
        extensions: None,
        extras: Default::default(),
    });
    use json::buffer::Target;
    let pos_view = buffer_view(&mut root, 0, normals_at, Target::ArrayBuffer);
    let pos_acc = accessor(
        &mut root,
        pos_view,
        0,
        nv,
        ComponentType::F32,
        Type::Vec3,
        Some(serde_json::json!(lo)),
        Some(serde_json::json!(hi)),
    );
    let mut attributes = BTreeMap::new();
    attributes.insert(Checked::Valid(Semantic::Positions), pos_acc);
    if normals {
        let view = buffer_view(
            &mut root,
            normals_at,
            indices_at - normals_at,
            Target::ArrayBuffer,
        );
        let acc = accessor(
            &mut root,
            view,
            0,
            nv,
            ComponentType::F32,
            Type::Vec3,
            None,
            None,
        );
        attributes.insert(Checked::Valid(Semantic::Normals), acc);
    }
    let index_view = buffer_view(
        &mut root,
        indices_at,
        extra_at - indices_at,
        Target::ElementArrayBuffer,
    );
    // Custom attributes: gltf-json only names them with its `extras`
    // feature, so they are added to the primitives' JSON below.
    let mut extra_accessors = Vec::with_capacity(extra.len());
    let mut at = extra_at;
    for a in extra {
        let len = a.values.len() * 4;
        let view = buffer_view(&mut root, at, len, Target::ArrayBuffer);
        let acc = accessor(
            &mut root,
            view,
            0,
            a.values.len(),
            ComponentType::F32,
            Type::Scalar,
            None,
            None,
        );
        extra_accessors.push((a.name.clone(), acc.value()));
        at += len;
    }

    let mut primitives = Vec::new();
    let mut offset = 0;
    let mut uses_strength = false;
    for (l, list) in per_label.iter().enumerate() {
        if list.is_empty() {
            continue;
        }
        let indices = accessor(
            &mut root,
            index_view,
            offset,
            list.len(),
            ComponentType::U32,
            Type::Scalar,
            None,
            None,
        );
        offset += list.len() * 4;
        let material = match mesh.labels.get(l).and_then(|lab| lab.material.as_ref()) {
            Some(m) => {
                let (jm, strength) = to_json_material(m);
                uses_strength |= strength;
                Some(root.push(jm))
            }
            None => None,
        };
        primitives.push(json::mesh::Primitive {
            attributes: attributes.clone(),
            extensions: None,
            extras: Default::default(),
            indices: Some(indices),
            material,
            mode: Checked::Valid(Mode::Triangles),
            targets: None,
        });
    }
    if uses_strength {
        root.extensions_used
            .push("KHR_materials_emissive_strength".to_string());
    }
    let mesh_index = root.push(json::Mesh {
        extensions: None,
        extras: Default::default(),
        name: Some("isoremesh".to_string()),
        primitives,
        weights: None,
    });
    let node = root.push(json::Node {
        mesh: Some(mesh_index),
        ..Default::default()
    });
    let scene = root.push(json::Scene {
        extensions: None,
        extras: Default::default(),
        name: None,
        nodes: vec![node],
    });
    root.scene = Some(scene);

    let ser =
        |e: serde_json::Error| IoError::parse(format, format!("serializing the JSON failed: {e}"));
    let json_text = if extra_accessors.is_empty() {
        serde_json::to_vec(&root).map_err(ser)?
    } else {
        let mut doc = serde_json::to_value(&root).map_err(ser)?;
        if let Some(prims) = doc["meshes"][0]["primitives"].as_array_mut() {
            for p in prims {
                for (name, acc) in &extra_accessors {
                    p["attributes"][name] = serde_json::json!(acc);
                }
            }
        }
        serde_json::to_vec(&doc).map_err(ser)?
    };
    if format == Format::Gltf {
        return Ok(json_text);
    }
    glb_container(json_text, bin)
}

/// Wraps JSON and binary data in a GLB container (header, JSON chunk padded
/// with spaces, BIN chunk padded with zeros).
fn glb_container(mut json_text: Vec<u8>, mut bin: Vec<u8>) -> Result<Vec<u8>, IoError> {
    while json_text.len() % 4 != 0 {
        json_text.push(b' ');
    }
    while bin.len() % 4 != 0 {
        bin.push(0);
    }
    let total = 12 + 8 + json_text.len() + 8 + bin.len();
    let too_large = || IoError::TooLarge {
        message: "the GLB would exceed 4 GiB".to_string(),
    };
    let total32 = u32::try_from(total).map_err(|_| too_large())?;
    let mut out = Vec::with_capacity(total);
    out.extend_from_slice(GLB_MAGIC);
    out.extend_from_slice(&2u32.to_le_bytes());
    out.extend_from_slice(&total32.to_le_bytes());
    out.extend_from_slice(&(json_text.len() as u32).to_le_bytes());
    out.extend_from_slice(&CHUNK_JSON.to_le_bytes());
    out.extend_from_slice(&json_text);
    out.extend_from_slice(&(bin.len() as u32).to_le_bytes());
    out.extend_from_slice(&CHUNK_BIN.to_le_bytes());
    out.extend_from_slice(&bin);
    Ok(out)
}
