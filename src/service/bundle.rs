//! `bundle=zip` downloads: a result and its companion files (an OBJ's
//! `.mtl` and texture images) packed into one zip archive, so that a
//! multi-file format arrives whole in one request.
//!
//! Text members are deflated; images are stored as they are, since PNG and
//! JPEG are compressed already.

use std::io::{Cursor, Write};

use zip::write::SimpleFileOptions;
use zip::CompressionMethod;

/// Packs `(name, bytes)` files into a zip archive, in order.
pub fn zip(files: &[(String, Vec<u8>)]) -> std::io::Result<Vec<u8>> {
    let mut w = zip::ZipWriter::new(Cursor::new(Vec::new()));
    for (name, bytes) in files {
        let compressed = crate::appearance::sniff_image(bytes).is_some();
        let method = if compressed {
            CompressionMethod::Stored
        } else {
            CompressionMethod::Deflated
        };
        let options = SimpleFileOptions::default()
            .compression_method(method)
            .large_file(bytes.len() as u64 >= u32::MAX as u64);
        w.start_file(name.as_str(), options)
            .map_err(std::io::Error::other)?;
        w.write_all(bytes)?;
    }
    Ok(w.finish().map_err(std::io::Error::other)?.into_inner())
}
