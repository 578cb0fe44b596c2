//! Butterworth design as second-order sections, step for step as `scipy.signal.butter`.

use crate::complex::{prod, C};
use crate::error::SignalError;
use std::f64::consts::PI;

/// Band type and edge frequencies (Hz) of a Butterworth filter.
#[derive(Debug, Clone, Copy, PartialEq)]
pub enum Band {
    /// Low-pass with the given −3 dB cutoff.
    Lowpass(f64),
    /// High-pass with the given −3 dB cutoff.
    Highpass(f64),
    /// Band-pass between the two edges (low, high).
    Bandpass(f64, f64),
    /// Band-stop between the two edges (low, high).
    Bandstop(f64, f64),
}

/// A cascade of second-order sections, one row `[b0, b1, b2, a0, a1, a2]` per section
/// (scipy's `sos` layout), with `a0 = 1` for every row.
///
/// Section `s` has the transfer function
/// `H_s(z) = (b0 + b1 z⁻¹ + b2 z⁻²) / (1 + a1 z⁻¹ + a2 z⁻²)`; the filter is the product.
#[derive(Debug, Clone, PartialEq)]
pub struct Sos {
    sections: Vec<[f64; 6]>,
}

impl Sos {
    /// Wrap rows `[b0, b1, b2, a0, a1, a2]`. Every coefficient must be finite and
    /// `a0` must be exactly 1 (as `scipy.signal.sosfilt` requires); at least one row.
    pub fn new(sections: Vec<[f64; 6]>) -> Result<Self, SignalError> {
        if sections.is_empty() {
            return Err(SignalError::EmptySos);
        }
        for (index, row) in sections.iter().enumerate() {
            if row.iter().any(|c| !c.is_finite()) {
                return Err(SignalError::InvalidSection {
                    index,
                    reason: "non-finite coefficient",
                });
            }
            if row[3] != 1.0 {
                return Err(SignalError::InvalidSection {
                    index,
                    reason: "a0 must be 1",
                });
            }
        }
        Ok(Self { sections })
    }

    /// The rows `[b0, b1, b2, a0, a1, a2]`.
    pub fn sections(&self) -> &[[f64; 6]] {
        &self.sections
    }

    /// Number of second-order sections.
    pub fn len(&self) -> usize {
        self.sections.len()
    }

    /// Always `false` (a valid `Sos` has at least one section); provided for clippy.
    pub fn is_empty(&self) -> bool {
        self.sections.is_empty()
    }

    /// Consume into the rows.
    pub fn into_sections(self) -> Vec<[f64; 6]> {
        self.sections
    }
}

/// Design a digital Butterworth filter of order `order` and return it as second-order
/// sections, identical to `scipy.signal.butter(order, Wn, btype, fs=fs, output='sos')`.
///
/// Band-pass and band-stop designs have `2·order` poles (scipy's convention), so
/// `butter(2, Band::Bandpass(10.0, 350.0), fs)` is a 4th-order band-pass in 2 sections.
///
/// # Errors
/// [`SignalError::InvalidOrder`] for `order == 0`, [`SignalError::InvalidSamplingRate`],
/// [`SignalError::CutoffOutOfRange`] unless `0 < f < fs/2` for every edge,
/// [`SignalError::BandEdgesOutOfOrder`] unless `low < high`.
pub fn butter(order: usize, band: Band, fs: f64) -> Result<Sos, SignalError> {
    if order == 0 {
        return Err(SignalError::InvalidOrder { order });
    }
    if !(fs.is_finite() && fs > 0.0) {
        return Err(SignalError::InvalidSamplingRate { fs_hz: fs });
    }
    let nyquist_hz = fs / 2.0;
    let check = |f: f64| {
        if f > 0.0 && f < nyquist_hz {
            Ok(())
        } else {
            Err(SignalError::CutoffOutOfRange {
                cutoff_hz: f,
                nyquist_hz,
            })
        }
    };
    // Normalised frequency Wn = f / (fs/2) ∈ (0, 1); prewarp with scipy's fs = 2:
    // warped = 2·fs·tan(π·Wn/fs) = 4·tan(π·Wn/2).
    let warp = |f: f64| {
        let wn = f / nyquist_hz;
        4.0 * (PI * wn / 2.0).tan()
    };
    let (z, p, k) = buttap(order);
    let (z, p, k) = match band {
        Band::Lowpass(f) => {
            check(f)?;
            lp2lp_zpk(&z, &p, k, warp(f))
        }
        Band::Highpass(f) => {
            check(f)?;
            lp2hp_zpk(&z, &p, k, warp(f))
        }
        Band::Bandpass(lo, hi) | Band::Bandstop(lo, hi) => {
            check(lo)?;
            check(hi)?;
            if lo >= hi {
                return Err(SignalError::BandEdgesOutOfOrder {
                    low_hz: lo,
                    high_hz: hi,
                });
            }
            let (w0, w1) = (warp(lo), warp(hi));
            let bw = w1 - w0;
            let wo = (w0 * w1).sqrt();
            if matches!(band, Band::Bandpass(..)) {
                lp2bp_zpk(&z, &p, k, wo, bw)
            } else {
                lp2bs_zpk(&z, &p, k, wo, bw)
            }
        }
    };
    let (z, p, k) = bilinear_zpk(&z, &p, k, 2.0);
    Ok(Sos {
        sections: zpk2sos_nearest(z, p, k),
    })
}

