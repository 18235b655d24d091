//! Limited-memory BFGS memory and the two-loop recursion (Nocedal & Wright, Algorithm 7.4):
//! `dx = -H_k g` from the last `m` pairs `s = x_(k+1) - x_k`, `y = g_(k+1) - g_k`, over an
//! initial inverse Hessian the caller applies ([`super::settings::LbfgsInitial`]). Buffers are
//! a ring of `m` pairs allocated once per size; a pair with `s·y <= 0` (no positive
//! curvature) is skipped and counted, so the recursion stays positive definite.

/// The last `m` curvature pairs of one solve.
#[derive(Default)]
pub struct Lbfgs {
    s: Vec<Vec<f64>>,
    y: Vec<Vec<f64>>,
    rho: Vec<f64>,
    alpha: Vec<f64>,
    /// Pairs held, and the slot of the newest.
    len: usize,
    newest: usize,
    /// Pairs skipped for lack of positive curvature (over the memory's life).
    pub skipped: u64,
}

impl Lbfgs {
    /// Room for `m` pairs of size `n`; empties the memory.
    pub fn reset(&mut self, m: usize, n: usize) {
        if self.s.len() != m || self.s.first().is_some_and(|v| v.len() != n) {
            self.s = vec![vec![0.0; n]; m];
            self.y = vec![vec![0.0; n]; m];
            self.rho = vec![0.0; m];
            self.alpha = vec![0.0; m];
        }
        self.len = 0;
        self.newest = 0;
    }

    /// Forget the pairs (a direction that did not descend).
    pub fn clear(&mut self) {
        self.len = 0;
    }

    /// Pairs held.
    pub fn len(&self) -> usize {
        self.len
    }

    /// Whether no pair is held.
    pub fn is_empty(&self) -> bool {
        self.len == 0
    }

    /// Add the pair `s = x_new - x_old`, `y = g_new - g_old` unless `s·y` is not positive
    /// (relative to `‖s‖ ‖y‖`).
    pub fn push(&mut self, x_new: &[f64], x_old: &[f64], g_new: &[f64], g_old: &[f64]) {
        let m = self.s.len();
        if m == 0 {
            return;
        }
        let (mut sy, mut ss, mut yy) = (0.0, 0.0, 0.0);
        for i in 0..x_new.len() {
            let (si, yi) = (x_new[i] - x_old[i], g_new[i] - g_old[i]);
            sy += si * yi;
            ss += si * si;
            yy += yi * yi;
        }
        if sy.is_nan() || sy <= 1e-12 * (ss * yy).sqrt() {
            self.skipped += 1;
            return;
        }
        let slot = if self.len == 0 {
            0
        } else {
            (self.newest + 1) % m
        };
        for (i, (s, y)) in self.s[slot].iter_mut().zip(&mut self.y[slot]).enumerate() {
            *s = x_new[i] - x_old[i];
            *y = g_new[i] - g_old[i];
        }
        self.rho[slot] = 1.0 / sy;
        self.newest = slot;
        self.len = (self.len + 1).min(m);
    }

    /// Shanno's scaling `s·y / y·y` of the newest pair (None without pairs).
    pub fn shanno_scale(&self) -> Option<f64> {
        if self.len == 0 {
            return None;
        }
        let y = &self.y[self.newest];
        let yy: f64 = y.iter().map(|v| v * v).sum();
        Some(1.0 / (self.rho[self.newest] * yy))
    }

    /// The two-loop recursion on `q` (in: `-g`; out: the direction), `initial` applying the
    /// initial inverse Hessian in place between the loops.
    pub fn apply<E>(
        &mut self,
        q: &mut [f64],
        initial: &mut dyn FnMut(&mut [f64]) -> Result<(), E>,
    ) -> Result<(), E> {
        let m = self.s.len();
        // Newest to oldest.
        for j in 0..self.len {
            let k = (self.newest + m - j) % m;
            let a = self.rho[k] * dot(&self.s[k], q);
            self.alpha[k] = a;
            q.iter_mut()
                .zip(&self.y[k])
                .for_each(|(qi, y)| *qi -= a * y);
        }
        initial(q)?;
        // Oldest to newest.
        for j in (0..self.len).rev() {
            let k = (self.newest + m - j) % m;
            let b = self.rho[k] * dot(&self.y[k], q);
            let a = self.alpha[k];
            q.iter_mut()
                .zip(&self.s[k])
                .for_each(|(qi, s)| *qi += (a - b) * s);
        }
        Ok(())
    }
}

fn dot(a: &[f64], b: &[f64]) -> f64 {
    a.iter().zip(b).map(|(x, y)| x * y).sum()
}

#[cfg(test)]
mod tests {
    use super::*;

    /// On a quadratic with a diagonal Hessian, n exact pairs make the recursion the inverse.
    #[test]
    fn exact_pairs_of_a_quadratic_give_its_inverse_hessian() {
        let h = [2.0, 5.0, 0.5];
        let mut memory = Lbfgs::default();
        memory.reset(3, 3);
        let zero = [0.0; 3];
        for i in 0..3 {
            let mut x = [0.0; 3];
            x[i] = 1.0 + i as f64;
            let g: Vec<f64> = x.iter().zip(&h).map(|(x, h)| x * h).collect();
            memory.push(&x, &zero, &g, &zero);
        }
        assert_eq!(memory.len(), 3);
        let mut q = [1.0, 1.0, 1.0];
        memory
            .apply(&mut q, &mut |v: &mut [f64]| {
                v.iter_mut().for_each(|x| *x *= 0.3);
                Ok::<(), ()>(())
            })
            .unwrap();
        for (qi, hi) in q.iter().zip(&h) {
            assert!((qi - 1.0 / hi).abs() < 1e-12, "{q:?}");
        }
    }

    #[test]
    fn a_pair_without_positive_curvature_is_skipped() {
        let mut memory = Lbfgs::default();
        memory.reset(2, 2);
        memory.push(&[1.0, 0.0], &[0.0, 0.0], &[-1.0, 0.0], &[0.0, 0.0]);
        assert!(memory.is_empty());
        assert_eq!(memory.skipped, 1);
    }
}
