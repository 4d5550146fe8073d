//! Geomview OFF, text form: a header keyword (`OFF`, or a variant with the
//! prefixes `ST`, `C`, `N`, `4`, `n` such as `COFF`, `NOFF`), the counts
//! `V F E`, then one vertex per line and one face per line as
//! `n i0 … i(n-1)` with optional trailing colour. `#` starts a comment.
//! Only the first three numbers of a vertex line are positions; colours,
//! normals and texture coordinates that follow are skipped. Polygons are
//! triangulated by [`super::polygon`]. Binary OFF and 4D/nD variants are refused.

use std::io::Write;

use glam::DVec3;

use super::format::is_off_keyword;
use super::text::{push_lines, push_u64, push_vec3_line};
use super::{Format, Imported, IoError};
use crate::TriMesh;

/// The meaningful lines: comments stripped, blank lines skipped.
fn data_lines(text: &str) -> impl Iterator<Item = &str> {
    text.lines()
        .map(|l| l.split('#').next().unwrap_or("").trim())
        .filter(|l| !l.is_empty())
}

fn parse_err(message: impl AsRef<str>) -> IoError {
    IoError::parse(Format::Off, message)
}

pub(super) fn read(bytes: &[u8]) -> Result<Imported, IoError> {
    let text = std::str::from_utf8(bytes).map_err(|_| {
        IoError::unsupported(
            Format::Off,
            "the file is not UTF-8 text (binary OFF is not read)",
        )
    })?;
    let text = text.strip_prefix('\u{feff}').unwrap_or(text);
    let mut lines = data_lines(text);
    let first = lines.next().ok_or(IoError::Empty)?;
    let mut words = first.split_whitespace();
    let keyword = words.next().unwrap_or("");
    if !is_off_keyword(keyword.as_bytes()) {
        return Err(IoError::BadMagic {
            format: Format::Off,
            expected: "\"OFF\"",
        });
    }
    if keyword.contains('4') || keyword.contains('n') {
        return Err(IoError::unsupported(
            Format::Off,
            format!("{keyword} (4D or n-dimensional vertices)"),
        ));
    }
    // The counts may follow the keyword on the same line.
    let mut rest: Vec<&str> = words.collect();
    if rest.first() == Some(&"BINARY") {
        return Err(IoError::unsupported(Format::Off, "binary OFF"));
    }
    if rest.is_empty() {
        rest = lines
            .next()
            .ok_or_else(|| parse_err("missing the vertex and face counts"))?
            .split_whitespace()
            .collect();
    }
    let count = |i: usize, what: &str| -> Result<usize, IoError> {
        rest.get(i)
            .and_then(|w| w.parse::<usize>().ok())
            .ok_or_else(|| parse_err(format!("the header has no valid {what} count")))
    };
    let (nv, nf) = (count(0, "vertex")?, count(1, "face")?);
    // Every vertex and face takes at least two bytes ("0\n"), which bounds
    // the counts before anything is allocated.
    for (n, what) in [(nv, "vertices"), (nf, "faces")] {
        if n > bytes.len() / 2 {
            return Err(IoError::Truncated {
                format: Format::Off,
                what: format!("{n} {what}"),
                needed: (n as u64).saturating_mul(2),
                available: bytes.len() as u64,
            });
        }
    }
    super::vertex_index(nv)?;

    let mut mesh = TriMesh::default();
    mesh.positions.reserve(nv);
    for i in 0..nv {
        let line = lines
            .next()
            .ok_or_else(|| parse_err(format!("the file ends after {i} of {nv} vertices")))?;
        let mut c = [0.0; 3];
        let mut w = line.split_whitespace();
        for x in &mut c {
            *x = w
                .next()
                .and_then(|s| s.parse::<f64>().ok())
                .ok_or_else(|| parse_err(format!("vertex {i} does not start with 3 numbers")))?;
        }
        mesh.positions.push(DVec3::from_array(c));
    }
    mesh.triangles.reserve(nf);
    let mut ignored = 0;
    let mut corners: Vec<i64> = Vec::new();
    let mut polygon: Vec<u32> = Vec::new();
    for i in 0..nf {
        let line = lines
            .next()
            .ok_or_else(|| parse_err(format!("the file ends after {i} of {nf} faces")))?;
        let mut w = line.split_whitespace();
        let n = w
            .next()
            .and_then(|s| s.parse::<usize>().ok())
            .ok_or_else(|| parse_err(format!("face {i} does not start with a corner count")))?;
        corners.clear();
        for _ in 0..n {
            let v = w
                .next()
                .and_then(|s| s.parse::<i64>().ok())
                .ok_or_else(|| parse_err(format!("face {i} has fewer than {n} vertex indices")))?;
            corners.push(v);
        }
        if n < 3 {
            ignored += 1;
            continue;
        }
        for &v in &corners {
            if v < 0 || v as u64 >= nv as u64 {
                return Err(IoError::IndexOutOfRange {
                    face: i as u64,
                    index: v,
                    vertex_count: nv as u64,
                });
            }
        }
        // In range, so each index fits in u32.
        polygon.clear();
        polygon.extend(corners.iter().map(|&v| v as u32));
        super::polygon::triangulate(i as u64, &polygon, &mut mesh.triangles)?;
    }
    Ok(Imported {
        mesh,
        ignored_primitives: ignored,
    })
}

pub(super) fn write(mesh: &TriMesh) -> Vec<u8> {
    let mut out = Vec::with_capacity(mesh.positions.len() * 60 + mesh.triangles.len() * 24);
    // Writing into a Vec cannot fail.
    let _ = writeln!(
        out,
        "OFF\n{} {} 0",
        mesh.positions.len(),
        mesh.triangles.len()
    );
    push_lines(&mut out, &mesh.positions, 60, |o, _, &p| {
        push_vec3_line(o, b"", p)
    });
    push_lines(&mut out, &mesh.triangles, 24, |o, _, t| {
        o.push(b'3');
        for &v in t {
            o.push(b' ');
            push_u64(o, v as u64);
        }
        o.push(b'\n');
    });
    out
}
