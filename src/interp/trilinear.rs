//! Trilinear interpolation (Agbegha, Guo and Bai 2011, Section II.A, Eqs. 1–4).
//!
//! Inside a cell the error is the tensor product of linear interpolations along x, y and
//! z through the cell's 8 corners. Outside the grid the end cell's linear functions are
//! continued (linear extrapolation, flagged by [`Interpolator::outside`]), so affine
//! fields are reproduced exactly everywhere. Cost: fit none; evaluation 3 binary searches
//! and 8 multiply–adds.

use super::{Interpolator, Locator, eval_cells, locators};
use crate::table::Grid;

/// Trilinear interpolator over a grid (axes with one node are constant along them).
#[derive(Debug, Clone)]
pub struct Trilinear {
    grid: Grid,
    loc: [Locator; 3],
}

impl Trilinear {
    pub fn new(grid: &Grid) -> Self {
        Self {
            grid: grid.clone(),
            loc: locators(grid),
        }
    }
}

impl Interpolator for Trilinear {
    fn predict(&self, p: [f64; 3]) -> f64 {
        eval_cells(&self.grid, &self.loc, p, |u| [1.0 - u, u])
    }

    fn outside(&self, p: [f64; 3]) -> bool {
        self.grid.outside(p)
    }
}
