//! Latin-hypercube designs.
//!
//! `n` points in the unit cube `[0, 1]^m`: coordinate `j` of point `i` is
//!
//! ```text
//! u_ij = (σ_j(i) + v_ij) / n,      v_ij ~ U[0, 1),
//! ```
//!
//! with `σ_j` an independent uniform random permutation of `0..n` per coordinate, so that every
//! one of the `n` equal strata of every coordinate holds exactly one point. The permutations
//! are drawn by a Fisher–Yates shuffle written out here (from the last element down, swap `i`
//! with a uniform index in `0..=i`), not by the `rand` crate's shuffle, so a seed keeps giving
//! the same design across `rand` versions. Per coordinate the permutation is drawn first,
//! then the `n` offsets.
//!
//! ```
//! use numerics::latin_hypercube::latin_hypercube_in_box;
//! use rand::SeedableRng;
//! let mut rng = rand_chacha::ChaCha8Rng::seed_from_u64(7);
//! let pts = latin_hypercube_in_box(&mut rng, &[(0.0, 10.0), (-1.0, 1.0)], 5);
//! assert_eq!(pts.len(), 5);
//! // one point in each fifth of the first coordinate's range
//! let mut strata: Vec<usize> = pts.iter().map(|p| (p[0] / 2.0) as usize).collect();
//! strata.sort();
//! assert_eq!(strata, vec![0, 1, 2, 3, 4]);
//! ```

use rand::Rng;

/// `n` Latin-hypercube points in `[0, 1]^m` (see the module documentation).
pub fn latin_hypercube<R: Rng + ?Sized>(rng: &mut R, n: usize, m: usize) -> Vec<Vec<f64>> {
    let mut pts = vec![vec![0.0; m]; n];
    let mut perm: Vec<usize> = Vec::with_capacity(n);
    for j in 0..m {
        perm.clear();
        perm.extend(0..n);
        for i in (1..n).rev() {
            let k = rng.random_range(0..=i);
            perm.swap(i, k);
        }
        for (p, &s) in pts.iter_mut().zip(&perm) {
            p[j] = (s as f64 + rng.random::<f64>()) / n as f64;
        }
    }
    pts
}

/// `n` Latin-hypercube points in the box `bounds`: [`latin_hypercube`] mapped by
/// `x = lo + (hi − lo)·u` per coordinate.
pub fn latin_hypercube_in_box<R: Rng + ?Sized>(
    rng: &mut R,
    bounds: &[(f64, f64)],
    n: usize,
) -> Vec<Vec<f64>> {
    let mut pts = latin_hypercube(rng, n, bounds.len());
    for p in &mut pts {
        for (v, (lo, hi)) in p.iter_mut().zip(bounds) {
            *v = lo + (hi - lo) * *v;
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
        let pts = latin_hypercube(&mut rng, n, m);
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

    #[test]
    fn a_seed_gives_one_design() {
        let draw = |seed| latin_hypercube(&mut ChaCha8Rng::seed_from_u64(seed), 6, 3);
        assert_eq!(draw(5), draw(5));
        assert_ne!(draw(5), draw(6));
        assert!(latin_hypercube(&mut ChaCha8Rng::seed_from_u64(1), 0, 3).is_empty());
    }

    #[test]
    fn boxes_scale_the_unit_design() {
        let bounds = [(2.0, 4.0), (-10.0, -5.0)];
        let unit = latin_hypercube(&mut ChaCha8Rng::seed_from_u64(3), 8, 2);
        let boxed = latin_hypercube_in_box(&mut ChaCha8Rng::seed_from_u64(3), &bounds, 8);
        for (u, x) in unit.iter().zip(&boxed) {
            for j in 0..2 {
                let (lo, hi) = bounds[j];
                assert!((lo..hi).contains(&x[j]));
                assert!((x[j] - (lo + (hi - lo) * u[j])).abs() < 1e-15);
            }
        }
    }
}
