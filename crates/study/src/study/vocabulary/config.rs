//! The study file schema (TOML): which scenes, which grid of runs, what is measured.
//!
//! Values the runner must point back to (grid entries, scenes, overrides) keep their byte
//! span in the file, so an error can name the line.

use std::collections::BTreeMap;
use toml::Spanned;

/// The scene key of the integration method (a grid axis of its own).
pub(in crate::study) const METHOD_KEY: &str = "integrator.method";
/// The scene key of the linear solver (a grid axis of its own).
pub(in crate::study) const SOLVER_KEY: &str = "integrator.linear_solver";

/// The `study` of a sweep: one registered kind (`[sweep] kind`) over one grid key. Every other
/// `study` value names a registered kind (`softbench list`).
pub const SWEEP: &str = "sweep";

/// The keys of a study file that are not a kind's settings table.
pub(in crate::study) const STUDY_KEYS: [&str; 10] = [
    "name",
    "study",
    "description",
    "scenes",
    "leave_out_what_cannot_run",
    "set",
    "grid",
    "methods",
    "sweep",
    "quick",
];

/// A study file as written. Its keys other than the generic ones (`name`, `study`, `scenes`,
/// ...) are the kinds' own settings tables, which each kind parses (and loading checks that no
/// other key is there).
#[derive(Clone, Debug, serde::Deserialize)]
pub struct StudyFile {
    /// The study's name: its results folder.
    pub name: String,
    /// What is measured: a registered kind's name, or [`SWEEP`].
    pub study: Spanned<String>,
    /// A sentence or two for the report.
    #[serde(default)]
    pub description: Option<String>,
    /// Scene files (relative to the study file) or inline scene tables.
    pub scenes: Vec<Spanned<toml::Value>>,
    /// Leave out, as omissions with the method's reason, the runs whose method cannot run
    /// their scene (a peer without drags on a dragged body), instead of refusing the study.
    /// A suite always does.
    #[serde(default)]
    pub leave_out_what_cannot_run: bool,
    /// Scene keys set for every run (dotted paths), e.g. `"run.steps" = 100`.
    #[serde(default)]
    pub set: BTreeMap<String, Spanned<toml::Value>>,
    /// Scene keys to sweep (dotted paths); every combination is one run.
    #[serde(default)]
    pub grid: BTreeMap<String, Spanned<toml::Value>>,
    /// Methods each with their own options (`[[methods]] method = "adaptive-rk4"
    /// "integrator.adaptive.tolerance" = [1e-4, 1e-6]`), instead of `integrator.method` in
    /// the grid.
    #[serde(default)]
    pub methods: Vec<Spanned<toml::Table>>,
    #[serde(default)]
    pub sweep: Option<SweepSettings>,
    /// What `--quick` changes.
    #[serde(default)]
    pub quick: QuickSettings,
    /// Each registered kind's settings table as its kind parsed and resolved it (JSON null
    /// where the file has none), by kind name; filled at load.
    #[serde(skip)]
    pub tables: BTreeMap<&'static str, serde_json::Value>,
}

impl StudyFile {
    /// The settings table of `kind` as resolved at load; `None` when the file has none.
    pub fn settings<T: serde::de::DeserializeOwned>(&self, kind: &str) -> Option<T> {
        from_json(self.tables.get(kind))
    }

    /// Replace the resolved settings table of `kind` (`[quick]` applied to it).
    pub(in crate::study) fn set_settings<T: serde::Serialize>(
        &mut self,
        kind: &'static str,
        value: &T,
    ) {
        self.tables.insert(
            kind,
            serde_json::to_value(value).unwrap_or(serde_json::Value::Null),
        );
    }
}

/// `[sweep]`: a study of another kind over one grid key.
#[derive(Clone, Debug, PartialEq, serde::Serialize, serde::Deserialize)]
#[serde(deny_unknown_fields)]
pub struct SweepSettings {
    /// What each run measures: a registered kind's name.
    pub kind: String,
    /// The swept grid key (dotted path), the x axis of the sweep plots.
    pub parameter: String,
    /// Columns of runs.csv plotted against the parameter. Default per kind.
    #[serde(default)]
    pub metrics: Vec<String>,
}

/// `[quick]`: how `--quick` shortens the study. `set` applies whatever the kind; every other
/// key belongs to a kind (`Kind::quick_keys`), which parses and checks it at load.
#[derive(Clone, Debug, Default, PartialEq, serde::Deserialize)]
pub struct QuickSettings {
    /// Scene keys set in quick mode (dotted paths), after `set` and the grid.
    #[serde(default)]
    pub set: BTreeMap<String, toml::Value>,
    /// The kinds' own keys as they parsed them (JSON null where the file has none), merged.
    #[serde(skip)]
    pub keys: serde_json::Map<String, serde_json::Value>,
}

impl QuickSettings {
    /// A kind's `[quick]` key as parsed at load; `None` when the file does not set it.
    pub fn get<T: serde::de::DeserializeOwned>(&self, key: &str) -> Option<T> {
        from_json(self.keys.get(key))
    }
}

/// As hashed into every run and recorded in meta.json: `set` and every kind's keys, one object.
impl serde::Serialize for QuickSettings {
    fn serialize<S: serde::Serializer>(&self, serializer: S) -> Result<S::Ok, S::Error> {
        let mut all = self.keys.clone();
        let set = serde_json::to_value(&self.set).map_err(serde::ser::Error::custom)?;
        all.insert("set".into(), set);
        all.serialize(serializer)
    }
}

/// A value parsed at load, read back as its type (`None` for null or absent).
fn from_json<T: serde::de::DeserializeOwned>(value: Option<&serde_json::Value>) -> Option<T> {
    value
        .filter(|v| !v.is_null())
        .and_then(|v| serde_json::from_value(v.clone()).ok())
}

/// The line (1-based) of byte offset `at` in `text`.
pub fn line_of(text: &str, at: usize) -> usize {
    text[..at.min(text.len())].matches('\n').count() + 1
}
