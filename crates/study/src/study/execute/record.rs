//! A finished run on disk: its series files, and its row of `runs.csv`.

use crate::study::vocabulary::error::RunError;
use crate::study::vocabulary::identity::value_text;
use crate::study::vocabulary::measured::Measured;
use crate::study::vocabulary::spec::{RunSpec, Study};
use softbench_run::io::write_atomic;
use std::collections::HashMap;
use std::path::Path;

/// Write a finished run's series files and return its `runs.csv` row.
pub(in crate::study) fn record(
    study: &Study,
    spec: &RunSpec,
    m: &Measured,
    header: &[String],
    dir: &Path,
) -> Result<Vec<String>, RunError> {
    let series = dir.join("series").join(format!("{}.csv", spec.id));
    write_atomic(&series, |w| {
        let mut csv = csv::Writer::from_writer(w);
        if m.series.is_empty() {
            csv.write_record(["step"])?;
        }
        for row in &m.series {
            csv.serialize(row)?;
        }
        csv.flush()
    })
    .map_err(|error| RunError::Io {
        path: series.clone(),
        error,
    })?;
    if let Some(snapshots) = &m.snapshots {
        let path = crate::study::present::pictures::snapshot_path(dir, &spec.id);
        snapshots
            .write(&path)
            .map_err(|e| RunError::Run(e.to_string()))?;
    }
    for (name, table) in &m.tables {
        debug_assert!(crate::study::vocabulary::measured::SERIES_TABLES.contains(name));
        let path = dir.join("series").join(format!("{}-{name}.csv", spec.id));
        table
            .write(&path)
            .map_err(|error| RunError::Io { path, error })?;
    }
    let params: HashMap<String, String> = study
        .parameter_columns()
        .into_iter()
        .map(|(i, name)| {
            (
                name,
                spec.parameters[i]
                    .as_ref()
                    .map_or(String::new(), value_text),
            )
        })
        .collect();
    let fixed = |column: &str| match column {
        "run_id" => Some(spec.id.clone()),
        "scene" => Some(spec.scene.clone()),
        "method" => Some(spec.method.name().to_owned()),
        "linear_solver" => Some(
            spec.linear_solver
                .map_or("-".to_owned(), |s| s.name().to_owned()),
        ),
        "outcome" => Some(m.outcome.clone()),
        "message" => Some(m.message.clone()),
        "config_hash" => Some(spec.hash.clone()),
        other => params.get(other).cloned(),
    };
    crate::study::vocabulary::columns::row(header, &fixed, &m.cells).map_err(|e| {
        RunError::Run(format!(
            "run {}: {e} (a defect of the {} study kind)",
            spec.id, study.kind
        ))
    })
}
