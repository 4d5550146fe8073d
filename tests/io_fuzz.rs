//! Deterministic fuzz-style robustness: random truncations and byte flips
//! of real files must give `Ok` or a typed error, never a panic (not even
//! one caught and reported as `IoError::Panic`). Successful reads must
//! satisfy the mesh invariants.

mod data_support;

use isoremesh::io::{self, Format, IoError, ReadOptions};

/// xorshift64*: a fixed seed gives the same cases on every run.
struct Rng(u64);

impl Rng {
    fn next(&mut self) -> u64 {
        self.0 ^= self.0 >> 12;
        self.0 ^= self.0 << 25;
        self.0 ^= self.0 >> 27;
        self.0.wrapping_mul(0x2545_F491_4F6C_DD1D)
    }
    fn below(&mut self, n: usize) -> usize {
        (self.next() % n as u64) as usize
    }
}

fn check(name: &str, case: &str, bytes: &[u8], format: Format, tally: &mut [u32; 2]) {
    let opts = ReadOptions {
        max_triangles: 1 << 20,
        ..Default::default()
    };
    match io::read(bytes, format, &opts) {
        Ok(r) => {
            r.mesh
                .check()
                .unwrap_or_else(|e| panic!("{name} {case}: invalid mesh: {e}"));
            assert!(r.mesh.positions.iter().all(|p| p.is_finite()));
            assert!(!r.mesh.triangles.is_empty());
            tally[0] += 1;
        }
        Err(IoError::Panic { message, .. }) => {
            panic!("{name} {case}: a parser panicked: {message}")
        }
        Err(e) => {
            assert!(!e.to_string().contains('\n'), "{name} {case}: {e}");
            tally[1] += 1;
        }
    }
}

fn fuzz(name: &str, format: Format, rounds: usize, seed: u64) {
    let original = data_support::bytes(name);
    let mut rng = Rng(seed);
    let mut tally = [0u32; 2];
    for round in 0..rounds {
        // Truncation at a random length.
        let cut = rng.below(original.len() + 1);
        check(
            name,
            &format!("cut at {cut}"),
            &original[..cut],
            format,
            &mut tally,
        );
        // 1 to 8 random byte changes; half the time near the start, where
        // headers and JSON live.
        let mut bytes = original.clone();
        let flips = 1 + rng.below(8);
        let window = if round % 2 == 0 {
            bytes.len().min(2048)
        } else {
            bytes.len()
        };
        for _ in 0..flips {
            let at = rng.below(window);
            bytes[at] = match rng.below(4) {
                0 => 0,
                1 => 0xFF,
                2 => bytes[at] ^ (1 << rng.below(8)),
                _ => rng.next() as u8,
            };
        }
        check(
            name,
            &format!("round {round} flips"),
            &bytes,
            format,
            &mut tally,
        );
    }
    eprintln!("{name}: {} ok, {} typed errors", tally[0], tally[1]);
}

#[test]
fn duck_glb_survives_truncation_and_flips() {
    fuzz("gltf/Duck.glb", Format::Glb, 400, 1);
}

#[test]
fn embedded_gltf_survives_truncation_and_flips() {
    fuzz(
        "gltf/BoxTexturedEmbedded/BoxTextured.gltf",
        Format::Gltf,
        400,
        2,
    );
}

#[test]
fn obj_survives_truncation_and_flips() {
    fuzz("cube.obj", Format::Obj, 400, 3);
}

#[test]
fn ply_survives_truncation_and_flips() {
    fuzz("cube_quads_double_le.ply", Format::Ply, 400, 4);
    fuzz("cube_ascii.ply", Format::Ply, 400, 5);
}

#[test]
fn stl_survives_truncation_and_flips() {
    fuzz("cube_ascii.stl", Format::Stl, 400, 6);
    // First triangles of the binary spot: keeps the loop fast.
    fuzz("spot_binary.stl", Format::Stl, 100, 7);
}

#[test]
fn off_survives_truncation_and_flips() {
    fuzz("fertility.off", Format::Off, 60, 8);
}
