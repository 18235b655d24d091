//! Building a [`Model`] from a [`ModelSpec`], in named steps: validate the parameters,
//! prepare the tets (indices, orientation, rest data), sum the vertex masses, eliminate the
//! fixed vertices, build the Hessian pattern with its gather lists, the mass matrix, the
//! diagonal slots and the energy's round-off scale.

use super::elastic::ElasticBody;
use super::pattern::{ElementGather, gather_matrix};
use super::{
    BlockPattern, Buffers, DofMap, EvalCounters, InvertedTets, MassKind, MassMatrix, Model,
    ModelError, ModelSpec, Spring,
};
use crate::fem::{TetRest, consistent_mass_matrix, lumped_vertex_mass};
use crate::material::MaterialModel;
use crate::mesh::TetMesh;
use crate::parallel::Parallelism;
use crate::sparse::SymmetricMatrix;
use nalgebra::Vector3;

impl Model {
    /// Build a model: validate the input, eliminate fixed vertices, build the Hessian pattern,
    /// the gather lists and the mass matrix.
    pub fn new(spec: ModelSpec) -> Result<Self, ModelError> {
        validate(&spec)?;
        let ModelSpec {
            mut mesh,
            material,
            density,
            mass_kind,
            point_masses,
            springs,
            gravity,
            fixed,
            inverted_tets,
            parallelism,
            damping,
        } = spec;
        let n = mesh.num_vertices();
        let uses_tets = material.is_some() || density.is_some();
        let (tets, rest) = if uses_tets {
            let rest = prepare_tets(&mut mesh, inverted_tets)?;
            (std::mem::take(&mut mesh.tets), rest)
        } else {
            (Vec::new(), Vec::new())
        };
        let vertex_mass = vertex_masses(n, density, &tets, &rest, point_masses.as_deref())?;
        let dofs = DofMap::new(&fixed.resolve(&mesh)?);
        if let Some(v) = dofs
            .free_vertices()
            .iter()
            .copied()
            .find(|&v| vertex_mass[v] <= 0.0)
        {
            return Err(ModelError::MasslessVertex { vertex: v });
        }
        let (pattern, tet_gather, spring_gather) = assembly_pattern(&dofs, &tets, &springs);
        let mass = match mass_kind {
            MassKind::Consistent => {
                let mut m = consistent_mass(density, &rest, &pattern, &tet_gather, parallelism);
                if let Some(pm) = &point_masses {
                    add_point_masses(&mut m, &pattern, &dofs, pm);
                }
                MassMatrix::Consistent(m)
            }
            MassKind::Lumped => lumped_mass(&dofs, &pattern, &vertex_mass),
        };
        // Tets used only for mass take no further part in assembly.
        let tet_gather = if material.is_some() {
            tet_gather
        } else {
            ElementGather::default()
        };
        let diagonal_slots = diagonal_slots(&dofs, &pattern);
        let energy_roundoff_scale = energy_roundoff_scale(material.as_ref(), &rest, &springs);
        let elastic = material.map(|material| ElasticBody {
            material,
            tets,
            rest,
        });
        Ok(Self {
            dofs,
            rest_positions: mesh.positions.clone(),
            positions: mesh.positions,
            elastic,
            springs,
            vertex_potentials: Vec::new(),
            contact_potential: None,
            off_pattern: Vec::new(),
            diagonal_slots,
            time: 0.0,
            damping,
            energy_roundoff_scale,
            velocities: vec![Vector3::zeros(); n],
            stiffness_scratch: None,
            pattern,
            tet_gather,
            spring_gather,
            vertex_mass,
            mass,
            density,
            gravity,
            parallelism,
            counters: EvalCounters::default(),
            force_seconds: 0.0,
            buffers: Buffers::default(),
        })
    }
}

