//! Bytes in, bytes out: reading and writing [`TriMesh`] as OBJ, glTF 2.0
//! (`.gltf` with embedded buffers and `.glb`), STL, PLY and OFF, format
//! detection, and split vertex normals for rendering.
//!
//! The layer never touches the filesystem or the network: a file that a
//! model names beside itself (a glTF buffer or image, an OBJ material
//! library or texture map) must be handed in through
//! [`ReadOptions::external_buffers`]; [`companions`] says which files those
//! are. Readers return the raw indexed triangles of the file (an STL is a
//! soup of three vertices per triangle); welding and repair belong to the
//! half-edge builder. Hostile input yields a typed [`IoError`], never a
//! panic: every length, count, stride and index is checked before it is
//! used, and third-party parsers run under `catch_unwind` as a last line of
//! defence. Format references: the Khronos glTF 2.0 specification, Paul
//! Bourke's PLY and OBJ notes, Geomview's OFF description, and the 3D
//! Systems STL layout (80-byte header, u32 count, 50-byte facets).

mod attributes;
pub mod companions;
mod error;
mod format;
mod gltf;
mod instances;
mod mtl;
mod normals;
mod obj;
mod off;
mod ply;
pub mod polygon;
pub(crate) mod result_mesh;
mod stl;
mod tangents;
mod text;

use std::collections::HashMap;
use std::panic::{catch_unwind, AssertUnwindSafe};

pub use attributes::{Attribute, Attributes};
pub use error::IoError;
pub use format::Format;
pub use gltf::percent_decode;
pub use normals::with_split_normals;

use crate::TriMesh;

/// Default for [`ReadOptions::max_triangles`]: 2^27 triangles, about 3 GB of
/// [`TriMesh`]. It bounds the output of glTF files that instance one mesh
/// from many nodes, where a small file can describe a huge mesh.
pub const DEFAULT_MAX_TRIANGLES: u64 = 1 << 27;

/// Inputs a reader may need besides the main file's bytes.
#[derive(Clone, Debug)]
pub struct ReadOptions {
    /// Companion files (see [`companions`]): a `.gltf`'s external buffers
    /// and images, an OBJ's material libraries and texture maps, keyed by
    /// the name the model gives them (percent-decoded keys, `/` for `\`,
    /// and bare file names also match).
    pub external_buffers: HashMap<String, Vec<u8>>,
    /// The largest number of triangles a reader may produce; larger meshes
    /// fail with [`IoError::TooLarge`] before they are allocated.
    pub max_triangles: u64,
}

impl Default for ReadOptions {
    fn default() -> Self {
        Self {
            external_buffers: HashMap::new(),
            max_triangles: DEFAULT_MAX_TRIANGLES,
        }
    }
}

/// The result of reading a file.
#[derive(Clone, Debug)]
pub struct Imported {
    /// The mesh, unwelded, with labels when the format carries them.
    pub mesh: TriMesh,
    /// How many non-triangle primitives were skipped: glTF points/lines
    /// primitives (and primitives without positions), OFF/PLY faces with
    /// fewer than three corners.
    pub ignored_primitives: u64,
}

/// How to write a mesh.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub struct WriteOptions {
    /// Write the mesh's per-vertex normals when it has them (OBJ `vn`, glTF
    /// `NORMAL`, PLY `nx ny nz`). STL always stores face normals; OFF never
    /// stores normals.
    pub normals: bool,
    /// Binary rather than ASCII, for STL and PLY.
    pub binary: bool,
}

impl Default for WriteOptions {
    fn default() -> Self {
        Self {
            normals: true,
            binary: true,
        }
    }
}

/// Reads a mesh of the given format from bytes.
///
/// The result satisfies [`TriMesh::check`], has at least one triangle and
/// only finite coordinates.
pub fn read(bytes: &[u8], format: Format, opts: &ReadOptions) -> Result<Imported, IoError> {
    let imported = guarded(format, || match format {
        Format::Obj => obj::read(bytes, opts),
        Format::Gltf | Format::Glb => gltf::read(bytes, format, opts),
        Format::Stl => stl::read(bytes),
        Format::Ply => ply::read(bytes),
        Format::Off => off::read(bytes),
    })?;
    validate_read(&imported.mesh, opts)?;
    Ok(imported)
}

/// Writes a mesh in the given format.
///
/// Fails with [`IoError::InvalidMesh`] when the mesh breaks its invariants
/// and with [`IoError::Empty`] when it has no triangles.
pub fn write(mesh: &TriMesh, format: Format, opts: &WriteOptions) -> Result<Vec<u8>, IoError> {
    write_with_attributes(mesh, format, opts, &Attributes::default())
}

