//! `softbench plot` and `softbench render` on a results folder: its `meta.json` and
//! `runs.csv` read back and checked, then the plots, the report's computed sections and the
//! pictures drawn again.

use crate::study::kinds;
use crate::study::present::{charts, pictures, plots, report};
use crate::study::vocabulary::columns;
use crate::study::vocabulary::error::ResultsError;
use crate::study::vocabulary::meta::{Meta, StudyMeta};
use crate::study::vocabulary::table;

/// Redraw the plots of a results folder from its `runs.csv`, series files and `meta.json`.
pub fn redraw(dir: &std::path::Path) -> Result<Vec<plots::Plot>, RedrawError> {
    let (meta, runs) = read_results(dir)?;
    check_runs_table(&runs, &meta.study, &dir.join("runs.csv"))?;
    let plots = plots::draw_all(dir, &meta.study, &runs)?;
    let report_error = |error| ResultsError::Io {
        path: dir.join("report.md"),
        error,
    };
    report::refresh_findings(dir, &meta, &runs).map_err(report_error)?;
    report::refresh_closing_sections(dir, &meta, &runs, &plots).map_err(report_error)?;
    Ok(plots)
}

/// [`pictures::draw`] for a study's results folder, reading its `runs.csv` and `meta.json` (for
/// the swept parameters that label the runs).
pub fn redraw_pictures(
    dir: &std::path::Path,
    coloring: softbench_run::render::Coloring,
) -> Result<Vec<charts::Plot>, RedrawError> {
    let (meta, runs) = read_results(dir)?;
    let which = kinds::present(&meta.study.kind).picture_rows();
    pictures::draw(dir, &runs, &meta.study.parameters, which, coloring)
        .map_err(|e| RedrawError::Plot(softbench_run::plot::PlotError::Draw(e.to_string())))
}

/// A results folder's `meta.json` (whose kind must be registered in this build) and
/// `runs.csv`.
fn read_results(dir: &std::path::Path) -> Result<(Meta, table::Table), ResultsError> {
    let meta_path = dir.join("meta.json");
    let text = std::fs::read_to_string(&meta_path).map_err(|error| ResultsError::Io {
        path: meta_path.clone(),
        error,
    })?;
    let meta: Meta = serde_json::from_str(&text).map_err(|e| ResultsError::Malformed {
        path: meta_path.clone(),
        message: e.to_string(),
    })?;
    if !kinds::is_registered(&meta.study.kind) {
        let names = kinds::names();
        return Err(ResultsError::Malformed {
            path: meta_path,
            message: softbench_core::names::unknown_name_message(
                "study kind",
                &meta.study.kind,
                &names,
            ),
        });
    }
    let runs_path = dir.join("runs.csv");
    let runs = table::Table::read(&runs_path)?.ok_or_else(|| ResultsError::Io {
        path: runs_path.clone(),
        error: std::io::Error::from(std::io::ErrorKind::NotFound),
    })?;
    Ok((meta, runs))
}

/// Before any plot is replaced or removed: `runs.csv` must have a whole header (the identity
/// columns first, the trailer last: a header cut short lacks the trailer) and at least one row
/// (a cut or emptied file would otherwise leave no plots; a row cut short fails to read).
/// The kind's measured columns are not required: a table an earlier softbench wrote lacks the
/// columns added since, and its plots are drawn without them.
fn check_runs_table(
    runs: &table::Table,
    study: &StudyMeta,
    path: &std::path::Path,
) -> Result<(), ResultsError> {
    let malformed = |message: String| ResultsError::Malformed {
        path: path.to_owned(),
        message,
    };
    if let Some(missing) = columns::IDENTITY
        .iter()
        .chain(&columns::TRAILER)
        .find(|c| runs.column(c).is_none())
    {
        return Err(malformed(format!(
            "line 1: the header has no `{missing}` column (a {} study's runs.csv has it); the \
             file is cut short or not softbench's: no plot was changed",
            study.kind
        )));
    }
    if runs.rows.is_empty() {
        return Err(malformed(
            "no runs below the header: nothing to draw, no plot was changed".into(),
        ));
    }
    Ok(())
}

/// Why plots could not be redrawn.
#[derive(Debug, thiserror::Error)]
pub enum RedrawError {
    #[error(transparent)]
    Results(#[from] ResultsError),
    #[error("cannot draw: {0}")]
    Plot(#[from] softbench_run::plot::PlotError),
}

impl softbench_core::error_class::Classify for RedrawError {
    /// A results folder that cannot be read back is the input of `softbench plot`; drawing
    /// is the system's.
    fn class(&self) -> softbench_core::error_class::ErrorClass {
        match self {
            Self::Results(e) => softbench_core::error_class::Classify::class(e),
            Self::Plot(e) => softbench_core::error_class::Classify::class(e),
        }
    }
}
