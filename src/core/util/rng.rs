//! Random streams: every random draw of a run comes from a stream seeded
//! by (scene seed, stream id, tick), so runs are reproducible from the seed
//! for any thread count and adding a stream never shifts another.

/// Seed of stream `stream` at tick `tick` (SplitMix64 finaliser of the mix).
pub fn stream_seed(seed: u64, stream: u64, tick: u64) -> u64 {
    let mut z = seed ^ stream.rotate_left(17) ^ tick.wrapping_mul(0x9E37_79B9_7F4A_7C15);
    z = (z ^ (z >> 30)).wrapping_mul(0xBF58_476D_1CE4_E5B9);
    z = (z ^ (z >> 27)).wrapping_mul(0x94D0_49BB_1331_11EB);
    z ^ (z >> 31)
}
