//! Loading a study: parse the file, resolve its scenes, expand the grid into runs and check
//! every run's scene before anything is run or written.

use super::config::{METHOD_KEY, SOLVER_KEY, StudyFile, StudyKind, line_of};
use super::context::Context;
use super::error::StudyError;
use super::grid::{Axis, grid_axes, method_entries, product};
use super::identity::{physics_hash, run_hash, sanitize, value_text};
use super::settings::check_settings;
use super::spec::{RunSpec, Study};
use crate::data::DataPaths;
use crate::integrate::Method;
use crate::parallel::Parallelism;
use crate::scene::{self, LoadedScene, SceneConfig, SceneError};
use crate::solve::LinearSolverKind;
use std::collections::{BTreeSet, HashMap};
use std::path::{Path, PathBuf};
use toml::Value;

/// A scene named by the study, before the grid.
struct SceneSource {
    name: String,
    path: PathBuf,
    /// The scene file's text (for error lines); `None` for inline scenes.
    text: Option<String>,
    table: toml::Table,
    /// Where the study names it.
    line: usize,
}

/// Longest run id (a file name, with `-trials.csv` appended, must stay under 255 bytes).
const MAX_RUN_ID: usize = 200;

/// Read, expand and check a study. `quick` applies its `[quick]` settings; the scenes' data
/// files are found through `data`.
pub fn load(path: &Path, quick: bool, data: &DataPaths) -> Result<Study, StudyError> {
    let text = scene::read_config_text(path).map_err(|error| StudyError::Io {
        path: path.to_owned(),
        error,
    })?;
    let file: StudyFile = toml::from_str(&text).map_err(|e| StudyError::Parse {
        path: path.to_owned(),
        message: crate::quote::clip_source(e.to_string().trim_end()),
    })?;
    let ctx = Context { path, text: &text };
    let kind = check_settings(&file, &ctx)?;
    let mut file = file;
    let spec = super::kinds::spec(kind);
    (spec.check_quick)(&file, &ctx)?;
    if quick {
        // The kinds' tables as `[quick]` resolves them, whatever the kind (meta.json records
        // both tables as resolved).
        super::stability::quick_table(&mut file, &ctx)?;
        super::work_precision::quick_table(&mut file);
    }
    let file = file;
    let scenes = scene_sources(&file, &ctx)?;
    let axes = grid_axes(&file, &ctx)?;
    let mut method_axes = method_entries(&file, &ctx, &axes)?;
    if quick {
        (spec.quick_axes)(&file, &mut method_axes);
    }
    let mut parameters: Vec<String> = Vec::new();
    let mut distinct: HashMap<String, BTreeSet<String>> = HashMap::new();
    for entry in &method_axes {
        for axis in entry {
            if axis.key != METHOD_KEY && axis.key != SOLVER_KEY && !parameters.contains(&axis.key) {
                parameters.push(axis.key.clone());
            }
            let set = distinct.entry(axis.key.clone()).or_default();
            set.extend(axis.values.iter().map(|v| v.to_string()));
        }
    }
    // A key that some `[[methods]]` entries set and others do not tells their runs apart
    // even with one value, so it goes into the run ids.
    for (key, set) in distinct.iter_mut() {
        if method_axes
            .iter()
            .any(|entry| !entry.iter().any(|a| &a.key == key))
        {
            set.insert(String::new());
        }
    }
    let in_id: Vec<&String> = parameters
        .iter()
        .filter(|k| distinct.get(*k).is_some_and(|s| s.len() > 1))
        .collect();

    // Bound the grid before expanding it: each run is a resolved and validated scene.
    let size = method_axes.iter().try_fold(0usize, |acc, entry| {
        let counts: Vec<usize> = entry.iter().map(|a| a.values.len()).collect();
        crate::limits::product(&counts)?.checked_add(acc)
    });
    crate::limits::RUNS
        .check_usize(size.and_then(|s| s.checked_mul(scenes.len())))
        .map_err(|e| ctx.invalid(0, "grid", e.to_string()))?;

    let mut runs: Vec<RunSpec> = Vec::new();
    let mut seen = BTreeSet::new();
    for source in &scenes {
        for entry in &method_axes {
            for combo in product(entry) {
                let Some(run) = resolve_run(&ctx, &file, quick, kind, source, &combo, entry)?
                else {
                    continue;
                };
                let mut id = vec![source.name.clone(), run.0.name().to_owned()];
                if let Some(solver) = run.1 {
                    id.push(solver.name().to_owned());
                }
                for key in &in_id {
                    if let Some((_, v)) = combo.iter().find(|(k, _)| k == *key) {
                        let short = key.rsplit('.').next().unwrap_or(key);
                        id.push(format!("{short}={}", value_text(v)));
                    }
                }
                let id = sanitize(&id.join("-"));
                if id.len() > MAX_RUN_ID {
                    return Err(StudyError::Invalid {
                        path: path.to_owned(),
                        line: source.line,
                        key: "scenes".into(),
                        message: format!(
                            "run id `{}...` is {} characters long; at most {MAX_RUN_ID} (it \
                             names the run's series file): use a shorter scene name",
                            id.chars().take(40).collect::<String>(),
                            id.len()
                        ),
                    });
                }
                let (method, linear_solver, loaded) = run;
                let hash = run_hash(&loaded.config, &file, kind, quick);
                // The same run twice (an entry repeated) is run once; two different runs
                // under one id would overwrite each other's series, so that is an error.
                if !seen.insert(id.clone()) {
                    if runs.iter().any(|r| r.id == id && r.hash == hash) {
                        continue;
                    }
                    return Err(StudyError::Invalid {
                        path: path.to_owned(),
                        line: source.line,
                        key: "methods".into(),
                        message: format!(
                            "two different runs get the id `{id}`: give the settings that tell \
                             them apart as grid or [[methods]] values"
                        ),
                    });
                }
                let parameters = parameters
                    .iter()
                    .map(|p| combo.iter().find(|(k, _)| k == p).map(|(_, v)| v.clone()))
                    .collect();
                let physics = physics_hash(&loaded.config);
                runs.push(RunSpec {
                    id,
                    scene: source.name.clone(),
                    method,
                    linear_solver,
                    parameters,
                    loaded,
                    hash,
                    physics,
                    dofs: 0,
                    data: data.clone(),
                });
            }
        }
    }
    check_scenes_build(&mut runs, &scenes, &ctx, data)?;
    Ok(Study {
        path: path.to_owned(),
        file,
        kind,
        quick,
        text: text.clone(),
        parameters,
        runs,
    })
}

