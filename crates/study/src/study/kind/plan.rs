//! What planning a study asks of its kind: its name and the tables of a study file it reads
//! (its settings table, its `[quick]` keys), how it checks them, how it adapts each run's
//! scene, which scene keys it decides itself, which scenes and methods it adds or leaves out,
//! and the cost of a run for the shard balance.

use crate::study::vocabulary::config::StudyFile;
use crate::study::vocabulary::context::Context;
use crate::study::vocabulary::error::StudyError;
use crate::study::vocabulary::grid::Axis;
use softbench_run::scene::SceneConfig;

/// What `load` and `own_keys` ask of a study kind. Methods with a default are the plain case
/// (no settings table, every scene and method of the study file).
pub(in crate::study) trait Plan: Sync {
    /// The kind's name in study files (`study = "..."`, `[sweep] kind = "..."`).
    fn name(&self) -> &'static str;

    /// One line for `softbench list`: what a run of this kind measures.
    fn description(&self) -> &'static str;

    /// The tables a minimal study of this kind adds to `name`, `study` and `scenes`: its
    /// settings table and the grid it needs. `tests/study_kinds.rs` runs every registered kind
    /// from it, and the docs show it.
    fn example(&self) -> &'static str;

    /// What the kind's scenes add to a plain scene file (the suite's `[problem]` table);
    /// empty for kinds that run any scene.
    fn scene_example(&self) -> &'static str {
        ""
    }

    /// The names its settings table may have at the top level of a study file, the first the
    /// usual one (none: the kind has no table).
    fn table_names(&self) -> &'static [&'static str] {
        &[]
    }

    /// Its settings table parsed out of the study file's `text` (the rest of the file is
    /// ignored here), with defaults filled in, as JSON; null when the file has none. Errors
    /// name the line.
    fn parse_table(&self, _text: &str) -> Result<serde_json::Value, toml::de::Error> {
        Ok(serde_json::Value::Null)
    }

    /// The kind's settings table as hashed into every run's hash (null when it has none).
    fn settings_json(&self, file: &StudyFile) -> serde_json::Value {
        file.tables
            .get(self.name())
            .cloned()
            .unwrap_or(serde_json::Value::Null)
    }

    /// Checks of the kind's settings table (`bad` makes the error for a key).
    fn check(
        &self,
        _: &StudyFile,
        _: &Context,
        _: &dyn Fn(&str, String) -> StudyError,
    ) -> Result<(), StudyError> {
        Ok(())
    }

    /// The `[quick]` keys the kind reads (besides `set`, which every kind applies).
    fn quick_keys(&self) -> &'static [&'static str] {
        &[]
    }

    /// Its `[quick]` keys parsed out of the study file's `text` (the rest is ignored here) as a
    /// JSON object, null where the file does not set them. Errors name the line.
    fn parse_quick(
        &self,
        _text: &str,
    ) -> Result<serde_json::Map<String, serde_json::Value>, toml::de::Error> {
        Ok(serde_json::Map::new())
    }

    /// Checks of the values of its `[quick]` keys, for every study whatever its kind and
    /// whether or not `--quick` is given, so a study file is valid or not.
    fn check_quick_values(
        &self,
        _: &StudyFile,
        _: &dyn Fn(&str, String) -> StudyError,
    ) -> Result<(), StudyError> {
        Ok(())
    }

    /// Checks of `[quick]` when this kind measures the study, whether or not `--quick` is
    /// given (a key another kind reads that this one refuses).
    fn check_quick(&self, _: &StudyFile, _: &Context) -> Result<(), StudyError> {
        Ok(())
    }

    /// `[quick]` applied to the kind's own settings table. Called for every registered kind
    /// in quick mode, whatever the study's kind, since meta.json records every table as
    /// resolved.
    fn quick_table(&self, _: &mut StudyFile, _: &Context) -> Result<(), StudyError> {
        Ok(())
    }

    /// In quick mode, what the kind drops from each method's axes.
    fn quick_axes(&self, _: &StudyFile, _: &mut [Vec<Axis>]) {}

    /// Adapt one run's resolved scene to the kind (`quick` applies `[quick]`); `axes` are the
    /// grid axes, for error lines.
    fn configure(
        &self,
        _ctx: &Context,
        _file: &StudyFile,
        _config: &mut SceneConfig,
        _axes: &[Axis],
        _quick: bool,
    ) -> Result<(), StudyError> {
        Ok(())
    }

    /// Scene keys the kind decides for every run itself (see [`OwnKey`]): loading refuses a
    /// grid over one, and a `[set]` of one it replaces.
    fn own_keys(&self) -> &'static [OwnKey] {
        &[]
    }

    /// The horizon every run covers whatever the scene's `run.steps` says, with how its
    /// steps follow from it (`"horizon / dt steps of each run.dt of the dt ladder"`): a scene
    /// whose own horizon differs gets a warning saying so. `None`: the kind runs the scene's.
    fn horizon(&self, _: &StudyFile) -> Option<(f64, &'static str)> {
        None
    }

    /// Roughly how many steps one run takes (its trials together, for a stability search):
    /// the cost estimate that balances `--shard` (only ratios between runs matter).
    fn estimated_steps(&self, _: &StudyFile, config: &SceneConfig) -> f64 {
        config.run.steps as f64
    }

    /// Scene files or folders the kind adds to the study's `scenes` (relative to the study
    /// file), e.g. the suite's private problem folders.
    fn extra_scenes(&self, _: &StudyFile) -> Vec<String> {
        Vec::new()
    }

    /// Whether a scene the study names takes part (`quick`: in quick mode).
    fn keeps_scene(&self, _: &StudyFile, _scene: &str, _quick: bool) -> bool {
        true
    }

    /// Methods the kind runs besides the study's `[[methods]]` entries, each with its default
    /// settings (the suite's `methods = "all"`: every registered method).
    fn extra_methods(&self, _: &StudyFile) -> Vec<softbench_core::integrate::Method> {
        Vec::new()
    }

    /// What the kind's settings leave out of the study on purpose (the suite's `omit`), for
    /// the omissions list.
    fn declared_omissions(&self, _: &StudyFile) -> Vec<crate::study::vocabulary::spec::Omission> {
        Vec::new()
    }

    /// The cut-off levels of the kind's runs, loosest first (a suite's; empty for others).
    fn levels(&self, _: &StudyFile) -> Vec<String> {
        Vec::new()
    }

    /// Whether a run that cannot run its scene (the method refuses the model, or an optional
    /// scene's data is missing) is left out of the study with the reason (see
    /// [`Study::omitted`]) instead of failing the load.
    fn leaves_out_what_cannot_run(&self) -> bool {
        false
    }
}

