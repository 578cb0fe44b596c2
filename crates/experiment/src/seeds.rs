//! Seeding: one `ChaCha8Rng` per part of the synthesis, on its own stream of a single seed.

use rand::SeedableRng;
use rand_chacha::ChaCha8Rng;

/// The independent random streams. Changing how one part draws never changes another part.
#[derive(Clone, Copy, Debug, PartialEq, Eq, Hash)]
pub enum Stream {
    /// AR(1) innovations of the trial's dynamometer noise.
    TrialAr1,
    /// White noise of the trial's dynamometer.
    TrialWhite,
    /// AR(1) innovations of the unloaded run.
    UnloadedAr1,
    /// White noise of the unloaded run.
    UnloadedWhite,
    /// Gaussian carrier of one EMG channel (0 sol, 1 gm, 2 gl, 3 ta).
    EmgCarrier(u8),
    /// Random wobble phases of one EMG channel's drive.
    EmgWobble(u8),
}

impl Stream {
    /// The ChaCha stream number.
    #[must_use]
    pub fn id(self) -> u64 {
        match self {
            Self::TrialAr1 => 1,
            Self::TrialWhite => 2,
            Self::UnloadedAr1 => 3,
            Self::UnloadedWhite => 4,
            Self::EmgCarrier(c) => 16 + u64::from(c),
            Self::EmgWobble(c) => 32 + u64::from(c),
        }
    }
}

/// `ChaCha8Rng::seed_from_u64(seed)` switched to `stream`.
#[must_use]
pub fn rng(seed: u64, stream: Stream) -> ChaCha8Rng {
    let mut r = ChaCha8Rng::seed_from_u64(seed);
    r.set_stream(stream.id());
    r
}