/// The scenes the study names, read and parsed (not yet validated: the grid may complete them).
fn scene_sources(file: &StudyFile, ctx: &Context) -> Result<Vec<SceneSource>, StudyError> {
    if file.scenes.is_empty() {
        return Err(ctx.invalid(0, "scenes", "name at least one scene file"));
    }
    let base = ctx.path.parent().unwrap_or(Path::new("."));
    let mut sources: Vec<SceneSource> = Vec::new();
    for (i, entry) in file.scenes.iter().enumerate() {
        let at = entry.span().start;
        let key = format!("scenes[{i}]");
        let scene_error = |error| StudyError::Scene {
            path: ctx.path.to_owned(),
            line: line_of(ctx.text, at),
            key: key.clone(),
            error: Box::new(error),
        };
        let source = match entry.get_ref() {
            Value::String(rel) => {
                let path = base.join(rel);
                let text = scene::read_config_text(&path).map_err(|error| {
                    scene_error(SceneError::Io {
                        path: path.clone(),
                        error,
                    })
                })?;
                let table = scene::parse_text(&text, &path).map_err(scene_error)?;
                let name = table
                    .get("name")
                    .and_then(Value::as_str)
                    .map(str::to_owned)
                    .unwrap_or_else(|| {
                        path.file_stem()
                            .map_or("scene".into(), |s| s.to_string_lossy().into_owned())
                    });
                SceneSource {
                    name,
                    path,
                    text: Some(text),
                    table,
                    line: line_of(ctx.text, at),
                }
            }
            Value::Table(table) => SceneSource {
                name: table
                    .get("name")
                    .and_then(Value::as_str)
                    .map_or_else(|| format!("scene{i}"), str::to_owned),
                path: ctx.path.to_owned(),
                text: None,
                table: table.clone(),
                line: line_of(ctx.text, at),
            },
            other => {
                return Err(ctx.invalid(
                    at,
                    &key,
                    format!(
                        "expected a scene file path or an inline scene table, found {}",
                        other.type_str()
                    ),
                ));
            }
        };
        if sources.iter().any(|s| s.name == source.name) {
            return Err(ctx.invalid(
                at,
                &key,
                format!(
                    "two scenes are named `{}`; give one a different `name`",
                    source.name
                ),
            ));
        }
        sources.push(source);
    }
    Ok(sources)
}

type ResolvedRun = (Method, Option<LinearSolverKind>, LoadedScene);

