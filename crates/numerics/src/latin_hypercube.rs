//! Latin-hypercube designs.
//!
//! `n` points in the unit cube `[0, 1]^m`: coordinate `j` of point `i` is
//!
//! ```text
//! u_ij = (σ_j(i) + v_ij) / n,      v_ij ~ U[0, 1),
//! ```
//!
//! with `σ_j` an independent uniform random permutation of `0..n` per coordinate, so that every
//! one of the `n` equal strata of every coordinate holds exactly one point. Per coordinate the
//! permutation is drawn first, then the `n` offsets. How the permutation is drawn from the
//! stream is a [`StrataShuffle`]: both give uniform permutations, but of different draws, and
//! each caller keeps the one its seeds have always meant.
//!
//! ```
//! use numerics::latin_hypercube::{latin_hypercube_in_box, StrataShuffle};
//! use rand::SeedableRng;
//! let mut rng = rand_chacha::ChaCha8Rng::seed_from_u64(7);
//! let pts = latin_hypercube_in_box(&mut rng, &[(0.0, 10.0), (-1.0, 1.0)], 5, StrataShuffle::Descending);
//! assert_eq!(pts.len(), 5);
//! // one point in each fifth of the first coordinate's range
//! let mut strata: Vec<usize> = pts.iter().map(|p| (p[0] / 2.0) as usize).collect();
//! strata.sort();
//! assert_eq!(strata, vec![0, 1, 2, 3, 4]);
//! ```

use rand::seq::SliceRandom;
use rand::Rng;

/// How the permutation of the strata is drawn.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum StrataShuffle {
    /// A Fisher–Yates shuffle written out here: from the last element down, swap `i` with a
    /// uniform index in `0..=i`; the draws do not depend on the `rand` version.
    Descending,
    /// The `rand` crate's `SliceRandom::shuffle`.
    Rand,
}

/// `n` points of a Latin hypercube in "stratum coordinates" `t_ij = σ_j(i) + v_ij ∈ [0, n)`
/// (`u = t/n`), `m` coordinates each.
fn strata<R: Rng + ?Sized>(
    rng: &mut R,
    n: usize,
    m: usize,
    shuffle: StrataShuffle,
) -> Vec<Vec<f64>> {
    let mut pts = vec![vec![0.0; m]; n];
    let mut perm: Vec<usize> = Vec::with_capacity(n);
    for j in 0..m {
        perm.clear();
        perm.extend(0..n);
        match shuffle {
            StrataShuffle::Descending => {
                for i in (1..n).rev() {
                    let k = rng.random_range(0..=i);
                    perm.swap(i, k);
                }
            }
            StrataShuffle::Rand => perm.shuffle(rng),
        }
        for (p, &s) in pts.iter_mut().zip(&perm) {
            p[j] = s as f64 + rng.random::<f64>();
        }
    }
    pts
}

/// `n` Latin-hypercube points in `[0, 1]^m` (see the module documentation).
pub fn latin_hypercube<R: Rng + ?Sized>(
    rng: &mut R,
    n: usize,
    m: usize,
    shuffle: StrataShuffle,
) -> Vec<Vec<f64>> {
    let mut pts = strata(rng, n, m, shuffle);
    for p in &mut pts {
        p.iter_mut().for_each(|t| *t /= n as f64);
    }
    pts
}

/// `n` Latin-hypercube points in the box `bounds`: `x = lo + (hi − lo)·t/n` per coordinate.
pub fn latin_hypercube_in_box<R: Rng + ?Sized>(
    rng: &mut R,
    bounds: &[(f64, f64)],
    n: usize,
    shuffle: StrataShuffle,
) -> Vec<Vec<f64>> {
    let mut pts = strata(rng, n, bounds.len(), shuffle);
    for p in &mut pts {
        for (v, (lo, hi)) in p.iter_mut().zip(bounds) {
            *v = lo + (hi - lo) * *v / n as f64;
        }
    }
    pts
}

#[cfg(test)]
mod tests {
    use super::*;
    use rand::SeedableRng;
    use rand_chacha::ChaCha8Rng;

    #[test]
    fn one_point_in_every_stratum_of_every_coordinate() {
        let mut rng = ChaCha8Rng::seed_from_u64(11);
        let (n, m) = (17, 4);
        for shuffle in [StrataShuffle::Descending, StrataShuffle::Rand] {
            let pts = latin_hypercube(&mut rng, n, m, shuffle);
            assert_eq!(pts.len(), n);
            for j in 0..m {
                let mut seen = vec![false; n];
                for p in &pts {
                    assert!((0.0..1.0).contains(&p[j]));
                    let s = (p[j] * n as f64) as usize;
                    assert!(!seen[s], "stratum {s} of coordinate {j} twice");
                    seen[s] = true;
                }
            }
        }
    }

    #[test]
    fn a_seed_gives_one_design() {
        let draw =
            |seed, shuffle| latin_hypercube(&mut ChaCha8Rng::seed_from_u64(seed), 6, 3, shuffle);
        for shuffle in [StrataShuffle::Descending, StrataShuffle::Rand] {
            assert_eq!(draw(5, shuffle), draw(5, shuffle));
            assert_ne!(draw(5, shuffle), draw(6, shuffle));
            assert!(latin_hypercube(&mut ChaCha8Rng::seed_from_u64(1), 0, 3, shuffle).is_empty());
        }
        // the two shuffles are different draws of one stream
        assert_ne!(
            draw(5, StrataShuffle::Descending),
            draw(5, StrataShuffle::Rand)
        );
    }

    #[test]
    fn boxes_scale_the_unit_design() {
        let bounds = [(2.0, 4.0), (-10.0, -5.0)];
        let shuffle = StrataShuffle::Descending;
        let unit = latin_hypercube(&mut ChaCha8Rng::seed_from_u64(3), 8, 2, shuffle);
        let boxed = latin_hypercube_in_box(&mut ChaCha8Rng::seed_from_u64(3), &bounds, 8, shuffle);
        for (u, x) in unit.iter().zip(&boxed) {
            for j in 0..2 {
                let (lo, hi) = bounds[j];
                assert!((lo..hi).contains(&x[j]));
                assert!((x[j] - (lo + (hi - lo) * u[j])).abs() < 1e-15);
            }
        }
    }
}
