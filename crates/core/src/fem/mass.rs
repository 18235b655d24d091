//! Element masses of a linear tet with density rho.

/// The consistent element mass matrix `rho * volume / 20 * (1 + delta_ab) ⊗ I3`, written
/// block-major into `out[0..144]` (the layout of element Hessians).
pub fn consistent_mass_matrix(density: f64, volume: f64, out: &mut [f64]) {
    let base = density * volume / 20.0;
    out[..144].fill(0.0);
    for a in 0..4 {
        for b in 0..4 {
            let m = if a == b { 2.0 * base } else { base };
            for i in 0..3 {
                out[super::block_offset(4, a, b) + 4 * i] = m;
            }
        }
    }
}

/// The lumped mass each of the four vertices receives: `rho * volume / 4` (the row sums of
/// the consistent matrix).
pub fn lumped_vertex_mass(density: f64, volume: f64) -> f64 {
    density * volume / 4.0
}
