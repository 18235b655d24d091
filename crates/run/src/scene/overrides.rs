//! `--set key=value` overrides with dotted paths into the TOML tree
//! (`--set integrator.method=rk4 --set run.dt=1e-3`).

use toml::{Table, Value};

/// A malformed override.
#[derive(Clone, Debug, PartialEq, Eq, thiserror::Error)]
pub enum OverrideError {
    #[error("--set {0}: expected key=value with a dotted key, e.g. run.dt=1e-3")]
    Syntax(String),
    #[error("--set {key}: `{prefix}` is a value, not a table")]
    NotATable { key: String, prefix: String },
}

impl softbench_core::error_class::Classify for OverrideError {
    fn class(&self) -> softbench_core::error_class::ErrorClass {
        softbench_core::error_class::ErrorClass::BadInput
    }
}

/// Parse a value as TOML (number, bool, array, inline table, quoted string); anything else is
/// taken as a bare string, so `integrator.method=rk4` needs no quotes.
fn parse_value(text: &str) -> Value {
    let doc = format!("v = {text}");
    match toml::from_str::<Table>(&doc) {
        Ok(mut t) => t
            .remove("v")
            .unwrap_or_else(|| Value::String(text.to_owned())),
        Err(_) => Value::String(text.to_owned()),
    }
}

/// Apply one `key=value` override to `root`, creating intermediate tables as needed.
pub fn apply(root: &mut Table, assignment: &str) -> Result<(), OverrideError> {
    let (key, value) = assignment
        .split_once('=')
        .filter(|(k, _)| !k.trim().is_empty())
        .ok_or_else(|| OverrideError::Syntax(assignment.to_owned()))?;
    let parts: Vec<&str> = key.trim().split('.').map(str::trim).collect();
    if parts.iter().any(|p| p.is_empty()) {
        return Err(OverrideError::Syntax(assignment.to_owned()));
    }
    set_value(root, key.trim(), parse_value(value.trim()))
}

/// Set the value at a dotted `key`, creating intermediate tables as needed.
pub fn set_value(root: &mut Table, key: &str, value: Value) -> Result<(), OverrideError> {
    let parts: Vec<&str> = key.split('.').map(str::trim).collect();
    if parts.iter().any(|p| p.is_empty()) {
        return Err(OverrideError::Syntax(key.to_owned()));
    }
    let (last, path) = parts.split_last().expect("non-empty");
    let mut table = root;
    for (depth, part) in path.iter().enumerate() {
        let entry = table
            .entry((*part).to_owned())
            .or_insert_with(|| Value::Table(Table::new()));
        table = entry
            .as_table_mut()
            .ok_or_else(|| OverrideError::NotATable {
                key: key.to_owned(),
                prefix: parts[..=depth].join("."),
            })?;
    }
    table.insert((*last).to_owned(), value);
    Ok(())
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn values_are_typed_and_bare_words_are_strings() {
        let mut t = Table::new();
        apply(&mut t, "run.dt=1e-3").unwrap();
        apply(&mut t, "integrator.method=rk4").unwrap();
        apply(&mut t, "forces.gravity=[0, -9.81, 0]").unwrap();
        apply(&mut t, "integrator.newton.project_hessian=true").unwrap();
        assert_eq!(t["run"]["dt"], Value::Float(1e-3));
        assert_eq!(t["integrator"]["method"], Value::String("rk4".into()));
        assert_eq!(t["forces"]["gravity"].as_array().unwrap().len(), 3);
        assert_eq!(
            t["integrator"]["newton"]["project_hessian"],
            Value::Boolean(true)
        );
    }

    #[test]
    fn malformed_overrides_are_errors() {
        let mut t = Table::new();
        assert!(matches!(
            apply(&mut t, "run.dt"),
            Err(OverrideError::Syntax(_))
        ));
        assert!(matches!(
            apply(&mut t, "run..dt=1"),
            Err(OverrideError::Syntax(_))
        ));
        apply(&mut t, "run.dt=1").unwrap();
        assert!(matches!(
            apply(&mut t, "run.dt.x=1"),
            Err(OverrideError::NotATable { .. })
        ));
    }
}
