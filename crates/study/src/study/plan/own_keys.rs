//! Scene keys a study kind decides itself ([`Kind::own_keys`], [`Kind::horizon`]). A grid over
//! one is refused: its runs would be one run repeated under several ids (a stability study's
//! `run.dt` grid ran six duplicates). A `[set]` of one the kind replaces is refused: the value
//! would be dropped without a word. A scene file's own `run.steps`, which every scene has,
//! is not refused but stated: when the kind's horizon differs from the scene's, a warning says
//! what replaced it, and `meta.json` and `report.md` keep it.

use crate::study::kind::{OwnKey, Plan};
use crate::study::vocabulary::config::StudyFile;
use crate::study::vocabulary::context::Context;
use crate::study::vocabulary::error::StudyError;
use crate::study::vocabulary::format::short;
use crate::study::vocabulary::grid::overlaps;

/// Refuse a `[grid]` or `[[methods]]` key the kind decides, and a `[set]` or `[quick] set`
/// key it replaces; the error names the key and what decides it.
pub(in crate::study) fn check(
    file: &StudyFile,
    ctx: &Context,
    kind: &dyn Plan,
) -> Result<(), StudyError> {
    let owned = |key: &str| kind.own_keys().iter().find(|o| overlaps(o.key, key));
    let study = kind.name();
    let repeated = |own: &OwnKey| {
        format!(
            "a {study} study sets {} itself ({}), so a grid over it would only repeat the same \
             run under several ids; remove it",
            own.key, own.why
        )
    };
    for (key, value) in &file.grid {
        if let Some(own) = owned(key) {
            return Err(ctx.invalid(
                value.span().start,
                &format!("grid.\"{key}\""),
                repeated(own),
            ));
        }
    }
    for (i, entry) in file.methods.iter().enumerate() {
        if let Some((key, own)) = entry
            .get_ref()
            .keys()
            .find_map(|k| owned(k).map(|own| (k, own)))
        {
            return Err(ctx.invalid(
                entry.span().start,
                &format!("methods[{i}].\"{key}\""),
                repeated(own),
            ));
        }
    }
    let replaced = |own: &OwnKey| {
        format!(
            "a {study} study sets {} itself ({}), so this value would be replaced in every run; \
             remove it",
            own.key, own.why
        )
    };
    for (key, value) in &file.set {
        if let Some(own) = owned(key).filter(|o| o.replaced) {
            return Err(ctx.invalid(value.span().start, &format!("set.\"{key}\""), replaced(own)));
        }
    }
    for key in file.quick.set.keys() {
        if let Some(own) = owned(key).filter(|o| o.replaced) {
            return Err(StudyError::Invalid {
                path: ctx.path.to_owned(),
                line: ctx.line_of_key(key),
                key: format!("quick.set.\"{key}\""),
                message: replaced(own),
            });
        }
    }
    Ok(())
}

/// One warning per scene whose own horizon (`run.dt × run.steps` as its table gives them,
/// before the study's grid) the kind's [`Kind::horizon`] replaces, saying by what.
pub(in crate::study) fn horizon_warnings<'a>(
    kind: &dyn Plan,
    file: &StudyFile,
    scenes: impl IntoIterator<Item = (&'a str, &'a toml::Table)>,
) -> Vec<String> {
    let Some((horizon, steps_from)) = kind.horizon(file) else {
        return Vec::new();
    };
    let table = kind.table_names().first().copied().unwrap_or(kind.name());
    let mut out = Vec::new();
    for (name, scene) in scenes {
        let run = scene.get("run").and_then(toml::Value::as_table);
        let Some(steps) = run
            .and_then(|r| r.get("steps"))
            .and_then(toml::Value::as_integer)
        else {
            continue;
        };
        let dt = run
            .and_then(|r| r.get("dt"))
            .and_then(|v| v.as_float().or_else(|| v.as_integer().map(|i| i as f64)));
        let own = match dt {
            Some(dt) => {
                let own = steps as f64 * dt;
                if (own - horizon).abs() <= 1e-9 * own.abs().max(horizon.abs()) {
                    continue;
                }
                format!(
                    " (a horizon of {} s at its run.dt = {} s)",
                    short(own),
                    short(dt)
                )
            }
            None => String::new(),
        };
        out.push(format!(
            "scene `{name}`: run.steps = {steps} of the scene{own} is replaced by {steps_from}, \
             for [{table}] horizon = {} s",
            short(horizon)
        ));
    }
    out
}
