//! Comparing two studies' results: every column but the machine's measurements (wall-clock
//! times and the process's peak memory).

use softbench::study::table::Table;
use std::path::Path;

/// Measurements of the machine, not of the method: the only columns allowed to differ between
/// two runs of a study (wall-clock times; the peak resident memory, which depends on what the
/// process ran before).
pub fn is_machine_measurement(column: &str) -> bool {
    column.contains("seconds") || column == "peak_rss_mib"
}

/// The CSV tables `a` and `b` hold the same rows in the same order, equal in every column but
/// the machine's measurements.
pub fn assert_same_results(a: &Path, b: &Path) {
    let read = |p: &Path| {
        Table::read(p)
            .unwrap()
            .unwrap_or_else(|| panic!("{} is missing", p.display()))
    };
    let (ta, tb) = (read(a), read(b));
    assert_eq!(ta.header, tb.header, "{} vs {}", a.display(), b.display());
    assert_eq!(
        ta.rows.len(),
        tb.rows.len(),
        "{} vs {}",
        a.display(),
        b.display()
    );
    let mut compared = 0;
    for (ra, rb) in ta.rows.iter().zip(&tb.rows) {
        for (i, column) in ta.header.iter().enumerate() {
            if !is_machine_measurement(column) {
                assert_eq!(
                    ra[i],
                    rb[i],
                    "{}: row {}, column {column}",
                    b.display(),
                    ra[0]
                );
                compared += 1;
            }
        }
    }
    assert!(compared > 0);
}

/// Two results folders agree in `runs.csv` and in every run's series file (timings aside).
pub fn assert_same_study(a: &Path, b: &Path) {
    assert_same_results(&a.join("runs.csv"), &b.join("runs.csv"));
    let runs = Table::read(&a.join("runs.csv")).unwrap().unwrap();
    for row in &runs.rows {
        let name = format!("series/{}.csv", row[0]);
        assert_same_results(&a.join(&name), &b.join(&name));
    }
}
