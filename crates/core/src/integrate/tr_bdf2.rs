//! TR-BDF2 (Bank et al. 1985; as an ESDIRK with an embedded pair, Hosea & Shampine 1996): a
//! trapezoidal stage to `t + γh` then a BDF2 stage to `t + h`, `γ = 2 − √2`. Second order,
//! L-stable, stiffly accurate; the embedded solution is third order (not L-stable), so the
//! estimate is that of the second-order step. One explicit and two implicit stages with one
//! diagonal value `γ/2`.

use super::dirk::DirkTableau;

/// `γ/2 = 1 − √2/2`, the diagonal.
const D: f64 = 0.292_893_218_813_452_5;
/// `√2/4`.
const W: f64 = 0.353_553_390_593_273_8;

/// The TR-BDF2 tableau (Hosea & Shampine 1996, Table 1).
pub const TABLEAU: DirkTableau = DirkTableau {
    name: "tr-bdf2",
    order: 2,
    embedded_order: 3,
    a: &[&[0.0], &[D, D], &[W, W, D]],
    b: &[W, W, D],
    // (1 − w)/3, (3w + 1)/3, d/3.
    b_embedded: &[
        0.215_482_203_135_575_42,
        0.686_886_723_926_607_1,
        0.097_631_072_937_817_49,
    ],
};
