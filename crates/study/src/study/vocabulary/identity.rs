//! Run identity: ids safe as file names, values as they appear in ids and tables, and the
//! hashes that decide whether a finished run can be reused.

use crate::study::vocabulary::config::QuickSettings;
use softbench_run::scene::{RunConfig, SceneConfig};
use toml::Value;

/// A value as it appears in run ids and tables: strings bare, numbers short.
pub fn value_text(v: &Value) -> String {
    match v {
        Value::String(s) => s.clone(),
        Value::Float(x) => crate::study::vocabulary::format::short(*x),
        other => other.to_string(),
    }
}

pub(in crate::study) fn float(v: &Value) -> f64 {
    match v {
        Value::Float(x) => *x,
        Value::Integer(i) => *i as f64,
        _ => f64::NAN,
    }
}

/// Keep run ids safe as file names.
pub(in crate::study) fn sanitize(id: &str) -> String {
    id.chars()
        .map(|c| {
            if c.is_ascii_alphanumeric() || "-_.=+".contains(c) {
                c
            } else {
                '_'
            }
        })
        .collect()
}

/// 64-bit FNV-1a, stable across platforms and versions (unlike `DefaultHasher`).
pub fn fnv1a(bytes: &[u8]) -> u64 {
    bytes.iter().fold(0xcbf2_9ce4_8422_2325, |h, b| {
        (h ^ u64::from(*b)).wrapping_mul(0x0000_0100_0000_01b3)
    })
}

/// The hash of a resolved run: its scene, its kind and the kind's settings table, `[quick]`
/// when it applies, and the softbench version.
pub(in crate::study) fn run_hash(
    config: &SceneConfig,
    kind: &str,
    settings: serde_json::Value,
    quick: Option<&QuickSettings>,
) -> String {
    let quick_settings = quick.map_or(serde_json::Value::Null, |q| {
        serde_json::to_value(q).unwrap_or_default()
    });
    let document = serde_json::json!({
        "version": env!("CARGO_PKG_VERSION"),
        "kind": kind,
        "scene": config,
        "settings": settings,
        "quick": quick_settings,
    });
    format!("{:016x}", fnv1a(document.to_string().as_bytes()))
}

pub(in crate::study) fn physics_hash(config: &SceneConfig) -> u64 {
    let mut c = config.clone();
    c.integrator = Default::default();
    c.run = RunConfig {
        dt: 1.0,
        steps: 1,
        sample_every: 1,
        energy_limit: 0.0,
        budget: None,
    };
    c.display = None;
    fnv1a(serde_json::to_string(&c).unwrap_or_default().as_bytes())
}
