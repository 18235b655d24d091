//! The elastic potential of a tet mesh: element loops over linear tets, generic over the
//! material so the per-element code has no dynamic dispatch.

use crate::fem::{
    ElementFilter, FilterScope, FilterSpace, ProjectToPsd, TetRest, pack_matrix12, unpack_matrix12,
};
use crate::material::{Material, MaterialModel, with_material};
use crate::parallel::{Parallelism, for_each_chunk_from};
use nalgebra::Vector3;
use std::sync::atomic::{AtomicBool, AtomicUsize, Ordering};

/// Elements per parallel task (and per partial energy sum, so sums never depend on threads).
pub(crate) const CHUNK: usize = 256;

/// Chunks from which each element loop runs on threads, from `cargo bench --bench
/// thread_crossover -- elements` on a quiet two-core machine, called from outside rayon's pool
/// (waking the pool costs ~20 µs; a step past these rules enters the pool once and calls them
/// from a pool thread, see `Model::element_loops_split`): the energy loop (~20 ns per tet) paid
/// from 2048–4096 tets (1.19–1.34x at 4096 in three runs, 0.4–0.8x at 512–1024), the gradient
/// loop (~25 ns per tet) from 4096–16384 (0.96–1.44x at 4096–8192, 1.12–1.23x at 16384); the
/// Hessian loop (~80 ns per tet) from 1024 tets (1.08–1.38x).
pub(crate) const ENERGY_MIN_CHUNKS: usize = 16;
/// See [`ENERGY_MIN_CHUNKS`].
pub(crate) const GRADIENT_MIN_CHUNKS: usize = 64;
/// See [`ENERGY_MIN_CHUNKS`].
pub(crate) const HESSIAN_MIN_CHUNKS: usize = 4;

/// An element whose energy is undefined at the current positions.
#[derive(Clone, Copy, Debug, PartialEq)]
pub(crate) struct ElementFailure {
    pub tet: usize,
    pub det_f: f64,
}

/// Tets with their rest data and one material.
#[derive(Clone, Debug)]
pub(crate) struct ElasticBody {
    pub material: MaterialModel,
    pub tets: Vec<[usize; 4]>,
    pub rest: Vec<TetRest>,
}

#[inline]
fn element_positions(tet: &[usize; 4], x: &[Vector3<f64>]) -> [Vector3<f64>; 4] {
    [x[tet[0]], x[tet[1]], x[tet[2]], x[tet[3]]]
}

impl ElasticBody {
    /// Number of partial sums the energy needs.
    pub fn num_chunks(&self) -> usize {
        self.tets.len().div_ceil(CHUNK)
    }

    /// Elastic energy; `partial` holds [`Self::num_chunks`] scratch values.
    pub fn energy(
        &self,
        par: Parallelism,
        x: &[Vector3<f64>],
        partial: &mut [f64],
    ) -> Result<f64, ElementFailure> {
        with_material!(&self.material, |m| energy(m, self, par, x, partial))
    }

    /// Element gradients into `buf` (12 per tet).
    pub fn gradients(
        &self,
        par: Parallelism,
        x: &[Vector3<f64>],
        buf: &mut [f64],
    ) -> Result<(), ElementFailure> {
        with_material!(&self.material, |m| gradients(m, self, par, x, buf))
    }

    /// Element Hessians into `buf` (144 per tet, block-major), through `filter` if given
    /// (see [`crate::fem::ElementFilter`]); `flags` (one per tet) is the on-demand filter's
    /// memory, read and written only by a filter of that scope. Returns how many element
    /// matrices the filter changed.
    pub fn hessians(
        &self,
        par: Parallelism,
        x: &[Vector3<f64>],
        filter: Option<&ElementFilter>,
        flags: &[AtomicBool],
        buf: &mut [f64],
    ) -> Result<usize, ElementFailure> {
        with_material!(&self.material, |m| hessians(
            m, self, par, x, filter, flags, buf
        ))
    }
}

fn energy<M: Material>(
    m: &M,
    body: &ElasticBody,
    par: Parallelism,
    x: &[Vector3<f64>],
    partial: &mut [f64],
) -> Result<f64, ElementFailure> {
    let n = body.tets.len();
    for_each_chunk_from(par, partial, 1, ENERGY_MIN_CHUNKS, |ci, out| {
        let mut sum = 0.0;
        for e in ci * CHUNK..((ci + 1) * CHUNK).min(n) {
            let rest = &body.rest[e];
            let f = rest.deformation_gradient(&element_positions(&body.tets[e], x));
            let psi = m.energy_density(&f).map_err(|err| ElementFailure {
                tet: e,
                det_f: err.det_f,
            })?;
            sum += rest.volume * psi;
        }
        out[0] = sum;
        Ok(())
    })?;
    Ok(partial.iter().sum())
}

fn gradients<M: Material>(
    m: &M,
    body: &ElasticBody,
    par: Parallelism,
    x: &[Vector3<f64>],
    buf: &mut [f64],
) -> Result<(), ElementFailure> {
    for_each_chunk_from(par, buf, 12 * CHUNK, GRADIENT_MIN_CHUNKS, |ci, out| {
        for (k, g) in out.chunks_exact_mut(12).enumerate() {
            let e = ci * CHUNK + k;
            let rest = &body.rest[e];
            let f = rest.deformation_gradient(&element_positions(&body.tets[e], x));
            let p = m.first_piola(&f).map_err(|err| ElementFailure {
                tet: e,
                det_f: err.det_f,
            })?;
            rest.gradient_from_stress(&p, g);
        }
        Ok(())
    })
}