type Zpk = (Vec<C>, Vec<C>, f64);

/// Analog prototype: poles `p_m = −exp(iπm/(2N))`, `m = −N+1, −N+3, …, N−1`; no zeros; k = 1.
fn buttap(n: usize) -> Zpk {
    let two_n = C::real((2 * n) as f64);
    let p = (0..n)
        .map(|j| {
            let m = -(n as f64) + 1.0 + 2.0 * j as f64;
            // numpy: ((1j·π)·m) / (2N) with complex division, then exp.
            let theta = C::new(0.0, PI).scale(m).div(two_n).im;
            C::new(-theta.cos(), -theta.sin())
        })
        .collect();
    (Vec::new(), p, 1.0)
}

fn relative_degree(z: &[C], p: &[C]) -> usize {
    p.len().saturating_sub(z.len())
}

fn lp2lp_zpk(z: &[C], p: &[C], k: f64, wo: f64) -> Zpk {
    let degree = relative_degree(z, p);
    let z2 = z.iter().map(|&v| v.scale(wo)).collect();
    let p2 = p.iter().map(|&v| v.scale(wo)).collect();
    (z2, p2, k * wo.powf(degree as f64))
}

fn lp2hp_zpk(z: &[C], p: &[C], k: f64, wo: f64) -> Zpk {
    let degree = relative_degree(z, p);
    let w = C::real(wo);
    let mut z2: Vec<C> = z.iter().map(|&v| w.div(v)).collect();
    let p2 = p.iter().map(|&v| w.div(v)).collect();
    z2.extend(std::iter::repeat_n(C::real(0.0), degree));
    let nz: Vec<C> = z.iter().map(|&v| -v).collect();
    let np: Vec<C> = p.iter().map(|&v| -v).collect();
    (z2, p2, k * prod(&nz).div(prod(&np)).re)
}

/// `s → (s² + wo²)/(s·bw)`: each root r gives `r·bw/2 ± sqrt((r·bw/2)² − wo²)`.
fn split_bp(r: &[C], wo: f64) -> Vec<C> {
    let wo2 = C::real(wo * wo);
    let roots: Vec<C> = r.iter().map(|&v| (v * v - wo2).sqrt()).collect();
    let mut out: Vec<C> = r.iter().zip(&roots).map(|(&a, &s)| a + s).collect();
    out.extend(r.iter().zip(&roots).map(|(&a, &s)| a - s));
    out
}

fn lp2bp_zpk(z: &[C], p: &[C], k: f64, wo: f64, bw: f64) -> Zpk {
    let degree = relative_degree(z, p);
    let zl: Vec<C> = z.iter().map(|&v| v.scale(bw).scale(0.5)).collect();
    let pl: Vec<C> = p.iter().map(|&v| v.scale(bw).scale(0.5)).collect();
    let mut z2 = split_bp(&zl, wo);
    let p2 = split_bp(&pl, wo);
    z2.extend(std::iter::repeat_n(C::real(0.0), degree));
    (z2, p2, k * bw.powf(degree as f64))
}

