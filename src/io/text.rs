//! Fast text output for the line-based writers (OBJ, OFF): shortest
//! round-trip floats (ryu) and integers (itoa) appended to byte buffers, and
//! lines formatted in parallel chunks that are joined in order, so the bytes
//! do not depend on the thread count.

use rayon::prelude::*;

/// Items per chunk formatted by one task.
const CHUNK: usize = 8192;

/// Appends the shortest decimal that reads back as exactly `x`.
#[inline]
pub(super) fn push_f64(out: &mut Vec<u8>, x: f64) {
    let mut buf = ryu::Buffer::new();
    out.extend_from_slice(buf.format(x).as_bytes());
}

/// Appends `x` in decimal.
#[inline]
pub(super) fn push_u64(out: &mut Vec<u8>, x: u64) {
    let mut buf = itoa::Buffer::new();
    out.extend_from_slice(buf.format(x).as_bytes());
}

/// Appends `prefix`, then the three coordinates separated by spaces, then a newline.
#[inline]
pub(super) fn push_vec3_line(out: &mut Vec<u8>, prefix: &[u8], v: glam::DVec3) {
    out.extend_from_slice(prefix);
    push_f64(out, v.x);
    out.push(b' ');
    push_f64(out, v.y);
    out.push(b' ');
    push_f64(out, v.z);
    out.push(b'\n');
}

/// Appends the lines `line` writes for every item (with its index), formatting
/// chunks of items in parallel and joining them in order.
pub(super) fn push_lines<T: Sync>(
    out: &mut Vec<u8>,
    items: &[T],
    bytes_per_item: usize,
    line: impl Fn(&mut Vec<u8>, usize, &T) + Sync,
) {
    let parts: Vec<Vec<u8>> = items
        .par_chunks(CHUNK)
        .enumerate()
        .map(|(c, chunk)| {
            let mut buf = Vec::with_capacity(chunk.len() * bytes_per_item);
            for (k, item) in chunk.iter().enumerate() {
                line(&mut buf, c * CHUNK + k, item);
            }
            buf
        })
        .collect();
    out.reserve(parts.iter().map(Vec::len).sum());
    for p in parts {
        out.extend_from_slice(&p);
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn floats_read_back_exactly_and_lines_keep_order() {
        let xs = [0.1, -2.5e-9, 1.0, 123456.789, f64::MIN_POSITIVE, -0.0];
        let mut out = Vec::new();
        push_lines(&mut out, &xs, 24, |o, i, &x| {
            push_u64(o, i as u64);
            o.push(b' ');
            push_f64(o, x);
            o.push(b'\n');
        });
        let text = String::from_utf8(out).unwrap();
        for (i, l) in text.lines().enumerate() {
            let (a, b) = l.split_once(' ').unwrap();
            assert_eq!(a.parse::<usize>().unwrap(), i);
            assert_eq!(b.parse::<f64>().unwrap().to_bits(), xs[i].to_bits());
        }
        // Many chunks join in order.
        let many: Vec<u64> = (0..3 * CHUNK as u64 + 5).collect();
        let mut out = Vec::new();
        push_lines(&mut out, &many, 8, |o, _, &x| {
            push_u64(o, x);
            o.push(b'\n');
        });
        let back: Vec<u64> = String::from_utf8(out)
            .unwrap()
            .lines()
            .map(|l| l.parse().unwrap())
            .collect();
        assert_eq!(back, many);
    }
}