fn hessians<M: Material>(
    m: &M,
    body: &ElasticBody,
    par: Parallelism,
    x: &[Vector3<f64>],
    filter: Option<&ElementFilter>,
    flags: &[AtomicBool],
    buf: &mut [f64],
) -> Result<usize, ElementFailure> {
    let filtered = AtomicUsize::new(0);
    for_each_chunk_from(par, buf, 144 * CHUNK, HESSIAN_MIN_CHUNKS, |ci, out| {
        let mut count = 0;
        for (k, h) in out.chunks_exact_mut(144).enumerate() {
            let e = ci * CHUNK + k;
            let rest = &body.rest[e];
            let f = rest.deformation_gradient(&element_positions(&body.tets[e], x));
            let mut d = m.first_piola_derivative(&f).map_err(|err| ElementFailure {
                tet: e,
                det_f: err.det_f,
            })?;
            let Some(filter) = filter else {
                rest.hessian_from_stress_derivative(&d, h);
                continue;
            };
            let active = match filter.scope {
                FilterScope::Flagged => flags[e].load(Ordering::Relaxed),
                FilterScope::Every | FilterScope::EveryFlagging => true,
            };
            if active && filter.space == FilterSpace::Stress {
                let changed = match m.stress_eigensystem(&f) {
                    Some((values, vectors)) => filter.apply_eigensystem(&values, &vectors, &mut d),
                    None => filter.apply(&mut d),
                };
                rest.hessian_from_stress_derivative(&d, h);
                count += usize::from(changed);
                remember(filter, &flags[e], changed);
            } else {
                rest.hessian_from_stress_derivative(&d, h);
                if active {
                    let mut mat = unpack_matrix12(h);
                    let changed = filter.apply(&mut mat);
                    if changed {
                        pack_matrix12(&mat, h);
                    }
                    count += usize::from(changed);
                    remember(filter, &flags[e], changed);
                }
            }
        }
        filtered.fetch_add(count, Ordering::Relaxed);
        Ok(())
    })?;
    Ok(filtered.into_inner())
}

/// The on-demand memory after filtering one element (see [`FilterScope`]).
#[inline]
fn remember(filter: &ElementFilter, flag: &AtomicBool, changed: bool) {
    match filter.scope {
        FilterScope::Every => {}
        FilterScope::Flagged => {
            if !changed {
                flag.store(false, Ordering::Relaxed);
            }
        }
        FilterScope::EveryFlagging => {
            if changed {
                flag.store(true, Ordering::Relaxed);
            }
        }
    }
}

impl ElasticBody {
    /// Viscous element forces `volume * F S_v * grad N_a` (strain-rate damping with `phi`,
    /// `psi`) for vertex velocities `v`, into `buf` (12 per tet). Never fails: the viscous
    /// stress is defined for every F.
    pub fn viscous_forces(
        &self,
        par: Parallelism,
        (phi, psi): (f64, f64),
        x: &[Vector3<f64>],
        v: &[Vector3<f64>],
        buf: &mut [f64],
    ) {
        let ok: Result<(), ElementFailure> =
            for_each_chunk_from(par, buf, 12 * CHUNK, GRADIENT_MIN_CHUNKS, |ci, out| {
                for (k, g) in out.chunks_exact_mut(12).enumerate() {
                    let e = ci * CHUNK + k;
                    let rest = &self.rest[e];
                    let f = rest.deformation_gradient(&element_positions(&self.tets[e], x));
                    let fdot = rest.deformation_gradient(&element_positions(&self.tets[e], v));
                    rest.gradient_from_stress(
                        &super::damping::viscous_stress(phi, psi, &f, &fdot),
                        g,
                    );
                }
                Ok(())
            });
        ok.expect("viscous forces cannot fail");
    }

    /// Element damping matrices `beta * H_e(projected) + V_e` into `buf` (144 per tet,
    /// block-major): the Rayleigh stiffness part and the strain-rate viscous part.
    pub fn damping_matrices(
        &self,
        par: Parallelism,
        x: &[Vector3<f64>],
        beta: f64,
        viscous: Option<(f64, f64)>,
        buf: &mut [f64],
    ) -> Result<(), ElementFailure> {
        with_material!(&self.material, |m| damping_matrices(
            m, self, par, x, beta, viscous, buf
        ))
    }
}

fn damping_matrices<M: Material>(
    m: &M,
    body: &ElasticBody,
    par: Parallelism,
    x: &[Vector3<f64>],
    beta: f64,
    viscous: Option<(f64, f64)>,
    buf: &mut [f64],
) -> Result<(), ElementFailure> {
    for_each_chunk_from(par, buf, 144 * CHUNK, HESSIAN_MIN_CHUNKS, |ci, out| {
        let mut viscous_block = [0.0; 144];
        for (k, h) in out.chunks_exact_mut(144).enumerate() {
            let e = ci * CHUNK + k;
            let rest = &body.rest[e];
            let f = rest.deformation_gradient(&element_positions(&body.tets[e], x));
            if beta != 0.0 {
                let d = m.first_piola_derivative(&f).map_err(|err| ElementFailure {
                    tet: e,
                    det_f: err.det_f,
                })?;
                rest.hessian_from_stress_derivative(&d, h);
                let mut mat = unpack_matrix12(h);
                mat.project_to_psd();
                pack_matrix12(&(mat * beta), h);
            } else {
                h.fill(0.0);
            }
            if let Some((phi, psi)) = viscous {
                let dv = super::damping::viscous_stress_derivative(phi, psi, &f);
                rest.hessian_from_stress_derivative(&dv, &mut viscous_block);
                h.iter_mut().zip(&viscous_block).for_each(|(a, b)| *a += b);
            }
        }
        Ok(())
    })
}
