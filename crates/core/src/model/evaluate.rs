//! Evaluating a [`Model`]: the potential (split by source), its gradient and its sparse
//! Hessian at a state `q`. Element quantities are computed into the model's preallocated
//! buffers (in parallel chunks when asked) and gathered in a fixed order, so results are
//! bitwise identical for any thread count; every evaluation is counted.

use super::elastic::ElementFailure;
use super::pattern::{gather_matrix, gather_vector};
use super::{FIXED, HessianOptions, Model, ModelError, OffPatternBlock, PotentialParts};
use crate::fem::FilterScope;
use crate::sparse::SymmetricMatrix;
use std::sync::Arc;
use std::sync::atomic::AtomicBool;

impl Model {
    pub(super) fn load_state(&mut self, q: &[f64]) -> Result<(), ModelError> {
        if q.len() != self.num_dofs() {
            return Err(ModelError::StateLength {
                got: q.len(),
                expected: self.num_dofs(),
            });
        }
        self.dofs.scatter(q, &mut self.positions);
        Ok(())
    }

    /// Sum the element vectors in the buffers (tets, springs) into `out` over free DOFs.
    pub(super) fn gather_element_vectors(&self, out: &mut [f64]) {
        let b = &self.buffers;
        let families = [
            (&self.tet_gather, b.tet_vectors.as_slice()),
            (&self.spring_gather, b.spring_vectors.as_slice()),
        ];
        gather_vector(self.parallelism, &families, out);
    }

    /// Sum the element matrices in the buffers (tets, springs) into `values` over the pattern.
    pub(super) fn gather_element_matrices(&self, values: &mut [f64]) {
        let b = &self.buffers;
        let families = [
            (&self.tet_gather, b.tet_matrices.as_slice()),
            (&self.spring_gather, b.spring_matrices.as_slice()),
        ];
        gather_matrix(self.parallelism, &self.pattern, &families, values);
    }

    pub(super) fn element_error(&self, f: ElementFailure) -> ModelError {
        let material = self.material().map_or("material", |m| m.name());
        ModelError::InvertedElement {
            tet: f.tet,
            det_f: f.det_f,
            material,
        }
    }

    /// The potential at `q`, split by source.
    pub fn potential_parts(&mut self, q: &[f64]) -> Result<PotentialParts, ModelError> {
        self.timed_force(|m| m.potential_parts_untimed(q))
    }

    fn potential_parts_untimed(&mut self, q: &[f64]) -> Result<PotentialParts, ModelError> {
        self.load_state(q)?;
        self.counters.potential += 1;
        let x = &self.positions;
        let elastic = match &self.elastic {
            Some(body) => {
                self.buffers.partial.resize(body.num_chunks(), 0.0);
                body.energy(self.parallelism, x, &mut self.buffers.partial)
                    .map_err(|f| self.element_error(f))?
            }
            None => 0.0,
        };
        let springs = self
            .springs
            .iter()
            .map(|s| s.energy(&x[s.i], &x[s.j]))
            .sum();
        let gravity = self.gravity.map_or(0.0, |g| {
            -x.iter()
                .zip(&self.vertex_mass)
                .map(|(p, m)| m * g.dot(p))
                .sum::<f64>()
        });
        let vertex = self
            .vertex_potentials
            .iter()
            .map(|p| p.energy(self.time, x))
            .sum();
        let contact = self
            .contact_potential
            .as_ref()
            .map_or(0.0, |p| p.energy(self.time, x));
        Ok(PotentialParts {
            elastic,
            springs,
            gravity,
            vertex,
            contact,
        })
    }

    /// The total potential at `q` (J).
    pub fn potential(&mut self, q: &[f64]) -> Result<f64, ModelError> {
        Ok(self.potential_parts(q)?.total())
    }

    /// The gradient of the potential at `q`, written to `g` (length [`Self::num_dofs`]).
    pub fn gradient(&mut self, q: &[f64], g: &mut [f64]) -> Result<(), ModelError> {
        self.timed_force(|m| m.gradient_untimed(q, g))
    }

    fn gradient_untimed(&mut self, q: &[f64], g: &mut [f64]) -> Result<(), ModelError> {
        self.load_state(q)?;
        assert_eq!(
            g.len(),
            self.num_dofs(),
            "gradient output has the wrong length"
        );
        self.counters.gradient += 1;
        let par = self.parallelism;
        let b = &mut self.buffers;
        if let Some(body) = &self.elastic {
            b.tet_vectors.resize(12 * body.tets.len(), 0.0);
            let res = body.gradients(par, &self.positions, &mut b.tet_vectors);
            if let Err(f) = res {
                return Err(self.element_error(f));
            }
        }
        b.spring_vectors.resize(6 * self.springs.len(), 0.0);
        for (s, out) in self
            .springs
            .iter()
            .zip(b.spring_vectors.chunks_exact_mut(6))
        {
            s.gradient(&self.positions[s.i], &self.positions[s.j], out);
        }
        self.gather_element_vectors(g);
        self.add_load_gradients(g);
        Ok(())
    }

