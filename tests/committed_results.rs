//! The committed results are the product: every study folder under `results/` is read back and
//! redrawn by this build (`softbench plot` on a copy) — its meta.json and runs.csv parse, its
//! kind is registered, a table written by an earlier softbench (without the columns added
//! since) draws — and redrawing changes neither its table nor the suite's aggregate tables.

mod common;

use common::TempDir;
use std::path::Path;

/// Copy the folder `from` (recursively) to `to`.
fn copy_folder(from: &Path, to: &Path) {
    std::fs::create_dir_all(to).unwrap();
    for entry in std::fs::read_dir(from).unwrap() {
        let entry = entry.unwrap();
        let target = to.join(entry.file_name());
        if entry.file_type().unwrap().is_dir() {
            copy_folder(&entry.path(), &target);
        } else {
            std::fs::copy(entry.path(), &target).unwrap();
        }
    }
}

#[test]
fn every_committed_study_folder_redraws_with_this_build() {
    let results = Path::new(env!("CARGO_MANIFEST_DIR")).join("results");
    let tmp = TempDir::new("committed-results");
    let mut studies = 0;
    let mut entries: Vec<_> = std::fs::read_dir(&results)
        .unwrap()
        .map(|e| e.unwrap().path())
        .filter(|p| p.join("runs.csv").is_file() && p.join("meta.json").is_file())
        .collect();
    entries.sort();
    for folder in entries {
        let name = folder.file_name().unwrap().to_string_lossy().into_owned();
        let copy = tmp.path().join(&name);
        copy_folder(&folder, &copy);
        let out = common::softbench(&["plot", copy.to_str().unwrap()]);
        assert!(
            out.status.success(),
            "results/{name}: softbench plot failed: {}",
            String::from_utf8_lossy(&out.stderr)
        );
        let unchanged = |file: &str| {
            let committed = folder.join(file);
            if committed.is_file() {
                assert_eq!(
                    std::fs::read(&committed).unwrap(),
                    std::fs::read(copy.join(file)).unwrap(),
                    "results/{name}/{file} changed on redrawing"
                );
            }
        };
        unchanged("runs.csv");
        for table in ["summary.csv", "costs.csv", "pairwise.csv", "profiles.csv"] {
            unchanged(&format!("profiles/{table}"));
        }
        studies += 1;
    }
    assert!(
        studies >= 15,
        "only {studies} committed study folders found"
    );
}
