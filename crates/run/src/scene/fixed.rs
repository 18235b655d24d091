//! `[fixed]` as the model's [`FixedSelection`], and the refusal of a selection that fixes every
//! vertex. Fixed vertices stay at their rest positions (no key prescribes their motion), so a
//! body with 0 free DOFs has nothing to integrate: its run would "complete" with nothing
//! moved, which is a set-up mistake (a rule tolerance or box too large), never a result.

use super::config::FixedConfig;
use nalgebra::Vector3;
use softbench_core::mesh::TetMesh;
use softbench_core::model::{AxisRule, FixedSelection, Model};

/// The model's selection of the vertices `[fixed]` names: the union of its parts.
pub(super) fn selection(c: &FixedConfig) -> FixedSelection {
    FixedSelection {
        indices: c.indices.clone(),
        rules: c
            .rule
            .iter()
            .map(|r| AxisRule {
                axis: r.axis.index(),
                side: r.side,
                tolerance: r.tolerance,
            })
            .collect(),
        boxes: c
            .fixed_box
            .iter()
            .map(|b| (Vector3::from(b.min), Vector3::from(b.max)))
            .collect(),
    }
}

/// `Err((key, message))` when `model`, built with `c`'s selection, has no free vertex: the key
/// is the part of `[fixed]` that alone fixes them all (`fixed.rule`, `fixed.box`,
/// `fixed.indices`), else `fixed`; the message counts what each part fixes.
pub(super) fn check_some_free(c: &FixedConfig, model: &Model) -> Result<(), (String, String)> {
    let dofs = model.dofs();
    if dofs.num_free() > 0 || dofs.num_vertices() == 0 {
        return Ok(());
    }
    let n = dofs.num_vertices();
    // Only on this error path: each part resolved on its own, to say which fixes what.
    let mesh = TetMesh {
        positions: model.rest_positions().to_vec(),
        tets: Vec::new(),
    };
    let whole = selection(c);
    let parts = [
        (
            "fixed.indices",
            FixedSelection {
                indices: whole.indices.clone(),
                ..FixedSelection::none()
            },
        ),
        (
            "fixed.rule",
            FixedSelection {
                rules: whole.rules.clone(),
                ..FixedSelection::none()
            },
        ),
        (
            "fixed.box",
            FixedSelection {
                boxes: whole.boxes.clone(),
                ..FixedSelection::none()
            },
        ),
    ];
    let counts: Vec<(&str, usize)> = parts
        .iter()
        .map(|(key, part)| {
            let fixed = part
                .resolve(&mesh)
                .map_or(0, |f| f.iter().filter(|x| **x).count());
            (*key, fixed)
        })
        .filter(|(_, fixed)| *fixed > 0)
        .collect();
    let key = counts
        .iter()
        .find(|(_, fixed)| *fixed == n)
        .map_or("fixed", |(key, _)| key);
    let each: Vec<String> = counts
        .iter()
        .map(|(key, fixed)| format!("{key} fixes {fixed}"))
        .collect();
    Err((
        key.to_owned(),
        format!(
            "fixes all {n} vertices of the body ({}): it would have 0 free DOFs, and fixed \
             vertices stay where they are, so nothing would move; leave at least one vertex \
             free (a smaller rule tolerance, a box that leaves part of the body out, fewer \
             indices)",
            each.join(", ")
        ),
    ))
}
