//! The optimisers: a small deterministic L-BFGS with Armijo backtracking (the Gaussian
//! process' hyperparameter fit) and golden-section search on an interval (the
//! diagnosis' nonlinear parameters: a period, a time constant).

use std::collections::VecDeque;

/// Minimises `f` (value and gradient; `None` where undefined) by L-BFGS with Armijo
/// backtracking, from `x0`. Returns the best value and point, or `None` if `f` is
/// undefined at `x0`. Deterministic.
pub fn lbfgs(
    f: &impl Fn(&[f64]) -> Option<(f64, Vec<f64>)>,
    x0: Vec<f64>,
    max_iterations: usize,
) -> Option<(f64, Vec<f64>)> {
    const MEMORY: usize = 8;
    let dot = |a: &[f64], b: &[f64]| a.iter().zip(b).map(|(x, y)| x * y).sum::<f64>();
    let mut x = x0;
    let (mut fx, mut g) = f(&x)?;
    let mut history: VecDeque<(Vec<f64>, Vec<f64>, f64)> = VecDeque::with_capacity(MEMORY);
    for _ in 0..max_iterations {
        // Two-loop recursion: d = −H g.
        let mut q = g.clone();
        let mut alphas = Vec::with_capacity(history.len());
        for (s, y, rho) in history.iter().rev() {
            let a = rho * dot(s, &q);
            for (qi, yi) in q.iter_mut().zip(y) {
                *qi -= a * yi;
            }
            alphas.push(a);
        }
        if let Some((s, y, _)) = history.back() {
            let gamma = dot(s, y) / dot(y, y);
            for qi in &mut q {
                *qi *= gamma;
            }
        } else {
            // First step: at most 1 in any coordinate.
            let gmax = g.iter().fold(0.0, |m: f64, v| m.max(v.abs()));
            if gmax > 1.0 {
                for qi in &mut q {
                    *qi /= gmax;
                }
            }
        }
        for ((s, y, rho), a) in history.iter().zip(alphas.iter().rev()) {
            let b = rho * dot(y, &q);
            for (qi, si) in q.iter_mut().zip(s) {
                *qi += (a - b) * si;
            }
        }
        let mut d: Vec<f64> = q.iter().map(|v| -v).collect();
        let mut slope = dot(&g, &d);
        if slope.is_nan() || slope >= 0.0 {
            history.clear();
            d = g.iter().map(|v| -v).collect();
            slope = dot(&g, &d);
            if slope.is_nan() || slope >= 0.0 {
                break;
            }
        }
        // Armijo backtracking.
        let mut t = 1.0;
        let mut accepted = None;
        for _ in 0..40 {
            let xn: Vec<f64> = x.iter().zip(&d).map(|(xi, di)| xi + t * di).collect();
            if let Some((fnew, gnew)) = f(&xn)
                && fnew <= fx + 1e-4 * t * slope
            {
                accepted = Some((xn, fnew, gnew));
                break;
            }
            t *= 0.5;
        }
        let Some((xn, fnew, gnew)) = accepted else {
            break;
        };
        let s: Vec<f64> = xn.iter().zip(&x).map(|(a, b)| a - b).collect();
        let y: Vec<f64> = gnew.iter().zip(&g).map(|(a, b)| a - b).collect();
        let sy = dot(&s, &y);
        if sy > 1e-12 * dot(&s, &s).sqrt() * dot(&y, &y).sqrt() {
            if history.len() == MEMORY {
                history.pop_front();
            }
            history.push_back((s, y, 1.0 / sy));
        }
        let decrease = fx - fnew;
        x = xn;
        fx = fnew;
        g = gnew;
        let gmax = g.iter().fold(0.0, |m: f64, v| m.max(v.abs()));
        if gmax < 1e-5 || decrease <= 1e-9 * (1.0 + fx.abs()) {
            break;
        }
    }
    Some((fx, x))
}

/// Golden-section minimisation of `f` on [lo, hi].
pub fn golden(mut lo: f64, mut hi: f64, iters: usize, mut f: impl FnMut(f64) -> f64) -> (f64, f64) {
    let g = 0.5 * (5f64.sqrt() - 1.0);
    let mut a = hi - g * (hi - lo);
    let mut b = lo + g * (hi - lo);
    let (mut fa, mut fb) = (f(a), f(b));
    for _ in 0..iters {
        if fa <= fb {
            hi = b;
            b = a;
            fb = fa;
            a = hi - g * (hi - lo);
            fa = f(a);
        } else {
            lo = a;
            a = b;
            fa = fb;
            b = lo + g * (hi - lo);
            fb = f(b);
        }
    }
    if fa <= fb { (a, fa) } else { (b, fb) }
}