/// The resolved scene of one combination, or `None` when the combination makes no sense
/// (a second linear solver or Newton setting for an explicit method).
fn resolve_run(
    ctx: &Context,
    file: &StudyFile,
    quick: bool,
    kind: StudyKind,
    source: &SceneSource,
    combo: &[(String, Value)],
    axes: &[Axis],
) -> Result<Option<ResolvedRun>, StudyError> {
    let assignments: Vec<(&str, &Value, usize)> = file
        .set
        .iter()
        .map(|(k, v)| (k.as_str(), v.get_ref(), line_of(ctx.text, v.span().start)))
        .chain(combo.iter().map(|(k, v)| {
            let line = axes.iter().find(|a| &a.key == k).map_or(1, |a| a.line);
            (k.as_str(), v, line)
        }))
        .collect();
    let config = match configure(source, &assignments, file, quick) {
        Ok(c) => c,
        Err(error) => {
            // Find the assignment at fault: the first that fails on its own.
            for (key, value, line) in &assignments {
                if let Err(e) = configure(source, &[(key, value, *line)], file, false) {
                    return Err(StudyError::Scene {
                        path: ctx.path.to_owned(),
                        line: *line,
                        key: format!("\"{key}\" = {value}"),
                        error: Box::new(e),
                    });
                }
            }
            return Err(StudyError::Scene {
                path: ctx.path.to_owned(),
                line: source.line,
                key: format!("scene `{}`", source.name),
                error: Box::new(error),
            });
        }
    };
    let mut config = config;
    (super::kinds::spec(kind).configure)(ctx, file, &mut config, axes, quick)?;
    let method = config.integrator.method;
    if method.is_explicit() {
        // An explicit method runs once whatever the implicit-only settings are.
        for axis in axes {
            let implicit_only = axis.key == SOLVER_KEY
                || axis.key.starts_with("integrator.newton")
                || axis.key.starts_with("integrator.solver");
            if implicit_only
                && let Some((_, v)) = combo.iter().find(|(k, _)| *k == axis.key)
                && *v != axis.values[0]
            {
                return Ok(None);
            }
        }
    }
    let linear_solver = method
        .uses_linear_solver()
        .then_some(config.integrator.linear_solver);
    Ok(Some((
        method,
        linear_solver,
        LoadedScene {
            path: source.path.clone(),
            config,
        },
    )))
}

/// The scene's table with the assignments (and quick settings) applied, validated.
fn configure(
    source: &SceneSource,
    assignments: &[(&str, &Value, usize)],
    file: &StudyFile,
    quick: bool,
) -> Result<SceneConfig, SceneError> {
    let mut table = source.table.clone();
    for (key, value, _) in assignments {
        scene::set_value(&mut table, key, (*value).clone())?;
    }
    if quick {
        for (key, value) in &file.quick.set {
            scene::set_value(&mut table, key, value.clone())?;
        }
    }
    scene::from_table(table, source.text.as_deref(), &source.path)
}

/// Build each distinct scene once, so a missing mesh file or a bad mesh is reported before
/// anything runs; record each run's free degrees of freedom. A run's pictures show the
/// scene's `[display]` mesh, which each run reads and skins itself: here it is only found.
fn check_scenes_build(
    runs: &mut [RunSpec],
    scenes: &[SceneSource],
    ctx: &Context,
    data: &DataPaths,
) -> Result<(), StudyError> {
    let mut built: HashMap<u64, usize> = HashMap::new();
    for run in runs.iter_mut() {
        if let Some(&dofs) = built.get(&run.physics) {
            run.dofs = dofs;
            continue;
        }
        match scene::build(&run.loaded, data, Parallelism::Sequential) {
            Ok(scene) => {
                run.dofs = scene.model.num_dofs();
                built.insert(run.physics, run.dofs);
            }
            Err(error) => {
                return Err(StudyError::Scene {
                    path: ctx.path.to_owned(),
                    line: scene_line(scenes, run),
                    key: format!("scene `{}` (run {})", run.scene, run.id),
                    error: Box::new(error),
                });
            }
        }
        if let Some(display) = &run.loaded.config.display
            && let Err(error) = data.resolve(&display.file, Some(run.loaded.base_dir()))
        {
            return Err(StudyError::Invalid {
                path: ctx.path.to_owned(),
                line: scene_line(scenes, run),
                key: format!("scene `{}` (run {}): display.file", run.scene, run.id),
                message: error.to_string(),
            });
        }
    }
    Ok(())
}

/// The line of the study that names `run`'s scene.
fn scene_line(scenes: &[SceneSource], run: &RunSpec) -> usize {
    scenes
        .iter()
        .find(|s| s.name == run.scene)
        .map_or(1, |s| s.line)
}