fn lp2bs_zpk(z: &[C], p: &[C], k: f64, wo: f64, bw: f64) -> Zpk {
    let degree = relative_degree(z, p);
    let h = C::real(bw / 2.0);
    let zh: Vec<C> = z.iter().map(|&v| h.div(v)).collect();
    let ph: Vec<C> = p.iter().map(|&v| h.div(v)).collect();
    let mut z2 = split_bp(&zh, wo);
    let p2 = split_bp(&ph, wo);
    z2.extend(std::iter::repeat_n(C::new(0.0, wo), degree));
    z2.extend(std::iter::repeat_n(C::new(0.0, -wo), degree));
    let nz: Vec<C> = z.iter().map(|&v| -v).collect();
    let np: Vec<C> = p.iter().map(|&v| -v).collect();
    (z2, p2, k * prod(&nz).div(prod(&np)).re)
}

/// Bilinear transform `z = (2fs + s)/(2fs − s)`; zeros at infinity map to `z = −1`.
fn bilinear_zpk(z: &[C], p: &[C], k: f64, fs: f64) -> Zpk {
    let degree = relative_degree(z, p);
    let fs2 = C::real(2.0 * fs);
    let mut zz: Vec<C> = z.iter().map(|&v| (fs2 + v).div(fs2 - v)).collect();
    let pz = p.iter().map(|&v| (fs2 + v).div(fs2 - v)).collect();
    zz.extend(std::iter::repeat_n(C::real(-1.0), degree));
    let nz: Vec<C> = z.iter().map(|&v| fs2 - v).collect();
    let np: Vec<C> = p.iter().map(|&v| fs2 - v).collect();
    (zz, pz, k * prod(&nz).div(prod(&np)).re)
}

/// scipy's `_cplxreal`: one representative (positive imaginary part, averaged with the
/// conjugate partner) of each conjugate pair, sorted by real part, followed by the real
/// roots sorted ascending. Returned as one list, complex ones first.
fn cplxreal(z: &[C]) -> Vec<C> {
    let tol = 100.0 * f64::EPSILON;
    let mut zs: Vec<C> = z.to_vec();
    // lexsort((|im|, re)): primary real part, then |im|; stable.
    zs.sort_by(|a, b| {
        a.re.total_cmp(&b.re)
            .then_with(|| a.im.abs().total_cmp(&b.im.abs()))
    });
    let is_real = |v: &C| v.im.abs() <= tol * v.abs();
    let zr: Vec<C> = zs
        .iter()
        .filter(|v| is_real(v))
        .map(|v| C::real(v.re))
        .collect();
    let cplx: Vec<C> = zs.iter().filter(|v| !is_real(v)).copied().collect();
    let mut zp: Vec<C> = cplx.iter().filter(|v| v.im > 0.0).copied().collect();
    let mut zn: Vec<C> = cplx.iter().filter(|v| v.im < 0.0).copied().collect();
    // Runs of (approximately) equal real parts are sorted by |im|.
    let mut start = 0;
    while start < zp.len() {
        let mut stop = start + 1;
        while stop < zp.len() && zp[stop].re - zp[stop - 1].re <= tol * zp[stop - 1].abs() {
            stop += 1;
        }
        if stop - start > 1 {
            zp[start..stop].sort_by(|a, b| a.im.abs().total_cmp(&b.im.abs()));
            if stop <= zn.len() {
                zn[start..stop].sort_by(|a, b| a.im.abs().total_cmp(&b.im.abs()));
            }
        }
        start = stop;
    }
    let mut out: Vec<C> = zp
        .iter()
        .zip(&zn)
        .map(|(&a, &b)| (a + b.conj()).scale(0.5))
        .collect();
    out.extend(zr);
    out
}

/// Index of the root closest to the unit circle (first one on ties, as `argmin`).
fn idx_worst(p: &[C]) -> usize {
    let mut best = 0;
    let mut best_d = f64::INFINITY;
    for (i, v) in p.iter().enumerate() {
        let d = (1.0 - v.abs()).abs();
        if d < best_d {
            best_d = d;
            best = i;
        }
    }
    best
}

#[derive(Clone, Copy)]
enum Which {
    Real,
    Complex,
    Any,
}

/// scipy's `_nearest_real_complex_idx`: nearest element of `fro` to `to` of the given kind.
fn nearest_idx(fro: &[C], to: C, which: Which) -> Option<usize> {
    let mut order: Vec<usize> = (0..fro.len()).collect();
    order.sort_by(|&a, &b| (fro[a] - to).abs().total_cmp(&(fro[b] - to).abs()));
    order.into_iter().find(|&i| match which {
        Which::Any => true,
        Which::Real => fro[i].is_real(),
        Which::Complex => !fro[i].is_real(),
    })
}