/// Check the spec's parameters (density, gravity, springs, damping) before anything is built.
fn validate(spec: &ModelSpec) -> Result<(), ModelError> {
    let n = spec.mesh.num_vertices();
    if let Some(rho) = spec.density
        && !(rho.is_finite() && rho > 0.0)
    {
        return Err(invalid(
            "material.density",
            rho,
            "a positive density in kg/m^3",
        ));
    }
    if let Some(g) = spec.gravity
        && !g.iter().all(|c| c.is_finite())
    {
        return Err(invalid(
            "forces.gravity",
            format!("{g:?}"),
            "three finite numbers (m/s^2)",
        ));
    }
    let non_negative = |x: f64| x.is_finite() && x >= 0.0;
    for (s, sp) in spec.springs.iter().enumerate() {
        if sp.i >= n || sp.j >= n || sp.i == sp.j {
            return Err(ModelError::InvalidSpring {
                spring: s,
                i: sp.i,
                j: sp.j,
                vertices: n,
            });
        }
        if !non_negative(sp.stiffness) || !non_negative(sp.rest_length) || !non_negative(sp.damping)
        {
            return Err(invalid(
                &format!("springs[{s}]"),
                format!(
                    "stiffness {} rest length {} damping {}",
                    sp.stiffness, sp.rest_length, sp.damping
                ),
                "finite, non-negative stiffness, rest length and damping",
            ));
        }
    }
    let damping = &spec.damping;
    if let Some((alpha, beta)) = damping.rayleigh
        && !(non_negative(alpha) && non_negative(beta))
    {
        return Err(invalid(
            "damping.rayleigh",
            format!("alpha {alpha}, beta {beta}"),
            "alpha >= 0 and beta >= 0",
        ));
    }
    if let Some((phi, psi)) = damping.strain_rate
        && !(non_negative(phi) && non_negative(psi))
    {
        return Err(invalid(
            "damping.strain_rate",
            format!("phi {phi}, psi {psi}"),
            "phi >= 0 and psi >= 0",
        ));
    }
    if damping.strain_rate.is_some() && spec.material.is_none() {
        return Err(invalid(
            "damping.strain_rate",
            "set",
            "a [material] for the tets it acts on",
        ));
    }
    Ok(())
}

/// Lumped vertex masses (also the row sums of the consistent matrix): the tets' share of
/// their mass plus the point masses.
fn vertex_masses(
    n: usize,
    density: Option<f64>,
    tets: &[[usize; 4]],
    rest: &[TetRest],
    point_masses: Option<&[f64]>,
) -> Result<Vec<f64>, ModelError> {
    let mut vertex_mass = vec![0.0; n];
    if let Some(rho) = density {
        for (tet, r) in tets.iter().zip(rest) {
            let m = lumped_vertex_mass(rho, r.volume);
            for &v in tet {
                vertex_mass[v] += m;
            }
        }
    }
    if let Some(pm) = point_masses {
        if pm.len() != n {
            return Err(invalid(
                "point_masses",
                pm.len(),
                &format!("one mass per vertex ({n})"),
            ));
        }
        for (v, &m) in pm.iter().enumerate() {
            if !(m.is_finite() && m >= 0.0) {
                return Err(invalid(
                    &format!("point_masses[{v}]"),
                    m,
                    "a finite, non-negative mass",
                ));
            }
            vertex_mass[v] += m;
        }
    }
    Ok(vertex_mass)
}

/// The Hessian's block pattern over the free vertices and the gather lists of the tets and
/// the springs into it.
fn assembly_pattern(
    dofs: &DofMap,
    tets: &[[usize; 4]],
    springs: &[Spring],
) -> (BlockPattern, ElementGather, ElementGather) {
    let free = |v: usize| dofs.free_index(v);
    let tet_free: Vec<[u32; 4]> = tets.iter().map(|t| t.map(free)).collect();
    let spring_free: Vec<[u32; 2]> = springs.iter().map(|s| [free(s.i), free(s.j)]).collect();
    let all_elements = tet_free
        .iter()
        .map(|t| t.as_slice())
        .chain(spring_free.iter().map(|s| s.as_slice()));
    let pattern = BlockPattern::new(dofs.num_free(), all_elements);
    let tet_gather = ElementGather::new(&pattern, 4, tet_free.iter().map(|t| t.as_slice()));
    let spring_gather = ElementGather::new(&pattern, 2, spring_free.iter().map(|s| s.as_slice()));
    (pattern, tet_gather, spring_gather)
}

/// The consistent mass matrix of the tets over the pattern.
fn consistent_mass(
    density: Option<f64>,
    rest: &[TetRest],
    pattern: &BlockPattern,
    tet_gather: &ElementGather,
    parallelism: Parallelism,
) -> SymmetricMatrix {
    let mut buf = vec![0.0; 144 * rest.len()];
    if let Some(rho) = density {
        for (r, out) in rest.iter().zip(buf.chunks_exact_mut(144)) {
            consistent_mass_matrix(rho, r.volume, out);
        }
    }
    let mut m = SymmetricMatrix::zeros(pattern.scalar().clone());
    gather_matrix(parallelism, pattern, &[(tet_gather, &buf)], m.values_mut());
    m
}

