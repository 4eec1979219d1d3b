//! Seeded random streams, one per (scenario seed, purpose, frame), so results never depend on
//! thread scheduling or on the order frames are processed.

use rand_pcg::Pcg64Mcg;

/// What a random stream is used for; distinct purposes never share a stream.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Hash)]
#[repr(u64)]
pub enum Stream {
    FrameTiming = 1,
    PixelNoise = 2,
    CameraVibration = 3,
    Mechanism = 4,
    MonteCarlo = 5,
    Compression = 6,
    /// Sub-pixel placement of the aligned nominal in a diagnosis's simulations.
    DiagnoseNuisance = 7,
    /// Generated inputs of the parser fuzzing harness (`fuzz`).
    Fuzz = 8,
    /// Pixel noise of the independent renderer (`render::independent`).
    IndependentRender = 9,
    /// Sub-pixel placement of the scene per seed of a decomposition (`pipeline::decompose`).
    DecomposePlacement = 10,
    /// Sub-pixel placement of the scene per seed of `analyze`'s error bars
    /// (`pipeline::error_bars`).
    ErrorBarPlacement = 11,
}

/// SplitMix64 finaliser: decorrelates nearby (seed, stream, index) triples.
fn mix(mut z: u64) -> u64 {
    z = z.wrapping_add(0x9E37_79B9_7F4A_7C15);
    z = (z ^ (z >> 30)).wrapping_mul(0xBF58_476D_1CE4_E5B9);
    z = (z ^ (z >> 27)).wrapping_mul(0x94D0_49BB_1331_11EB);
    z ^ (z >> 31)
}

/// The random stream for `purpose` at `index` (usually the frame number) under `seed`.
pub fn stream(seed: u64, purpose: Stream, index: u64) -> Pcg64Mcg {
    let a = mix(seed ^ mix(purpose as u64));
    let b = mix(a ^ mix(index.wrapping_add(0x5851_F42D_4C95_7F2D)));
    let state = ((a as u128) << 64) | (b as u128);
    Pcg64Mcg::new(state | 1)
}

#[cfg(test)]
mod tests {
    use super::*;
    use rand::Rng;

    #[test]
    fn streams_are_reproducible_and_distinct() {
        let x: u64 = stream(7, Stream::PixelNoise, 3).gen();
        let y: u64 = stream(7, Stream::PixelNoise, 3).gen();
        let z: u64 = stream(7, Stream::PixelNoise, 4).gen();
        let w: u64 = stream(7, Stream::FrameTiming, 3).gen();
        let v: u64 = stream(8, Stream::PixelNoise, 3).gen();
        assert_eq!(x, y);
        assert_ne!(x, z);
        assert_ne!(x, w);
        assert_ne!(x, v);
    }
}
