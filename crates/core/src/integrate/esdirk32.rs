//! ESDIRK3(2)4L[2]SA (Kennedy & Carpenter 2003, the implicit part of ARK3(2)4L[2]SA): third
//! order with an embedded second-order solution, L-stable, stiffly accurate, stage order 2;
//! one explicit and three implicit stages with diagonal `γ ≈ 0.4359`.

use super::dirk::DirkTableau;

const G: f64 = 1_767_732_205_903.0 / 4_055_673_282_236.0;

/// The ESDIRK3(2)4L[2]SA tableau (Kennedy & Carpenter 2003, Table 3; SUNDIALS ARKODE's
/// `ARKODE_ARK324L2SA_DIRK_4_2_3`).
pub const TABLEAU: DirkTableau = DirkTableau {
    name: "esdirk32",
    order: 3,
    embedded_order: 2,
    a: &[
        &[0.0],
        &[G, G],
        &[
            2_746_238_789_719.0 / 10_658_868_560_708.0,
            -640_167_445_237.0 / 6_845_629_431_997.0,
            G,
        ],
        &[
            1_471_266_399_579.0 / 7_840_856_788_654.0,
            -4_482_444_167_858.0 / 7_529_755_066_697.0,
            11_266_239_266_428.0 / 11_593_286_722_821.0,
            G,
        ],
    ],
    b: &[
        1_471_266_399_579.0 / 7_840_856_788_654.0,
        -4_482_444_167_858.0 / 7_529_755_066_697.0,
        11_266_239_266_428.0 / 11_593_286_722_821.0,
        G,
    ],
    b_embedded: &[
        2_756_255_671_327.0 / 12_835_298_489_170.0,
        -10_771_552_573_575.0 / 22_201_958_757_719.0,
        9_247_589_265_047.0 / 10_645_013_368_117.0,
        2_193_209_047_091.0 / 5_459_859_503_100.0,
    ],
};
