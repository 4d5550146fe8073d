//! STL through `stl_io`: binary (80-byte header, u32 triangle count,
//! 50-byte facets of f32 normal, three f32 vertices and a u16 attribute) and
//! ASCII (`solid … facet normal … outer loop … vertex … endsolid`).
//!
//! STL has no shared vertices, so reading yields three vertices per
//! triangle; the builder welds them. Binary versus ASCII is decided here, not
//! by `stl_io`'s keyword probe, because many binary files start their header
//! with `solid`: a file whose length matches its triangle count, or that
//! contains NUL bytes near the start, is binary.

use std::borrow::Cow;
use std::io::{Cursor, Write};

use glam::DVec3;

use super::format::binary_stl_size;
use super::{Format, Imported, IoError};
use crate::geometry::triangle_normal;
use crate::TriMesh;

pub(super) fn read(bytes: &[u8]) -> Result<Imported, IoError> {
    let text_start = bytes
        .iter()
        .position(|c| !c.is_ascii_whitespace())
        .unwrap_or(bytes.len());
    let text = &bytes[text_start..];
    let exact_binary = binary_stl_size(bytes) == Some(bytes.len() as u64);
    let has_nul = bytes[..bytes.len().min(1024)].contains(&0);
    if text.starts_with(b"solid") && !exact_binary && !has_nul {
        read_ascii(text)
    } else {
        read_binary(bytes)
    }
}

fn read_binary(bytes: &[u8]) -> Result<Imported, IoError> {
    let Some(size) = binary_stl_size(bytes) else {
        return Err(IoError::Truncated {
            format: Format::Stl,
            what: "the binary STL header".into(),
            needed: 84,
            available: bytes.len() as u64,
        });
    };
    let n = (size - 84) / 50;
    if size > bytes.len() as u64 {
        return Err(IoError::Truncated {
            format: Format::Stl,
            what: format!("a binary STL with {n} triangles"),
            needed: size,
            available: bytes.len() as u64,
        });
    }
    super::vertex_index(3 * n as usize)?;
    // `size` fits in the slice, so it fits in usize.
    let body = &bytes[..size as usize];
    // stl_io treats any file starting with "solid " as ASCII; hide the word
    // from its probe (the header is free text and ignored).
    let data: Cow<[u8]> = if body.starts_with(b"solid") {
        let mut owned = body.to_vec();
        owned[0] = b'S';
        Cow::Owned(owned)
    } else {
        Cow::Borrowed(body)
    };
    let mut cursor = Cursor::new(data.as_ref());
    let reader = stl_io::create_stl_reader(&mut cursor)
        .map_err(|e| IoError::parse(Format::Stl, e.to_string()))?;
    let mut mesh = TriMesh::default();
    mesh.positions.reserve(3 * n as usize);
    mesh.triangles.reserve(n as usize);
    for t in reader {
        let t = t.map_err(|e| IoError::parse(Format::Stl, e.to_string()))?;
        push_triangle(&mut mesh, &t)?;
    }
    Ok(Imported {
        mesh,
        ignored_primitives: 0,
    })
}

fn read_ascii(text: &[u8]) -> Result<Imported, IoError> {
    // stl_io wants "solid " with a space; the solid's name is optional.
    let data: Cow<[u8]> = if text.starts_with(b"solid ") {
        Cow::Borrowed(text)
    } else {
        let mut owned = b"solid ".to_vec();
        owned.extend_from_slice(&text[5..]);
        Cow::Owned(owned)
    };
    let mut cursor = Cursor::new(data.as_ref());
    let reader = stl_io::create_stl_reader(&mut cursor)
        .map_err(|e| IoError::parse(Format::Stl, e.to_string()))?;
    let mut mesh = TriMesh::default();
    for t in reader {
        let facet = mesh.triangles.len();
        let t = t.map_err(|e| {
            let message = e.to_string();
            if message.contains("finite") {
                IoError::NonFinite {
                    vertex: 3 * facet as u64,
                }
            } else {
                IoError::parse(Format::Stl, format!("facet {facet}: {message}"))
            }
        })?;
        push_triangle(&mut mesh, &t)?;
    }
    Ok(Imported {
        mesh,
        ignored_primitives: 0,
    })
}

fn push_triangle(mesh: &mut TriMesh, t: &stl_io::Triangle) -> Result<(), IoError> {
    let base = super::vertex_index(mesh.positions.len() + 3)? - 3;
    for v in &t.vertices {
        let [x, y, z] = v.0;
        mesh.positions
            .push(DVec3::new(f64::from(x), f64::from(y), f64::from(z)));
    }
    mesh.triangles.push([base, base + 1, base + 2]);
    Ok(())
}

fn facet(mesh: &TriMesh, t: &[u32; 3]) -> stl_io::Triangle {
    let p = mesh.corner_positions(t);
    let f = |v: DVec3| [v.x as f32, v.y as f32, v.z as f32];
    stl_io::Triangle {
        normal: stl_io::Normal::new(f(triangle_normal(p))),
        vertices: p.map(|v| stl_io::Vertex::new(f(v))),
    }
}

pub(super) fn write(mesh: &TriMesh, binary: bool) -> Vec<u8> {
    let mut out = Vec::new();
    if binary {
        out.reserve(84 + 50 * mesh.triangles.len());
        // Writing into a Vec cannot fail.
        let _ = stl_io::write_stl(&mut out, mesh.triangles.iter().map(|t| facet(mesh, t)));
        return out;
    }
    out.reserve(250 * mesh.triangles.len());
    let _ = writeln!(out, "solid isoremesh");
    for t in &mesh.triangles {
        let s = facet(mesh, t);
        let [nx, ny, nz] = s.normal.0;
        let _ = writeln!(out, "  facet normal {nx:e} {ny:e} {nz:e}\n    outer loop");
        for v in &s.vertices {
            let [x, y, z] = v.0;
            let _ = writeln!(out, "      vertex {x:e} {y:e} {z:e}");
        }
        let _ = writeln!(out, "    endloop\n  endfacet");
    }
    let _ = writeln!(out, "endsolid isoremesh");
    out
}