/// `np.poly` of at most two roots, real part (conjugate pairs / real roots only).
fn poly2(r: &[C]) -> Vec<f64> {
    match r {
        [] => vec![1.0],
        [a] => vec![1.0, -a.re],
        [a, b] => {
            let (na, nb) = (-*a, -*b);
            vec![1.0, (na + nb).re, (na * nb).re]
        }
        _ => unreachable!("sections have at most two roots"),
    }
}

/// scipy's `_single_zpksos` with k = 1: right-aligned numerator and denominator.
fn single_section(z: &[C], p: &[C]) -> [f64; 6] {
    let mut row = [0.0; 6];
    let b = poly2(z);
    let a = poly2(p);
    row[3 - b.len()..3].copy_from_slice(&b);
    row[6 - a.len()..6].copy_from_slice(&a);
    row
}

/// scipy's `zpk2sos(z, p, k, pairing='nearest')` for a digital system.
fn zpk2sos_nearest(mut z: Vec<C>, mut p: Vec<C>, k: f64) -> Vec<[f64; 6]> {
    if z.len() < p.len() {
        z.resize(p.len(), C::real(0.0));
    }
    if p.len() < z.len() {
        p.resize(z.len(), C::real(0.0));
    }
    let n_sections = p.len().div_ceil(2);
    if p.len() % 2 == 1 {
        p.push(C::real(0.0));
        z.push(C::real(0.0));
    }
    let mut z = cplxreal(&z);
    let mut p = cplxreal(&p);
    let mut sos = vec![[0.0; 6]; n_sections];
    let nearest = |z: &[C], to: C, which: Which| nearest_idx(z, to, which).unwrap_or(0);

    for si in (0..n_sections).rev() {
        let p1 = p.remove(idx_worst(&p));
        let n_real_p = p.iter().filter(|v| v.is_real()).count();
        let n_real_z = z.iter().filter(|v| v.is_real()).count();
        if p1.is_real() && n_real_p == 0 {
            // Special case 1: last remaining real pole, paired with a real zero (and 0s).
            let z1 = z.remove(nearest(&z, p1, Which::Real));
            sos[si] = single_section(&[z1, C::real(0.0)], &[p1, C::real(0.0)]);
        } else if p.len() + 1 == z.len() && !p1.is_real() && n_real_p == 1 && n_real_z == 1 {
            // Special case 2: one real pole and one real zero left; must take a complex zero.
            let z1 = z.remove(nearest(&z, p1, Which::Complex));
            sos[si] = single_section(&[z1, z1.conj()], &[p1, p1.conj()]);
        } else {
            let p2 = if p1.is_real() {
                let real_idx: Vec<usize> = (0..p.len()).filter(|&i| p[i].is_real()).collect();
                let reals: Vec<C> = real_idx.iter().map(|&i| p[i]).collect();
                p.remove(real_idx[idx_worst(&reals)])
            } else {
                p1.conj()
            };
            if z.is_empty() {
                sos[si] = single_section(&[], &[p1, p2]);
            } else {
                let z1 = z.remove(nearest(&z, p1, Which::Any));
                if !z1.is_real() {
                    sos[si] = single_section(&[z1, z1.conj()], &[p1, p2]);
                } else if !z.is_empty() {
                    let z2 = z.remove(nearest(&z, p1, Which::Real));
                    sos[si] = single_section(&[z1, z2], &[p1, p2]);
                } else {
                    sos[si] = single_section(&[z1], &[p1, p2]);
                }
            }
        }
    }
    for c in &mut sos[0][..3] {
        *c *= k;
    }
    sos
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn buttap_poles_on_unit_circle_left_half_plane() {
        let (_, p, k) = buttap(5);
        assert_eq!(k, 1.0);
        assert_eq!(p.len(), 5);
        for v in &p {
            assert!((v.abs() - 1.0).abs() < 1e-15);
            assert!(v.re < 0.0);
        }
        assert_eq!(p[2].im, -0.0);
    }

    #[test]
    fn cplxreal_orders_complex_then_real() {
        let z = [
            C::new(1.0, 0.0),
            C::new(-0.5, -0.3),
            C::new(-2.0, 0.0),
            C::new(-0.5, 0.3),
        ];
        let out = cplxreal(&z);
        assert_eq!(out, vec![C::new(-0.5, 0.3), C::real(-2.0), C::real(1.0)]);
    }
}
