//! The rows of a study's results folder: the `runs.csv` header, which runs are done, the
//! rows earlier invocations and shards left, and where a shard keeps its own.

use crate::study::vocabulary::columns::{IDENTITY, TRAILER};
use crate::study::vocabulary::error::{RunError, io_error};
use crate::study::vocabulary::shard::Shard;
use crate::study::vocabulary::shard_record::ShardRecord;
use crate::study::vocabulary::spec::{RunSpec, Study};
use crate::study::vocabulary::table::Table;
use std::collections::HashMap;
use std::path::{Path, PathBuf};

/// The header of the study's `runs.csv`: the identity, the parameters, the kind's columns
/// and the trailer ([`crate::study::vocabulary::columns`]).
pub fn header(study: &Study) -> Vec<String> {
    let kind_columns = study.kind_columns;
    IDENTITY
        .iter()
        .map(|s| (*s).to_owned())
        .chain(study.parameter_columns().into_iter().map(|(_, c)| c))
        .chain(kind_columns.iter().map(|s| (*s).to_owned()))
        .chain(TRAILER.iter().map(|s| (*s).to_owned()))
        .collect()
}

/// The folder of one shard: `<study>/shards/K-of-N`.
pub(in crate::study) fn shard_folder(dir: &Path, shard: Shard) -> PathBuf {
    dir.join("shards").join(shard.folder_name())
}

/// Whether `spec` has a row of the same configuration and its series file.
pub(in crate::study) fn is_done(
    dir: &Path,
    spec: &RunSpec,
    rows: &HashMap<String, Vec<String>>,
) -> bool {
    rows.get(&spec.id)
        .is_some_and(|row| row.last() == Some(&spec.hash))
        && dir.join("series").join(format!("{}.csv", spec.id)).exists()
}

/// The rows of earlier invocations by run id: the study's `runs.csv` and every shard's table
/// (whatever N), rows with the current header only; where sources disagree, a row of the
/// run's current configuration wins.
pub(in crate::study) fn earlier_rows(
    study: &Study,
    dir: &Path,
    header: &[String],
) -> Result<HashMap<String, Vec<String>>, RunError> {
    let hashes: HashMap<&str, &str> = study
        .runs
        .iter()
        .map(|r| (r.id.as_str(), r.hash.as_str()))
        .collect();
    let mut tables = vec![dir.join("runs.csv")];
    tables.extend(
        ShardRecord::folders(dir)
            .map_err(io_error(&dir.join("shards")))?
            .into_iter()
            .map(|(_, folder)| folder.join("runs.csv")),
    );
    let mut rows: HashMap<String, Vec<String>> = HashMap::new();
    for path in tables {
        let Some(table) = Table::read(&path)? else {
            continue;
        };
        // Rows are reused only when the columns are the same.
        if table.header != header {
            continue;
        }
        for row in table.rows {
            if row.len() != header.len() {
                continue;
            }
            let current = hashes.get(row[0].as_str()) == row.last().map(String::as_str).as_ref();
            let has_current = rows.get(&row[0]).is_some_and(|r| {
                hashes.get(r[0].as_str()) == r.last().map(String::as_str).as_ref()
            });
            if current || !has_current {
                rows.insert(row[0].clone(), row);
            }
        }
    }
    Ok(rows)
}

/// The rows present, in the study's run order.
pub(in crate::study) fn ordered(
    study: &Study,
    header: &[String],
    rows: &HashMap<String, Vec<String>>,
) -> Table {
    let mut table = Table::new(header.to_vec());
    table.rows = study
        .runs
        .iter()
        .filter_map(|r| rows.get(&r.id).cloned())
        .collect();
    table
}