/// A scene key a kind decides for its runs (see [`Kind::own_keys`]). A grid over it would
/// only repeat one run under several ids; a value the study's `[set]` gives one the kind
/// replaces would be dropped without a word.
#[derive(Clone, Copy, Debug)]
pub(in crate::study) struct OwnKey {
    /// The dotted scene key (`run.dt`); its sub-keys are covered too.
    pub key: &'static str,
    /// What decides it instead, for the message: "the search chooses each trial's step".
    pub why: &'static str,
    /// Whether the kind replaces the value (so `[set]` of it is refused too), rather than
    /// leaving it unused (a scene needs `run.steps` even where the kind ignores it, so
    /// `[set]` may give it).
    pub replaced: bool,
}

/// The `[quick]` keys of a kind's `Q` (a struct of `Option`s named as the keys) parsed out of a
/// study file's text: what `Kind::parse_quick` returns.
pub(in crate::study) fn parse_quick<Q>(
    text: &str,
) -> Result<serde_json::Map<String, serde_json::Value>, toml::de::Error>
where
    Q: serde::de::DeserializeOwned + serde::Serialize + Default,
{
    #[derive(serde::Deserialize)]
    #[serde(bound = "Q: serde::de::DeserializeOwned")]
    struct File<Q> {
        #[serde(default = "Option::default")]
        quick: Option<Q>,
    }
    let file: File<Q> = toml::from_str(text)?;
    Ok(match serde_json::to_value(file.quick.unwrap_or_default()) {
        Ok(serde_json::Value::Object(keys)) => keys,
        _ => serde_json::Map::new(),
    })
}
