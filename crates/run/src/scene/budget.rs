//! Size and magnitude checks of a scene, made at validation — before any mesh is generated or
//! read, any model allocated or any file written — so an absurd number is an error that names
//! the key, the number and the limit (see [`softbench_core::limits`] for the budgets and how to raise
//! them) instead of an abort, a wrapped count or a frozen run.

use super::config::SceneConfig;
use super::springs::JelloShape;
use softbench_core::limits::{self, OverBudget};

/// A check that failed: the key and the message.
pub(super) struct Problem {
    pub key: &'static str,
    pub message: String,
}

fn over(key: &'static str) -> impl Fn(OverBudget) -> Problem {
    move |e| Problem {
        key,
        message: e.to_string(),
    }
}

/// Largest |coordinate| (m) and largest size of a generated body: beyond this, volumes and
/// energies (cubes and squares of lengths) overflow f64.
pub const MAX_LENGTH: f64 = 1e50;
/// Largest density (kg/m^3): osmium is 2.3e4; 1e9 leaves room for scaled test problems.
pub const MAX_DENSITY: f64 = 1e9;
/// Largest gravitational acceleration (m/s^2): 1e6 g.
pub const MAX_GRAVITY: f64 = 1e7;

/// Checks the scene's counts (steps, rows, generated mesh and jello sizes) against the
/// budgets, and its lengths, density and gravity against physical sanity bounds.
pub(super) fn check(c: &SceneConfig) -> Result<(), Problem> {
    let r = &c.run;
    limits::STEPS
        .check_usize(Some(r.steps))
        .map_err(over("run.steps"))?;
    let i = &c.integrator;
    let iterations: [(&'static str, Option<u64>); 7] = [
        (
            "integrator.newton.max_iterations",
            Some(i.newton.max_iterations.into()),
        ),
        ("integrator.vbd.iterations", Some(i.vbd.iterations.into())),
        (
            "integrator.projective_dynamics.iterations",
            Some(i.projective_dynamics.iterations.into()),
        ),
        (
            "integrator.xpbd.substeps",
            u64::from(i.xpbd.substeps).checked_mul(i.xpbd.iterations.into()),
        ),
        (
            "integrator.adaptive.max_substeps",
            Some(i.adaptive.max_substeps),
        ),
        (
            "integrator.static.max_load_steps",
            Some(i.static_solve.max_load_steps.into()),
        ),
        (
            "integrator.solver.cg.max_iterations",
            u64::try_from(i.solver.cg.max_iterations).ok(),
        ),
    ];
    for (key, count) in iterations {
        limits::ITERATIONS.check(count).map_err(over(key))?;
    }
    if !(r.dt * r.steps as f64).is_finite() {
        return Err(Problem {
            key: "run.dt",
            message: format!(
                "run.dt = {:e} s times run.steps = {} overflows the time: give a time step \
                 whose horizon is a finite number",
                r.dt, r.steps
            ),
        });
    }
    limits::ROWS
        .check_usize(Some(r.steps / r.sample_every.max(1) + 2))
        .map_err(over("run.sample_every"))?;
    if let Some(g) = c.mesh.as_ref().and_then(|m| m.generate.as_ref()) {
        if let Some([nx, ny, nz]) = g.box_cells {
            let vertices = limits::product(&[
                nx.saturating_add(1),
                ny.saturating_add(1),
                nz.saturating_add(1),
            ]);
            let tets = limits::product(&[6, nx, ny, nz]);
            let total = vertices.zip(tets).and_then(|(v, t)| v.checked_add(t));
            limits::MESH
                .check_usize(total)
                .map_err(over("mesh.generate.box"))?;
        }
        if let Some(n) = g.ball {
            let side = n.checked_mul(2).and_then(|s| s.checked_add(1));
            let vertices = side.and_then(|s| limits::product(&[s, s, s]));
            let tets = limits::product(&[48, n, n, n]);
            let total = vertices.zip(tets).and_then(|(v, t)| v.checked_add(t));
            limits::MESH
                .check_usize(total)
                .map_err(over("mesh.generate.ball"))?;
        }
        let lengths = g
            .size
            .iter()
            .flatten()
            .chain(&g.radius)
            .chain(g.origin.iter().flatten());
        check_lengths("mesh.generate", lengths)?;
    }
    if let Some(j) = &c.jello {
        // Particles, plus springs (at most 13 per particle for a cube, 3 + antipodal for a
        // sphere) and the display lattice's tets (6 per cell).
        let (key, particles) = match j.shape {
            JelloShape::Cube => ("jello.n", j.n.and_then(|n| limits::product(&[n, n, n]))),
            JelloShape::Sphere => (
                "jello.segments",
                j.rings
                    .zip(j.segments)
                    .and_then(|(r, s)| limits::product(&[r, s])?.checked_add(2)),
            ),
        };
        let total = particles.and_then(|p| p.checked_mul(20));
        limits::MESH.check_usize(total).map_err(|e| Problem {
            key,
            message: format!(
                "{} particles, about 20 entries each with springs and display tets: {e}",
                particles.map_or("more than 2^64".into(), |p| p.to_string())
            ),
        })?;
        let lengths = j
            .size
            .iter()
            .chain(&j.radius)
            .chain(j.origin.iter().flatten())
            .chain(j.center.iter().flatten());
        check_lengths("jello", lengths)?;
    }
    for d in &c.drag {
        let lengths = d
            .point
            .iter()
            .chain([&d.radius])
            .chain(d.path.iter().flat_map(|w| w.offset.iter()));
        check_lengths("drag", lengths)?;
    }
    if let Some(m) = &c.material
        && !(m.density.is_finite() && m.density > 0.0 && m.density <= MAX_DENSITY)
    {
        return Err(Problem {
            key: "material.density",
            message: format!(
                "must be in (0, {MAX_DENSITY:e}] kg/m^3 (got {:e}); larger values make the \
                 model's energies overflow",
                m.density
            ),
        });
    }
    if let Some(g) = c
        .forces
        .gravity
        .iter()
        .find(|g| g.is_nan() || g.abs() > MAX_GRAVITY)
    {
        return Err(Problem {
            key: "forces.gravity",
            message: format!(
                "component {g:e} m/s^2 is beyond ±{MAX_GRAVITY:e} m/s^2 (Earth's gravity is \
                 9.81); larger values make the model's energies overflow"
            ),
        });
    }
    if let Some(b) = &c.fixed.fixed_box
        && b.min.iter().chain(&b.max).any(|x| x.is_nan())
    {
        return Err(Problem {
            key: "fixed.box",
            message: "min and max must be numbers (NaN selects nothing)".into(),
        });
    }
    Ok(())
}

fn check_lengths<'a>(
    key: &'static str,
    mut lengths: impl Iterator<Item = &'a f64>,
) -> Result<(), Problem> {
    match lengths.find(|x| x.is_nan() || x.abs() > MAX_LENGTH) {
        Some(x) => Err(Problem {
            key,
            message: format!("lengths must be within ±{MAX_LENGTH:e} m (got {x:e})"),
        }),
        None => Ok(()),
    }
}
