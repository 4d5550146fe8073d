//! The random stream of the distance samples: PCG64 (O'Neill 2014, the
//! XSL-RR 128/64 variant) seeded through the SeedSequence entropy mixer, bit
//! for bit as NumPy's `numpy.random.default_rng(seed)` draws it, and its
//! `random()` doubles. Drawing the same numbers as the benchmark's
//! `quality.py` means that, on the same mesh, both tools measure the
//! distance at the same sample points, so their figures agree exactly
//! instead of within two independent samplings' noise.
//!
//! The algorithms follow their published descriptions: PCG64 in O'Neill,
//! "PCG: A Family of Simple Fast Space-Efficient Statistically Good
//! Algorithms for Random Number Generation" (2014), and the seed mixing of
//! NumPy's `SeedSequence` (NEP 19), itself after M. E. O'Neill's
//! `seed_seq_fe`. The tests pin the stream to values NumPy 2 prints.

/// PCG's default 128-bit LCG multiplier.
const MULTIPLIER: u128 = (2_549_297_995_355_413_924u128 << 64) | 4_865_540_595_714_422_341u128;

/// SeedSequence hash constants (32-bit arithmetic).
const INIT_A: u32 = 0x43b0_d7e5;
const MULT_A: u32 = 0x931e_8875;
const INIT_B: u32 = 0x8b51_f9dd;
const MULT_B: u32 = 0x58f3_8ded;
const MIX_MULT_L: u32 = 0xca01_f9dd;
const MIX_MULT_R: u32 = 0x4973_f715;
const XSHIFT: u32 = 16;
/// Words of SeedSequence's entropy pool.
const POOL_SIZE: usize = 4;

/// The 32-bit words of a non-negative integer seed, least significant
/// first; zero is one zero word, as NumPy coerces it.
fn seed_words(seed: u64) -> Vec<u32> {
    let low = seed as u32;
    let high = (seed >> 32) as u32;
    if high == 0 {
        vec![low]
    } else {
        vec![low, high]
    }
}

/// The entropy pool after mixing `entropy` (SeedSequence's `mix_entropy`).
fn mix_pool(entropy: &[u32]) -> [u32; POOL_SIZE] {
    let mut hash_const = INIT_A;
    let mut hashmix = |value: u32| -> u32 {
        let mut v = value ^ hash_const;
        hash_const = hash_const.wrapping_mul(MULT_A);
        v = v.wrapping_mul(hash_const);
        v ^ (v >> XSHIFT)
    };
    let mix = |x: u32, y: u32| -> u32 {
        let r = MIX_MULT_L
            .wrapping_mul(x)
            .wrapping_sub(MIX_MULT_R.wrapping_mul(y));
        r ^ (r >> XSHIFT)
    };
    let mut pool = [0u32; POOL_SIZE];
    for (i, slot) in pool.iter_mut().enumerate() {
        *slot = hashmix(entropy.get(i).copied().unwrap_or(0));
    }
    for src in 0..POOL_SIZE {
        for dst in 0..POOL_SIZE {
            if src != dst {
                let h = hashmix(pool[src]);
                pool[dst] = mix(pool[dst], h);
            }
        }
    }
    for &word in entropy.iter().skip(POOL_SIZE) {
        for slot in pool.iter_mut() {
            let h = hashmix(word);
            *slot = mix(*slot, h);
        }
    }
    pool
}

/// `n` 64-bit words of generated state (SeedSequence's `generate_state`).
fn generate_state<const N: usize>(pool: &[u32; POOL_SIZE]) -> [u64; N] {
    let mut hash_const = INIT_B;
    let mut words32 = Vec::with_capacity(2 * N);
    for i in 0..2 * N {
        let mut v = pool[i % POOL_SIZE] ^ hash_const;
        hash_const = hash_const.wrapping_mul(MULT_B);
        v = v.wrapping_mul(hash_const);
        words32.push(v ^ (v >> XSHIFT));
    }
    let mut out = [0u64; N];
    for (i, w) in out.iter_mut().enumerate() {
        *w = u64::from(words32[2 * i]) | (u64::from(words32[2 * i + 1]) << 32);
    }
    out
}

/// A PCG64 generator in the state `numpy.random.default_rng(seed)` starts in.
#[derive(Clone, Debug)]
pub(crate) struct Pcg64 {
    state: u128,
    increment: u128,
}

impl Pcg64 {
    /// The generator NumPy's `default_rng(seed)` builds.
    pub(crate) fn from_seed(seed: u64) -> Self {
        let words: [u64; 4] = generate_state(&mix_pool(&seed_words(seed)));
        let initial = (u128::from(words[0]) << 64) | u128::from(words[1]);
        let sequence = (u128::from(words[2]) << 64) | u128::from(words[3]);
        let mut g = Self {
            state: 0,
            increment: (sequence << 1) | 1,
        };
        g.step();
        g.state = g.state.wrapping_add(initial);
        g.step();
        g
    }

    #[inline]
    fn step(&mut self) {
        self.state = self
            .state
            .wrapping_mul(MULTIPLIER)
            .wrapping_add(self.increment);
    }

    /// The next 64-bit output (XSL-RR of the advanced state).
    #[inline]
    pub(crate) fn next_u64(&mut self) -> u64 {
        self.step();
        let folded = ((self.state >> 64) as u64) ^ (self.state as u64);
        folded.rotate_right((self.state >> 122) as u32)
    }

    /// A double uniform in [0, 1) from the top 53 bits, as `Generator.random()`.
    #[inline]
    pub(crate) fn next_f64(&mut self) -> f64 {
        (self.next_u64() >> 11) as f64 * (1.0 / (1u64 << 53) as f64)
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    /// `numpy.random.default_rng(seed).random(5)`, printed by NumPy 2.4 with
    /// `repr` (17 significant digits, so the doubles are exact).
    #[test]
    fn matches_numpy_default_rng() {
        let cases: [(u64, [f64; 3]); 3] = [
            (
                0,
                [0.6369616873214543, 0.2697867137638703, 0.04097352393619469],
            ),
            (
                1,
                [0.5118216247002567, 0.9504636963259353, 0.14415961271963373],
            ),
            (
                12345,
                [0.22733602246716966, 0.31675833970975287, 0.7973654573327341],
            ),
        ];
        for (seed, expected) in cases {
            let mut g = Pcg64::from_seed(seed);
            for e in expected {
                assert_eq!(g.next_f64(), e, "seed {seed}");
            }
        }
    }

    #[test]
    fn seeds_above_32_bits_use_two_words() {
        assert_eq!(seed_words(0), vec![0]);
        assert_eq!(seed_words(7), vec![7]);
        assert_eq!(seed_words(1 << 40), vec![0, 256]);
        // numpy.random.default_rng(2**40).random(2)
        let mut g = Pcg64::from_seed(1 << 40);
        assert_eq!(g.next_f64(), 0.3608095734199638);
        assert_eq!(g.next_f64(), 0.6282402478110984);
    }

    #[test]
    fn stream_is_uniform() {
        let mut g = Pcg64::from_seed(3);
        let mut bins = [0u32; 10];
        for _ in 0..100_000 {
            let u = g.next_f64();
            assert!((0.0..1.0).contains(&u));
            bins[(u * 10.0) as usize] += 1;
        }
        for b in bins {
            assert!((b as f64 - 10_000.0).abs() < 500.0, "{bins:?}");
        }
    }
}
