//! Work that runs share (a scene's highest mode, a reference solution), stored in the study
//! folder as `shared/<key>/value.json`, so the shards of a study compute each item once: the
//! first shard that needs it takes the item's lock (`shared/<key>/.softbench.lock`) and
//! computes it, the others wait for the lock and read what it stored. Numbers are stored as
//! their f64 bits, so every shard uses exactly what the first one computed.

use crate::study::vocabulary::error::RunError;
use serde::Serialize;
use serde::de::DeserializeOwned;
use softbench_run::io::write_atomic;
use softbench_run::lock::{FolderLock, Wait, Waiting};
use std::path::{Path, PathBuf};

/// The `shared/` folder of a study folder.
#[derive(Clone, Debug)]
pub(in crate::study) struct SharedStore {
    dir: PathBuf,
}

impl SharedStore {
    pub(in crate::study) fn new(study_dir: &Path) -> Self {
        Self {
            dir: study_dir.join("shared"),
        }
    }

    fn value_path(&self, key: &str) -> PathBuf {
        self.dir.join(key).join("value.json")
    }

    /// The stored value of `key`, if any.
    pub(in crate::study) fn read<T: DeserializeOwned>(
        &self,
        key: &str,
    ) -> Result<Option<T>, RunError> {
        let path = self.value_path(key);
        let text = match std::fs::read_to_string(&path) {
            Ok(t) => t,
            Err(e) if e.kind() == std::io::ErrorKind::NotFound => return Ok(None),
            Err(error) => return Err(RunError::Io { path, error }),
        };
        serde_json::from_str(&text).map(Some).map_err(|e| {
            RunError::Run(format!(
                "{}: not a stored shared result ({e}); remove its folder to compute it again",
                path.display()
            ))
        })
    }

    /// The stored value of `key`; if there is none, `compute` it under the item's lock
    /// (waiting while another process computes it, `on_wait` called once) and store it when
    /// `keep` says so (a result cut short by a stop request is not kept).
    pub(in crate::study) fn get_or_compute<T: Serialize + DeserializeOwned>(
        &self,
        key: &str,
        on_wait: impl FnMut(&Waiting),
        compute: impl FnOnce() -> T,
        keep: impl FnOnce(&T) -> bool,
    ) -> Result<T, RunError> {
        if let Some(value) = self.read(key)? {
            return Ok(value);
        }
        let folder = self.dir.join(key);
        std::fs::create_dir_all(&folder).map_err(|error| RunError::Io {
            path: folder.clone(),
            error,
        })?;
        let _lock = FolderLock::acquire(&folder, &format!("computing {key}"), Wait::Yes, on_wait)?;
        // Whoever held the lock before may have stored it.
        if let Some(value) = self.read(key)? {
            return Ok(value);
        }
        softbench_run::io::remove_stale_partials(&folder).map_err(|error| RunError::Io {
            path: folder.clone(),
            error,
        })?;
        let value = compute();
        if keep(&value) {
            let path = self.value_path(key);
            write_atomic(&path, |w| {
                serde_json::to_writer(&mut *w, &value)?;
                writeln!(w)
            })
            .map_err(|error| RunError::Io { path, error })?;
        }
        Ok(value)
    }
}

/// An f64 as stored: its bits (exact, NaN and infinities included).
pub(in crate::study) fn bits(x: f64) -> u64 {
    x.to_bits()
}

/// The f64 of stored bits.
pub(in crate::study) fn from_bits(b: u64) -> f64 {
    f64::from_bits(b)
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn a_stored_value_is_computed_once_and_read_back_exactly() {
        let dir = tempfile::tempdir().unwrap();
        let store = SharedStore::new(dir.path());
        let x = 0.1f64 + 0.2;
        let calls = std::cell::Cell::new(0);
        let compute = || {
            calls.set(calls.get() + 1);
            vec![bits(x), bits(f64::NAN)]
        };
        let first: Vec<u64> = store
            .get_or_compute("k", |_| {}, compute, |_| true)
            .unwrap();
        let again: Vec<u64> = store
            .get_or_compute("k", |_| {}, compute, |_| true)
            .unwrap();
        assert_eq!(calls.get(), 1);
        assert_eq!(first, again);
        assert_eq!(from_bits(again[0]), x);
        assert!(from_bits(again[1]).is_nan());
        // Not kept: computed again next time.
        let _: u32 = store
            .get_or_compute("cut", |_| {}, || 1, |_| false)
            .unwrap();
        assert_eq!(store.read::<u32>("cut").unwrap(), None);
        // Garbage is an error naming the file, not a panic.
        std::fs::write(dir.path().join("shared/k/value.json"), "{").unwrap();
        let e = store.read::<Vec<u64>>("k").unwrap_err().to_string();
        assert!(
            e.contains("value.json") && e.contains("remove its folder"),
            "{e}"
        );
    }
}
