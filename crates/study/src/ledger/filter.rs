//! Row filters of a claim's rule: which rows of a results table a side of a comparison, a
//! trend or a bound reads. A filter is a table of `column = condition`; every condition must
//! hold. A condition is a value (`"vbd"`: equal), alternatives (`"unstable|solver-failed"`),
//! a negation (`"!= completed"`), a numeric comparison (`"< 1e-5"`, `">= 0.49"`) or `"*"` (any
//! non-empty cell). A number or a boolean in the TOML is compared as its text.

use crate::study::table::Table;
use std::collections::BTreeMap;

/// One column's condition.
#[derive(Clone, Debug, PartialEq)]
pub enum Condition {
    Equal(String),
    OneOf(Vec<String>),
    NotEqual(String),
    /// A numeric comparison: the operator (`<`, `<=`, `>`, `>=`) and the bound.
    Compare(&'static str, f64),
    NonEmpty,
}

impl Condition {
    /// Parse a condition as written.
    pub fn parse(text: &str) -> Result<Self, String> {
        let t = text.trim();
        if t == "*" {
            return Ok(Self::NonEmpty);
        }
        if let Some(rest) = t.strip_prefix("!=") {
            return Ok(Self::NotEqual(rest.trim().to_owned()));
        }
        for op in ["<=", ">=", "<", ">"] {
            if let Some(rest) = t.strip_prefix(op) {
                let bound: f64 = rest.trim().parse().map_err(|_| {
                    format!("`{t}`: `{op}` needs a number after it (e.g. `{op} 1e-5`)")
                })?;
                return Ok(Self::Compare(op, bound));
            }
        }
        if t.contains('|') {
            return Ok(Self::OneOf(
                t.split('|').map(|s| s.trim().to_owned()).collect(),
            ));
        }
        Ok(Self::Equal(t.to_owned()))
    }

    /// Whether a cell meets it.
    pub fn holds(&self, cell: &str) -> bool {
        match self {
            Self::Equal(v) => cell == v,
            Self::OneOf(vs) => vs.iter().any(|v| v == cell),
            Self::NotEqual(v) => cell != v,
            Self::NonEmpty => !cell.is_empty(),
            Self::Compare(op, bound) => cell.parse::<f64>().is_ok_and(|x| match *op {
                "<" => x < *bound,
                "<=" => x <= *bound,
                ">" => x > *bound,
                _ => x >= *bound,
            }),
        }
    }
}

impl std::fmt::Display for Condition {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        match self {
            Self::Equal(v) => write!(f, "= {v}"),
            Self::OneOf(vs) => write!(f, "∈ {{{}}}", vs.join(", ")),
            Self::NotEqual(v) => write!(f, "≠ {v}"),
            Self::Compare(op, b) => write!(f, "{op} {b}"),
            Self::NonEmpty => write!(f, "set"),
        }
    }
}

/// A table of conditions, by column.
#[derive(Clone, Debug, Default, PartialEq)]
pub struct Filter(pub BTreeMap<String, Condition>);

impl Filter {
    /// The filter a TOML table writes (values: strings, numbers or booleans).
    pub fn from_toml(table: &toml::Table) -> Result<Self, String> {
        let mut out = BTreeMap::new();
        for (column, value) in table {
            let text = match value {
                toml::Value::String(s) => s.clone(),
                toml::Value::Integer(i) => i.to_string(),
                toml::Value::Float(x) => x.to_string(),
                toml::Value::Boolean(b) => b.to_string(),
                other => {
                    return Err(format!(
                        "`{column}`: a condition is a string, a number or a boolean, found {}",
                        other.type_str()
                    ));
                }
            };
            out.insert(
                column.clone(),
                Condition::parse(&text).map_err(|e| format!("`{column}`: {e}"))?,
            );
        }
        Ok(Self(out))
    }

    /// Whether `row` of `table` meets every condition (a missing column meets none).
    pub fn keeps(&self, table: &Table, row: &[String]) -> bool {
        self.0.iter().all(|(column, condition)| {
            table
                .get(row, column)
                .is_some_and(|cell| condition.holds(cell))
        })
    }

    /// The columns it reads.
    pub fn columns(&self) -> impl Iterator<Item = &str> {
        self.0.keys().map(String::as_str)
    }

    /// How the ledger shows it: `method = vbd, level = tight`.
    pub fn describe(&self) -> String {
        if self.0.is_empty() {
            return "every row".into();
        }
        self.0
            .iter()
            .map(|(c, cond)| format!("{c} {cond}"))
            .collect::<Vec<_>>()
            .join(", ")
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn conditions_parse_and_hold() {
        assert!(Condition::parse("vbd").unwrap().holds("vbd"));
        assert!(!Condition::parse("vbd").unwrap().holds("xpbd"));
        assert!(Condition::parse("a|b").unwrap().holds("b"));
        assert!(Condition::parse("!= completed").unwrap().holds("unstable"));
        assert!(Condition::parse("< 1e-5").unwrap().holds("3e-6"));
        assert!(!Condition::parse("< 1e-5").unwrap().holds(""));
        assert!(Condition::parse(">= 0.49").unwrap().holds("0.49"));
        assert!(Condition::parse("*").unwrap().holds("x"));
        assert!(!Condition::parse("*").unwrap().holds(""));
        assert!(Condition::parse("< x").is_err());
    }
}