/// Writes a mesh with per-element attributes (see [`Attributes`] for how
/// each format stores them). Without attributes the bytes are those of
/// [`write`]; with attributes, formats other than glTF, GLB and PLY fail
/// with [`IoError::Unsupported`].
pub fn write_with_attributes(
    mesh: &TriMesh,
    format: Format,
    opts: &WriteOptions,
    attrs: &Attributes,
) -> Result<Vec<u8>, IoError> {
    validate_write(mesh, format, attrs)?;
    let normals = opts.normals && !mesh.normals.is_empty();
    let (mesh, attrs) = match format {
        Format::Gltf | Format::Glb => (
            std::borrow::Cow::Borrowed(mesh),
            std::borrow::Cow::Borrowed(attrs),
        ),
        _ => instances::expand(mesh, attrs)?,
    };
    let (mesh, attrs) = (&*mesh, &*attrs);
    match format {
        Format::Obj => Ok(obj::write(mesh, normals, None)),
        Format::Gltf | Format::Glb => {
            let (split, extra) = if attrs.is_empty() {
                (std::borrow::Cow::Borrowed(mesh), Vec::new())
            } else {
                let (m, e) = attributes::per_corner(mesh, attrs);
                (std::borrow::Cow::Owned(m), e)
            };
            if normals && tangents::wanted(&split) {
                // A per-corner mesh has one corner per vertex, so tangents
                // never split it and `extra` keeps its vertex order.
                let (m, t) = tangents::with_tangents(&split);
                debug_assert!(extra.is_empty() || m.positions.len() == split.positions.len());
                gltf::write(&m, format, normals, &extra, Some(&t))
            } else {
                gltf::write(&split, format, normals, &extra, None)
            }
        }
        Format::Stl => Ok(stl::write(mesh, opts.binary)),
        Format::Ply => ply::write(mesh, opts.binary, normals, attrs),
        Format::Off => Ok(off::write(mesh)),
    }
}

/// Writes a mesh as the files its format needs, named after `stem`: the
/// model file first, then its companions. An OBJ with materials comes with
/// `stem.mtl` and its texture images (under their own relative names when
/// they have plain ones); every other format is one file, as [`write_with_attributes`]
/// writes it.
pub fn write_files(
    mesh: &TriMesh,
    format: Format,
    opts: &WriteOptions,
    attrs: &Attributes,
    stem: &str,
) -> Result<Vec<(String, Vec<u8>)>, IoError> {
    if format != Format::Obj {
        let bytes = write_with_attributes(mesh, format, opts, attrs)?;
        return Ok(vec![(format!("{stem}.{}", format.extension()), bytes)]);
    }
    validate_write(mesh, format, attrs)?;
    let normals = opts.normals && !mesh.normals.is_empty();
    let (mesh, _) = instances::expand(mesh, attrs)?;
    Ok(obj::write_files(&mesh, normals, stem))
}

/// The checks every writer's input passes.
fn validate_write(mesh: &TriMesh, format: Format, attrs: &Attributes) -> Result<(), IoError> {
    mesh.check()
        .map_err(|message| IoError::InvalidMesh { message })?;
    if mesh.triangles.is_empty() {
        return Err(IoError::Empty);
    }
    if let Some(v) = mesh.positions.iter().position(|p| !p.is_finite()) {
        return Err(IoError::NonFinite { vertex: v as u64 });
    }
    attrs.check(mesh, format)
}

/// Runs a reader, turning a panic inside it into [`IoError::Panic`].
fn guarded<T>(format: Format, f: impl FnOnce() -> Result<T, IoError>) -> Result<T, IoError> {
    match catch_unwind(AssertUnwindSafe(f)) {
        Ok(r) => r,
        Err(payload) => {
            let message = payload
                .downcast_ref::<&str>()
                .map(|s| s.to_string())
                .or_else(|| payload.downcast_ref::<String>().cloned())
                .unwrap_or_else(|| "unknown panic".to_string());
            Err(IoError::Panic {
                format,
                message: error::one_line(&message),
            })
        }
    }
}

/// The checks every reader's output passes: size limit, indices in range,
/// finite coordinates, at least one triangle.
fn validate_read(mesh: &TriMesh, opts: &ReadOptions) -> Result<(), IoError> {
    check_triangle_budget(mesh.triangles.len() as u64, opts)?;
    let n = mesh.positions.len();
    for (f, t) in mesh.triangles.iter().enumerate() {
        if let Some(&v) = t.iter().find(|&&v| v as usize >= n) {
            return Err(IoError::IndexOutOfRange {
                face: f as u64,
                index: i64::from(v),
                vertex_count: n as u64,
            });
        }
    }
    if let Some(v) = mesh.positions.iter().position(|p| !p.is_finite()) {
        return Err(IoError::NonFinite { vertex: v as u64 });
    }
    if mesh.triangles.is_empty() {
        return Err(IoError::Empty);
    }
    debug_assert_eq!(mesh.check(), Ok(()));
    Ok(())
}

/// Fails when `triangles` exceeds the caller's limit.
pub(crate) fn check_triangle_budget(triangles: u64, opts: &ReadOptions) -> Result<(), IoError> {
    if triangles > opts.max_triangles {
        return Err(IoError::TooLarge {
            message: format!(
                "{triangles} triangles exceed the limit of {}",
                opts.max_triangles
            ),
        });
    }
    Ok(())
}

/// Converts a vertex count to the u32 index range of [`TriMesh`].
pub(crate) fn vertex_index(count: usize) -> Result<u32, IoError> {
    u32::try_from(count).map_err(|_| IoError::TooLarge {
        message: format!("{count} vertices exceed the u32 index range"),
    })
}