    /// Add the gradients of gravity, the vertex potentials and the contact potential (at the
    /// loaded positions and the model's time) to `g`.
    pub(super) fn add_load_gradients(&self, g: &mut [f64]) {
        if let Some(gr) = self.gravity {
            for (f, &v) in self.dofs.free_vertices().iter().enumerate() {
                for i in 0..3 {
                    g[3 * f + i] -= self.vertex_mass[v] * gr[i];
                }
            }
        }
        let dofs = &self.dofs;
        let mut add = |v: usize, gv: nalgebra::Vector3<f64>| {
            let f = dofs.free_index(v);
            if f != FIXED {
                let f = f as usize;
                for i in 0..3 {
                    g[3 * f + i] += gv[i];
                }
            }
        };
        for p in &self.vertex_potentials {
            p.gradient(self.time, &self.positions, &mut add);
        }
        if let Some(p) = &self.contact_potential {
            p.gradient(self.time, &self.positions, &mut add);
        }
    }

    /// The Hessian of the potential at `q`, written into `h` (which must be over
    /// [`Self::hessian_pattern`]; see [`Self::new_hessian`]). Contact-potential blocks the
    /// pattern lacks are kept in [`Self::off_pattern_blocks`] instead.
    pub fn hessian(
        &mut self,
        q: &[f64],
        h: &mut SymmetricMatrix,
        options: HessianOptions,
    ) -> Result<(), ModelError> {
        self.load_state(q)?;
        assert!(
            Arc::ptr_eq(h.pattern(), self.pattern.scalar()),
            "the Hessian must be created by Model::new_hessian"
        );
        self.counters.hessian += 1;
        let par = self.parallelism;
        let b = &mut self.buffers;
        let filter = options.filter.as_ref();
        b.filtered = 0;
        if let Some(body) = &self.elastic {
            b.tet_matrices.resize(144 * body.tets.len(), 0.0);
            if b.tet_flags.len() != body.tets.len() {
                b.tet_flags = (0..body.tets.len())
                    .map(|_| AtomicBool::new(false))
                    .collect();
            }
            let res = body.hessians(
                par,
                &self.positions,
                filter,
                &b.tet_flags,
                &mut b.tet_matrices,
            );
            match res {
                Ok(n) => b.filtered += n,
                Err(f) => return Err(self.element_error(f)),
            }
        }
        b.spring_matrices.resize(36 * self.springs.len(), 0.0);
        b.spring_flags.resize(self.springs.len(), false);
        for ((s, out), flag) in self
            .springs
            .iter()
            .zip(b.spring_matrices.chunks_exact_mut(36))
            .zip(b.spring_flags.iter_mut())
        {
            let active = match filter.map(|f| f.scope) {
                Some(FilterScope::Flagged) => *flag,
                _ => true,
            };
            let changed = s.hessian_filtered(
                &self.positions[s.i],
                &self.positions[s.j],
                filter.filter(|_| active),
                out,
            );
            b.filtered += usize::from(changed);
            match filter.map(|f| f.scope) {
                Some(FilterScope::Flagged) if active => *flag = changed,
                Some(FilterScope::EveryFlagging) if changed => *flag = true,
                _ => {}
            }
        }
        self.gather_element_matrices(h.values_mut());
        let values = h.values_mut();
        let (dofs, slots) = (&self.dofs, &self.diagonal_slots);
        for p in &self.vertex_potentials {
            p.hessian(
                self.time,
                &self.positions,
                filter.is_some(),
                &mut |v, block| {
                    let f = dofs.free_index(v);
                    if f != FIXED {
                        for (slot, value) in slots[f as usize].iter().zip(block.iter()) {
                            values[*slot] += value;
                        }
                    }
                },
            );
        }
        self.off_pattern.clear();
        if let Some(p) = &self.contact_potential {
            let (pattern, off) = (&self.pattern, &mut self.off_pattern);
            let col_ptr = pattern.scalar().col_ptr();
            let project = filter.is_some();
            p.hessian(self.time, &self.positions, project, &mut |a, b, block| {
                let (fa, fb) = (dofs.free_index(a), dofs.free_index(b));
                if fa == FIXED || fb == FIXED {
                    return;
                }
                let (row, col) = (fa as usize, fb as usize);
                // Block (row, col), if stored, sits in scalar columns 3col..3col+3 at the same
                // offset within each column (rows 3row..3row+3, contiguous).
                let rows = pattern.scalar().row_idx();
                let first = &rows[col_ptr[3 * col]..col_ptr[3 * col + 1]];
                let start = first.partition_point(|&r| r < 3 * row);
                if first.get(start) == Some(&(3 * row)) {
                    for j in 0..3 {
                        let c = 3 * col + j;
                        for i in 0..3 {
                            values[col_ptr[c] + start + i] += block[(i, j)];
                        }
                    }
                } else {
                    off.push(OffPatternBlock {
                        row: fa,
                        col: fb,
                        block: *block,
                    });
                }
            });
        }
        Ok(())
    }
}
