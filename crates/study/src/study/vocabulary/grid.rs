//! The grid: axes of dotted scene keys and their values, per-method options, and every
//! combination of them.

use crate::study::vocabulary::config::METHOD_KEY;
use crate::study::vocabulary::config::{StudyFile, line_of};
use crate::study::vocabulary::context::Context;
use crate::study::vocabulary::error::StudyError;
use toml::Value;

/// One axis of the grid: a dotted key and its values.
#[derive(Clone, Debug)]
pub(in crate::study) struct Axis {
    pub key: String,
    pub values: Vec<Value>,
    pub line: usize,
}

/// The `[grid]` axes in file order.
pub(in crate::study) fn grid_axes(
    file: &StudyFile,
    ctx: &Context,
) -> Result<Vec<Axis>, StudyError> {
    let mut axes = Vec::new();
    for (key, value) in &file.grid {
        // Both apply to every run, so one would silently replace the other.
        if let Some(set) = file.set.keys().find(|s| overlaps(s, key)) {
            return Err(ctx.invalid(
                value.span().start,
                &format!("grid.\"{key}\""),
                format!(
                    "[set] gives \"{set}\" too, and the grid's values would replace it in every \
                     run: give the key in one place ([set] for one value, [grid] for several)"
                ),
            ));
        }
        axes.push(axis(key, value.get_ref(), value.span().start, ctx, true)?);
    }
    if axes.is_empty() && file.methods.is_empty() {
        return Err(ctx.invalid(
            0,
            "grid",
            "the grid is empty: give at least one key with a list of values, e.g. \
             \"integrator.method\" = [\"rk4\", \"backward-euler\"]",
        ));
    }
    axes.sort_by_key(|a| a.line);
    Ok(axes)
}

/// One axis from a grid entry; `list_only` refuses single values (as in `[grid]`).
pub(in crate::study) fn axis(
    key: &str,
    value: &Value,
    at: usize,
    ctx: &Context,
    list_only: bool,
) -> Result<Axis, StudyError> {
    let values = match value {
        Value::Array(values) => values.clone(),
        other if !list_only => vec![other.clone()],
        other => {
            return Err(ctx.invalid(
                at,
                &format!("grid.\"{key}\""),
                format!("expected a list of values, found {}", other.type_str()),
            ));
        }
    };
    if values.is_empty() {
        return Err(ctx.invalid(
            at,
            &format!("grid.\"{key}\""),
            "the list is empty: give at least one value",
        ));
    }
    // A value listed twice is one run (same id, same configuration), so the grid would be
    // smaller than written without a word.
    if let Some(v) = values
        .iter()
        .enumerate()
        .find_map(|(i, v)| values[..i].contains(v).then_some(v))
    {
        return Err(ctx.invalid(
            at,
            &format!("grid.\"{key}\""),
            format!("lists {v} more than once: a repeated value is the same run; give each once"),
        ));
    }
    Ok(Axis {
        key: key.to_owned(),
        values,
        line: line_of(ctx.text, at),
    })
}

/// The axes of each method entry: the grid with the entry's own options on top, then one
/// entry per `extra` method (the kind's own) with the grid alone. Without either, the grid
/// alone.
pub(in crate::study) fn method_entries(
    file: &StudyFile,
    ctx: &Context,
    grid: &[Axis],
    extra: &[softbench_core::integrate::Method],
) -> Result<Vec<Vec<Axis>>, StudyError> {
    if file.methods.is_empty() && extra.is_empty() {
        return Ok(vec![grid.to_vec()]);
    }
    if let Some(axis) = grid.iter().find(|a| a.key == METHOD_KEY) {
        return Err(StudyError::Invalid {
            path: ctx.path.to_owned(),
            line: axis.line,
            key: format!("grid.\"{METHOD_KEY}\""),
            message: "give the methods either in [grid] or as [[methods]], not both".into(),
        });
    }
    let mut entries = Vec::new();
    for (i, entry) in file.methods.iter().enumerate() {
        let at = entry.span().start;
        let table = entry.get_ref();
        let Some(method) = table.get("method") else {
            return Err(ctx.invalid(
                at,
                &format!("methods[{i}]"),
                "each [[methods]] entry needs `method = \"...\"`",
            ));
        };
        let mut axes: Vec<Axis> = grid.to_vec();
        let line = line_of(ctx.text, at);
        axes.push(Axis {
            key: METHOD_KEY.into(),
            values: vec![method.clone()],
            line,
        });
        for (key, value) in table.iter().filter(|(k, _)| *k != "method") {
            let mut a = axis(key, value, at, ctx, false)?;
            a.line = line;
            axes.retain(|b| b.key != a.key);
            axes.push(a);
        }
        entries.push(axes);
    }
    // The kind's own methods, each with the grid alone (its default settings).
    for method in extra {
        let mut axes: Vec<Axis> = grid.to_vec();
        axes.push(Axis {
            key: METHOD_KEY.into(),
            values: vec![Value::String(method.name().to_owned())],
            line: 1,
        });
        entries.push(axes);
    }
    Ok(entries)
}

/// Whether two dotted keys set the same thing: equal, or one a table holding the other.
pub(in crate::study) fn overlaps(a: &str, b: &str) -> bool {
    let under =
        |x: &str, y: &str| x.len() > y.len() && x.starts_with(y) && x[y.len()..].starts_with('.');
    a == b || under(a, b) || under(b, a)
}

/// Every combination of the axes' values.
pub(in crate::study) fn product(axes: &[Axis]) -> Vec<Vec<(String, Value)>> {
    let mut combos: Vec<Vec<(String, Value)>> = vec![Vec::new()];
    for axis in axes {
        combos = combos
            .into_iter()
            .flat_map(|c| {
                axis.values.iter().map(move |v| {
                    let mut c = c.clone();
                    c.push((axis.key.clone(), v.clone()));
                    c
                })
            })
            .collect();
    }
    combos
}
