//! The bounded objective trait, a closure adapter, and the affine map between a box and the
//! unit cube, `x = l + u·(h − l)`, `u = (x − l)/(h − l)`, on which the bounded optimisers of
//! this crate (and the annealer of `identify-sa`) take their steps.

use crate::NumericsError;

/// A cost function on a box.
///
/// `cost` returns `None` when the evaluation fails (e.g. a simulation that
/// could not be integrated). A failed evaluation is never turned into NaN: the
/// annealer of `identify-sa` treats it as a rejected move and Nelder–Mead as `+∞`. A returned
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
/// use numerics::{FnObjective, Objective};
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
pub struct UnitBox {
    lower: Vec<f64>,
    width: Vec<f64>,
    /// Scratch buffer holding the last point mapped to the box.
    x: Vec<f64>,
}

impl UnitBox {
    /// Validate the objective's bounds and build the map.
    ///
    /// # Errors
    /// [`NumericsError::EmptyProblem`], [`NumericsError::DimensionMismatch`] when the bounds do
    /// not match `dim()`, [`NumericsError::InvalidBounds`].
    pub fn new<O: Objective + ?Sized>(objective: &O) -> Result<Self, NumericsError> {
        let n = objective.dim();
        if n == 0 {
            return Err(NumericsError::EmptyProblem);
        }
        let bounds = objective.bounds();
        if bounds.len() != n {
            return Err(NumericsError::DimensionMismatch {
                expected: n,
                found: bounds.len(),
            });
        }
        Self::from_bounds(bounds)
    }

    /// Validate `bounds` (finite, lower < upper, at least one) and build the map.
    ///
    /// # Errors
    /// [`NumericsError::EmptyProblem`], [`NumericsError::InvalidBounds`].
    pub fn from_bounds(bounds: &[(f64, f64)]) -> Result<Self, NumericsError> {
        let n = bounds.len();
        if n == 0 {
            return Err(NumericsError::EmptyProblem);
        }
        let mut lower = Vec::with_capacity(n);
        let mut width = Vec::with_capacity(n);
        for (index, &(lo, hi)) in bounds.iter().enumerate() {
            let w = hi - lo;
            if !(lo.is_finite() && hi.is_finite() && w.is_finite() && w > 0.0) {
                return Err(NumericsError::InvalidBounds {
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

    /// Number of coordinates.
    pub fn dim(&self) -> usize {
        self.lower.len()
    }

    /// Lower bounds.
    pub fn lower(&self) -> &[f64] {
        &self.lower
    }

    /// Widths `upper − lower`.
    pub fn width(&self) -> &[f64] {
        &self.width
    }

    /// Convert a point of the box to unit coordinates, checking it lies inside.
    ///
    /// # Errors
    /// [`NumericsError::DimensionMismatch`], [`NumericsError::StartOutOfBounds`].
    pub fn to_unit(&self, x: &[f64], u: &mut [f64]) -> Result<(), NumericsError> {
        if x.len() != self.dim() {
            return Err(NumericsError::DimensionMismatch {
                expected: self.dim(),
                found: x.len(),
            });
        }
        for (i, (&xi, ui)) in x.iter().zip(u.iter_mut()).enumerate() {
            let upper = self.lower[i] + self.width[i];
            if !(xi >= self.lower[i] && xi <= upper) {
                return Err(NumericsError::StartOutOfBounds {
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

    /// Map unit coordinates to the box into a new vector (see [`map_coordinate`]).
    pub fn to_box(&self, u: &[f64]) -> Vec<f64> {
        u.iter()
            .zip(self.lower.iter().zip(&self.width))
            .map(|(&ui, (&lo, &w))| map_coordinate(ui, lo, w))
            .collect()
    }

    /// Evaluate the objective at unit coordinates `u` (no allocation).
    /// Non-finite costs count as failures.
    pub fn eval<O: Objective + ?Sized>(&mut self, objective: &mut O, u: &[f64]) -> Option<f64> {
        for (((xi, &ui), &lo), &w) in self.x.iter_mut().zip(u).zip(&self.lower).zip(&self.width) {
            *xi = map_coordinate(ui, lo, w);
        }
        objective.cost(&self.x).filter(|v| v.is_finite())
    }
}

/// `lo + u·w`, kept inside `[lo, lo + w]` despite rounding.
pub fn map_coordinate(u: f64, lo: f64, w: f64) -> f64 {
    (lo + u * w).clamp(lo, lo + w)
}
