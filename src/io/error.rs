//! The typed errors of the format layer. Every message is a single line that
//! names the problem, because the CLI prints it as `FILE: {error}`.

use super::Format;

/// Why reading or writing a mesh failed.
#[derive(Debug, thiserror::Error)]
pub enum IoError {
    /// The format could not be determined or a format name is unknown.
    #[error("unknown mesh format: {hint} (known formats: obj, gltf, glb, stl, ply, off)")]
    UnknownFormat {
        /// What was looked at.
        hint: String,
    },
    /// The data ends before a structure it declares.
    #[error(
        "{format} data is truncated: {what} needs {} bytes but only {available} are present", byte_end_text(*.needed)
    )]
    Truncated {
        /// The format being read.
        format: Format,
        /// The structure that does not fit.
        what: String,
        /// Bytes the structure needs.
        needed: u64,
        /// Bytes actually present.
        available: u64,
    },
    /// The data does not start with the signature of the requested format.
    #[error("not a {format} file: the data does not start with {expected}")]
    BadMagic {
        /// The format that was requested.
        format: Format,
        /// The signature that was expected.
        expected: &'static str,
    },
    /// A glTF accessor reaches past the end of its buffer view or buffer.
    #[error("glTF accessor {accessor} is out of bounds: it needs bytes up to {} but {within} has only {available}", byte_end_text(*.needed))]
    AccessorOutOfBounds {
        /// Accessor index.
        accessor: usize,
        /// What it is read from ("buffer view 3", "buffer 0").
        within: String,
        /// One past the last byte it needs (saturated on overflow).
        needed: u64,
        /// Length of the view or buffer.
        available: u64,
    },
    /// A glTF accessor declares zero elements, which the spec forbids.
    #[error("glTF accessor {accessor} has count 0 (the spec requires at least 1)")]
    ZeroCount {
        /// Accessor index.
        accessor: usize,
    },
    /// A glTF buffer view's byteStride is smaller than one element.
    #[error("glTF accessor {accessor}: buffer view {view} has byteStride {stride}, smaller than its {element_size}-byte elements")]
    BadStride {
        /// Accessor index.
        accessor: usize,
        /// Buffer view index.
        view: usize,
        /// Declared stride.
        stride: u64,
        /// Size of one element.
        element_size: u64,
    },
    /// A glTF buffer lives in another file that the caller did not provide.
    /// isoremesh never opens a file or URL named inside a model.
    #[error("{format} refers to the external file {uri:?}, which was not provided (isoremesh never opens files named inside a model; supply it together with the model)")]
    ExternalBuffer {
        /// The format of the model that names it.
        format: Format,
        /// The buffer's `uri` as written in the file.
        uri: String,
    },
    /// A vertex coordinate is NaN or infinite.
    #[error("vertex {vertex} has a non-finite coordinate (NaN or infinity)")]
    NonFinite {
        /// Vertex index (0-based, in the order the reader produced them).
        vertex: u64,
    },
    /// An OBJ face refers to a vertex that does not exist, reported in the
    /// file's own numbering: lines, faces and vertices counted from 1, the
    /// index as written (negative indices count back from the last vertex
    /// declared before the face).
    #[error("line {line}: face {face} refers to vertex {index}, but {}", obj_vertices_text(*.index, *.declared, *.vertex_count))]
    ObjIndexOutOfRange {
        /// Line of the face (1-based).
        line: u64,
        /// Face number (1-based, counting `f` lines).
        face: u64,
        /// The offending index as written in the file.
        index: i64,
        /// Vertices declared before the face (the base of negative indices).
        declared: u64,
        /// Vertices in the whole file.
        vertex_count: u64,
    },
    /// A face refers to a vertex that does not exist.
    #[error("face {face} refers to vertex {index}, but there are only {vertex_count} vertices (indices counted from 0)")]
    IndexOutOfRange {
        /// Face index (0-based).
        face: u64,
        /// The offending vertex index, 0-based (negative for OBJ index 0 or
        /// a relative index reaching before the first vertex).
        index: i64,
        /// Number of vertices available.
        vertex_count: u64,
    },
    /// The data contains no triangles.
    #[error("the mesh contains no triangles")]
    Empty,
    /// The data violates the format.
    #[error("invalid {format} data: {message}")]
    Parse {
        /// The format being read.
        format: Format,
        /// What is wrong, on one line.
        message: String,
    },
    /// The data uses a feature isoremesh does not read (Draco compression,
    /// binary OFF, ...).
    #[error("unsupported {format} feature: {message}")]
    Unsupported {
        /// The format being read.
        format: Format,
        /// What is unsupported.
        message: String,
    },
    /// A third-party parser panicked; caught so that hostile input cannot
    /// take the process down.
    #[error("the {format} parser failed on malformed input: {message}")]
    Panic {
        /// The format being read.
        format: Format,
        /// The panic payload, when it was a string.
        message: String,
    },
    /// The mesh would exceed a size limit ([`super::ReadOptions::max_triangles`]
    /// or the u32 index range).
    #[error("mesh is too large: {message}")]
    TooLarge {
        /// Which limit was hit.
        message: String,
    },
    /// The mesh passed to a writer breaks [`crate::TriMesh`]'s invariants.
    #[error("cannot write an invalid mesh: {message}")]
    InvalidMesh {
        /// The failed invariant.
        message: String,
    },
}

/// Collapses a possibly multi-line message from a dependency into one line.
pub(crate) fn one_line(s: &str) -> String {
    s.split_whitespace().collect::<Vec<_>>().join(" ")
}

impl IoError {
    pub(crate) fn parse(format: Format, message: impl AsRef<str>) -> Self {
        IoError::Parse {
            format,
            message: one_line(message.as_ref()),
        }
    }

    pub(crate) fn unsupported(format: Format, message: impl AsRef<str>) -> Self {
        IoError::Unsupported {
            format,
            message: one_line(message.as_ref()),
        }
    }
}

/// The second half of [`IoError::ObjIndexOutOfRange`]'s message, in OBJ's
/// numbering.
fn obj_vertices_text(index: i64, declared: u64, vertex_count: u64) -> String {
    if index < 0 {
        format!("only {declared} vertices are declared before it (relative indices run from -1 to -{declared})")
    } else {
        format!("the file has {vertex_count} vertices, numbered 1 to {vertex_count}")
    }
}

/// A byte position for a message; the readers saturate an overflowing end
/// at `u64::MAX`, which must not read as a real position.
fn byte_end_text(end: u64) -> String {
    if end == u64::MAX {
        "more than 2^64 (the declared sizes overflow)".to_string()
    } else {
        end.to_string()
    }
}
