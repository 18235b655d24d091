//! `runs.csv` and the series files as tables of strings with a header: written atomically,
//! read back for resuming, plotting and reporting.

use crate::study::vocabulary::error::ResultsError;
use softbench_run::io::write_atomic;
use std::path::Path;

/// A CSV table.
#[derive(Clone, Debug, Default, PartialEq)]
pub struct Table {
    pub header: Vec<String>,
    pub rows: Vec<Vec<String>>,
}

impl Table {
    /// An empty table with these columns.
    pub fn new(header: Vec<String>) -> Self {
        Self {
            header,
            rows: Vec::new(),
        }
    }

    /// Read `path`; `Ok(None)` if it does not exist. A file that does not end with a line
    /// break was cut short (softbench writes whole files only) and is an error naming its
    /// last line, as is a row with the wrong number of cells.
    pub fn read(path: &Path) -> Result<Option<Self>, ResultsError> {
        let bytes = match std::fs::read(path) {
            Ok(b) => b,
            Err(e) if e.kind() == std::io::ErrorKind::NotFound => return Ok(None),
            Err(error) => {
                return Err(ResultsError::Io {
                    path: path.to_owned(),
                    error,
                });
            }
        };
        let malformed = |e: csv::Error| ResultsError::Malformed {
            path: path.to_owned(),
            message: e.to_string(),
        };
        if bytes.last().is_some_and(|&b| b != b'\n') {
            let line = bytes.iter().filter(|&&b| b == b'\n').count() + 1;
            return Err(ResultsError::Malformed {
                path: path.to_owned(),
                message: format!(
                    "line {line}: the file ends in the middle of a line (it was cut short); \
                     run the study again to rewrite it"
                ),
            });
        }
        let mut reader = csv::Reader::from_reader(bytes.as_slice());
        let header = reader
            .headers()
            .map_err(malformed)?
            .iter()
            .map(str::to_owned)
            .collect();
        let mut rows = Vec::new();
        for record in reader.records() {
            rows.push(
                record
                    .map_err(malformed)?
                    .iter()
                    .map(str::to_owned)
                    .collect(),
            );
        }
        Ok(Some(Self { header, rows }))
    }

    /// Write `path` atomically.
    pub fn write(&self, path: &Path) -> std::io::Result<()> {
        write_atomic(path, |w| {
            let mut csv = csv::Writer::from_writer(w);
            csv.write_record(&self.header)?;
            for row in &self.rows {
                csv.write_record(row)?;
            }
            csv.flush()
        })
    }

    /// The index of a column.
    pub fn column(&self, name: &str) -> Option<usize> {
        self.header.iter().position(|h| h == name)
    }

    /// A cell by column name (`None` if the column is missing).
    pub fn get<'a>(&self, row: &'a [String], name: &str) -> Option<&'a str> {
        self.column(name)
            .and_then(|i| row.get(i))
            .map(String::as_str)
    }

    /// A numeric cell; `None` when missing, empty or not a number.
    pub fn number(&self, row: &[String], name: &str) -> Option<f64> {
        self.get(row, name).and_then(|s| s.parse().ok())
    }

    /// A numeric column.
    pub fn numbers(&self, name: &str) -> Vec<Option<f64>> {
        self.rows.iter().map(|r| self.number(r, name)).collect()
    }
}