/// Point masses lumped onto the diagonal of a consistent mass matrix.
fn add_point_masses(m: &mut SymmetricMatrix, pattern: &BlockPattern, dofs: &DofMap, pm: &[f64]) {
    for (f, &v) in dofs.free_vertices().iter().enumerate() {
        for i in 0..3 {
            let slot = pattern
                .scalar()
                .find(3 * f + i, 3 * f + i)
                .expect("diagonal");
            m.values_mut()[slot] += pm[v];
        }
    }
}

/// The lumped mass matrix: each free vertex's mass on its three diagonal entries.
fn lumped_mass(dofs: &DofMap, pattern: &BlockPattern, vertex_mass: &[f64]) -> MassMatrix {
    let diagonal = dofs
        .free_vertices()
        .iter()
        .flat_map(|&v| [vertex_mass[v]; 3])
        .collect();
    let diagonal_slots = (0..dofs.num_dofs())
        .map(|i| pattern.scalar().find(i, i).expect("diagonal"))
        .collect();
    MassMatrix::Lumped {
        diagonal,
        diagonal_slots,
    }
}

/// Where each free vertex's 3×3 diagonal block sits in the Hessian values (column-major).
fn diagonal_slots(dofs: &DofMap, pattern: &BlockPattern) -> Vec<[usize; 9]> {
    (0..dofs.num_free())
        .map(|f| {
            std::array::from_fn(|k| {
                let (i, j) = (k % 3, k / 3);
                pattern
                    .scalar()
                    .find(3 * f + i, 3 * f + j)
                    .expect("diagonal blocks are in the pattern")
            })
        })
        .collect()
}

/// Elastic energy is a difference of O(stiffness) terms (e.g. J^(-2/3) I1 - 3) and a
/// spring's is (l - L)^2 with l - L a difference of O(L) numbers: their round-off is set by
/// these magnitudes, not by the (possibly tiny) energy itself.
fn energy_roundoff_scale(
    material: Option<&MaterialModel>,
    rest: &[TetRest],
    springs: &[Spring],
) -> f64 {
    let stiffness_scale = material
        .and_then(|m| {
            m.first_piola_derivative(&nalgebra::Matrix3::identity())
                .ok()
        })
        .map_or(0.0, |d| d.norm());
    stiffness_scale * rest.iter().map(|r| r.volume).sum::<f64>()
        + springs
            .iter()
            .map(|s| s.stiffness * s.rest_length * s.rest_length)
            .sum::<f64>()
}

fn invalid(field: &str, value: impl std::fmt::Display, expected: &str) -> ModelError {
    ModelError::InvalidParameter {
        field: field.into(),
        value: value.to_string(),
        expected: expected.into(),
    }
}

/// Check tet indices and orientation; reorient if asked. Returns the rest data per tet.
fn prepare_tets(mesh: &mut TetMesh, policy: InvertedTets) -> Result<Vec<TetRest>, ModelError> {
    let n = mesh.num_vertices();
    for (t, tet) in mesh.tets.iter().enumerate() {
        if let Some(&v) = tet.iter().find(|&&v| v >= n) {
            return Err(ModelError::TetIndexOutOfRange {
                tet: t,
                vertex: v,
                vertices: n,
            });
        }
    }
    let inverted: Vec<usize> = (0..mesh.num_tets())
        .filter(|&t| mesh.signed_volume6(t) < 0.0)
        .collect();
    if !inverted.is_empty() {
        match policy {
            InvertedTets::Refuse => {
                return Err(ModelError::InvertedTets {
                    count: inverted.len(),
                    first: inverted.iter().copied().take(10).collect(),
                });
            }
            InvertedTets::Reorient => {
                for &t in &inverted {
                    mesh.tets[t].swap(2, 3);
                }
            }
        }
    }
    let mut degenerate = Vec::new();
    let rest: Vec<TetRest> = mesh
        .tets
        .iter()
        .enumerate()
        .filter_map(|(t, tet)| {
            let x = tet.map(|v| mesh.positions[v]);
            TetRest::new(&x).map_err(|_| degenerate.push(t)).ok()
        })
        .collect();
    if !degenerate.is_empty() {
        return Err(ModelError::DegenerateTets {
            count: degenerate.len(),
            first: degenerate.into_iter().take(10).collect(),
        });
    }
    Ok(rest)
}
