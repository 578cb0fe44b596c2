//! The bounded objective trait, a closure adapter, and the map to the unit box.

use crate::Error;

/// A cost function on a box.
///
/// `cost` returns `None` when the evaluation fails (e.g. a simulation that
/// could not be integrated). A failed evaluation is never turned into NaN: the
/// annealer treats it as a rejected move and Nelder–Mead as `+∞`. A returned
/// `Some(v)` with `v` not finite is treated exactly like `None`.
pub trait Objective {
    /// Number of parameters.
    fn dim(&self) -> usize;
    /// `(lower, upper)` for every parameter; `lower < upper`, both finite.
    fn bounds(&self) -> &[(f64, f64)];
    /// The cost at `x` (`x.len() == dim()`, `x` inside the bounds), or `None` on failure.
    fn cost(&mut self, x: &[f64]) -> Option<f64>;
}

impl<T: Objective + ?Sized> Objective for &mut T {
    fn dim(&self) -> usize {
        (**self).dim()
    }
    fn bounds(&self) -> &[(f64, f64)] {
        (**self).bounds()
    }
    fn cost(&mut self, x: &[f64]) -> Option<f64> {
        (**self).cost(x)
    }
}

/// An [`Objective`] made of bounds and a closure `FnMut(&[f64]) -> Option<f64>`.
///
/// ```
/// use identify_sa::{FnObjective, Objective};
/// let mut sphere = FnObjective::new(vec![(-1.0, 1.0); 2], |x: &[f64]| {
///     Some(x.iter().map(|v| v * v).sum())
/// });
/// assert_eq!(sphere.dim(), 2);
/// assert_eq!(sphere.cost(&[0.5, 0.5]), Some(0.5));
/// ```
#[derive(Debug, Clone)]
pub struct FnObjective<F> {
    bounds: Vec<(f64, f64)>,
    f: F,
}

impl<F: FnMut(&[f64]) -> Option<f64>> FnObjective<F> {
    /// Wrap `f` with the box `bounds` (validated when an optimiser starts).
    pub fn new(bounds: Vec<(f64, f64)>, f: F) -> Self {
        Self { bounds, f }
    }
}

impl<F: FnMut(&[f64]) -> Option<f64>> Objective for FnObjective<F> {
    fn dim(&self) -> usize {
        self.bounds.len()
    }
    fn bounds(&self) -> &[(f64, f64)] {
        &self.bounds
    }
    fn cost(&mut self, x: &[f64]) -> Option<f64> {
        (self.f)(x)
    }
}

/// The affine map between the box and the unit cube, `x = lower + u·(upper − lower)`.
#[derive(Debug, Clone, PartialEq)]
pub(crate) struct UnitBox {
    lower: Vec<f64>,
    width: Vec<f64>,
    /// Scratch buffer holding the last point mapped to the box.
    x: Vec<f64>,
}

impl UnitBox {
    /// Validate the objective's bounds and build the map.
    pub(crate) fn new<O: Objective + ?Sized>(objective: &O) -> Result<Self, Error> {
        let n = objective.dim();
        if n == 0 {
            return Err(Error::EmptyProblem);
        }
        let bounds = objective.bounds();
        if bounds.len() != n {
            return Err(Error::DimensionMismatch {
                expected: n,
                found: bounds.len(),
            });
        }
        let mut lower = Vec::with_capacity(n);
        let mut width = Vec::with_capacity(n);
        for (index, &(lo, hi)) in bounds.iter().enumerate() {
            let w = hi - lo;
            if !(lo.is_finite() && hi.is_finite() && w.is_finite() && w > 0.0) {
                return Err(Error::InvalidBounds {
                    index,
                    lower: lo,
                    upper: hi,
                });
            }
            lower.push(lo);
            width.push(w);
        }
        Ok(Self {
            lower,
            width,
            x: vec![0.0; n],
        })
    }

    pub(crate) fn dim(&self) -> usize {
        self.lower.len()
    }

    /// Convert a point of the box to unit coordinates, checking it lies inside.
    pub(crate) fn to_unit(&self, x: &[f64], u: &mut [f64]) -> Result<(), Error> {
        if x.len() != self.dim() {
            return Err(Error::DimensionMismatch {
                expected: self.dim(),
                found: x.len(),
            });
        }
        for (i, (&xi, ui)) in x.iter().zip(u.iter_mut()).enumerate() {
            let upper = self.lower[i] + self.width[i];
            if !(xi >= self.lower[i] && xi <= upper) {
                return Err(Error::StartOutOfBounds {
                    index: i,
                    value: xi,
                    lower: self.lower[i],
                    upper,
                });
            }
            *ui = ((xi - self.lower[i]) / self.width[i]).clamp(0.0, 1.0);
        }
        Ok(())
    }

    /// Map unit coordinates to the box into a new vector.
    pub(crate) fn to_box(&self, u: &[f64]) -> Vec<f64> {
        u.iter()
            .zip(self.lower.iter().zip(&self.width))
            .map(|(&ui, (&lo, &w))| map_coordinate(ui, lo, w))
            .collect()
    }

    /// Evaluate the objective at unit coordinates `u` (no allocation).
    /// Non-finite costs count as failures.
    pub(crate) fn eval<O: Objective + ?Sized>(
        &mut self,
        objective: &mut O,
        u: &[f64],
    ) -> Option<f64> {
        for (((xi, &ui), &lo), &w) in self.x.iter_mut().zip(u).zip(&self.lower).zip(&self.width) {
            *xi = map_coordinate(ui, lo, w);
        }
        objective.cost(&self.x).filter(|v| v.is_finite())
    }
}

/// `lo + u·w`, kept inside `[lo, lo + w]` despite rounding.
fn map_coordinate(u: f64, lo: f64, w: f64) -> f64 {
    (lo + u * w).clamp(lo, lo + w)
}

/// Fold any real `y` into `[0, 1]` by reflection at both walls (period 2).
///
/// This is how the annealer keeps moves inside the box: a proposal that
/// overshoots a bound by `d` lands `d` inside it, so the proposal density
/// stays symmetric and no probability mass piles up on the bounds.
///
/// ```
/// use identify_sa::reflect_into_unit;
/// assert_eq!(reflect_into_unit(0.25), 0.25);
/// assert!((reflect_into_unit(1.25) - 0.75).abs() < 1e-15);
/// assert!((reflect_into_unit(-0.25) - 0.25).abs() < 1e-15);
/// assert!((reflect_into_unit(2.5) - 0.5).abs() < 1e-15);
/// ```
pub fn reflect_into_unit(y: f64) -> f64 {
    if !y.is_finite() {
        return 0.5;
    }
    let m = y.rem_euclid(2.0);
    let r = if m > 1.0 { 2.0 - m } else { m };
    r.clamp(0.0, 1.0)
}
