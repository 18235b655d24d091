//! ESDIRK4(3)6L[2]SA (Kennedy & Carpenter 2003, the implicit part of ARK4(3)6L[2]SA): fourth
//! order with an embedded third-order solution, L-stable, stiffly accurate, stage order 2;
//! one explicit and five implicit stages with diagonal `γ = 1/4`.

use super::dirk::DirkTableau;

const G: f64 = 0.25;

/// The ESDIRK4(3)6L[2]SA tableau (Kennedy & Carpenter 2003, Table 6; SUNDIALS ARKODE's
/// `ARKODE_ARK436L2SA_DIRK_6_3_4`).
pub const TABLEAU: DirkTableau = DirkTableau {
    name: "esdirk43",
    order: 4,
    embedded_order: 3,
    a: &[
        &[0.0],
        &[G, G],
        &[8_611.0 / 62_500.0, -1_743.0 / 31_250.0, G],
        &[
            5_012_029.0 / 34_652_500.0,
            -654_441.0 / 2_922_500.0,
            174_375.0 / 388_108.0,
            G,
        ],
        &[
            15_267_082_809.0 / 155_376_265_600.0,
            -71_443_401.0 / 120_774_400.0,
            730_878_875.0 / 902_184_768.0,
            2_285_395.0 / 8_070_912.0,
            G,
        ],
        &[
            82_889.0 / 524_892.0,
            0.0,
            15_625.0 / 83_664.0,
            69_875.0 / 102_672.0,
            -2_260.0 / 8_211.0,
            G,
        ],
    ],
    b: &[
        82_889.0 / 524_892.0,
        0.0,
        15_625.0 / 83_664.0,
        69_875.0 / 102_672.0,
        -2_260.0 / 8_211.0,
        G,
    ],
    b_embedded: &[
        4_586_570_599.0 / 29_645_900_160.0,
        0.0,
        178_811_875.0 / 945_068_544.0,
        814_220_225.0 / 1_159_782_912.0,
        -3_700_637.0 / 11_593_932.0,
        61_727.0 / 225_920.0,
    ],
};
