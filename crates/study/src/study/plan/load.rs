//! Loading a study: parse the file, resolve its scenes, expand the grid into runs and check
//! every run's scene before anything is run or written.

use crate::study::plan::peer_blocks::take_peer_blocks;
use crate::study::vocabulary::config::{
    METHOD_KEY, SOLVER_KEY, STUDY_KEYS, SWEEP, StudyFile, line_of,
};
use crate::study::vocabulary::context::Context;
use crate::study::vocabulary::error::StudyError;
use crate::study::vocabulary::grid::{Axis, grid_axes, method_entries, product};
use crate::study::vocabulary::identity::{physics_hash, run_hash, sanitize, value_text};
use crate::study::vocabulary::spec::{Omission, RunSpec, Study};
use softbench_core::integrate::Method;
use softbench_core::parallel::Parallelism;
use softbench_core::solve::LinearSolverKind;
use softbench_run::data::DataPaths;
use softbench_run::scene::{self, LoadedScene, SceneConfig, SceneError};
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

/// Longest run id (a file name, with `-iterations.csv` appended, must stay under 255 bytes).
const MAX_RUN_ID: usize = 200;

/// Read, expand and check a study. `quick` applies its `[quick]` settings; the scenes' data
/// files are found through `data`.
pub fn load(path: &Path, quick: bool, data: &DataPaths) -> Result<Study, StudyError> {
    let text = scene::read_config_text(path).map_err(|error| StudyError::Io {
        path: path.to_owned(),
        error,
    })?;
    let ctx = Context { path, text: &text };
    let (file, kind, unregistered_peers) = read_file(&ctx, quick)?;
    let measured_by = crate::study::kinds::plan(kind);
    let scenes: Vec<SceneSource> = scene_sources(&file, &ctx, &measured_by.extra_scenes(&file))?
        .into_iter()
        .filter(|s| measured_by.keeps_scene(&file, &s.name, quick))
        .collect();
    if scenes.is_empty() {
        return Err(ctx.invalid(0, "scenes", "no scene is left to run"));
    }
    let warnings = crate::study::plan::own_keys::horizon_warnings(
        measured_by,
        &file,
        scenes.iter().map(|s| (s.name.as_str(), &s.table)),
    );
    let axes = grid_axes(&file, &ctx)?;
    let mut method_axes = method_entries(&file, &ctx, &axes, &measured_by.extra_methods(&file))?;
    if quick {
        measured_by.quick_axes(&file, &mut method_axes);
    }
    let (parameters, in_id) = parameters(&method_axes);
    // Bound the grid before expanding it: each run is a resolved and validated scene.
    let size = method_axes.iter().try_fold(0usize, |acc, entry| {
        let counts: Vec<usize> = entry.iter().map(|a| a.values.len()).collect();
        softbench_core::limits::product(&counts)?.checked_add(acc)
    });
    softbench_core::limits::RUNS
        .check_usize(size.and_then(|s| s.checked_mul(scenes.len())))
        .map_err(|e| ctx.invalid(0, "grid", e.to_string()))?;
    let grid = Grid {
        ctx: &ctx,
        file: &file,
        quick,
        kind,
        data,
        scenes: &scenes,
        method_axes: &method_axes,
        parameters: &parameters,
        in_id: &in_id,
    };
    let mut runs = grid.expand()?;
    let mut omitted = measured_by.declared_omissions(&file);
    omitted.extend(unregistered_peers);
    omitted.extend(check_scenes_build(
        &mut runs,
        &scenes,
        &ctx,
        data,
        leaves_out(&file, measured_by),
    )?);
    let levels = measured_by.levels(&file);
    let study = Study {
        path: path.to_owned(),
        file,
        kind,
        kind_columns: crate::study::kinds::measure(kind).columns(),
        quick,
        text: text.clone(),
        parameters,
        runs,
        levels,
        omitted,
        warnings,
    };
    check_reference_steps(&study, &ctx)?;
    Ok(study)
}

/// Whether runs whose method cannot run their scene are left out (the kind always does, or
/// the file asks to) rather than refused.
fn leaves_out(file: &StudyFile, kind: &dyn crate::study::kind::Plan) -> bool {
    file.leave_out_what_cannot_run || kind.leaves_out_what_cannot_run()
}

/// The study file parsed and checked, with every kind's settings table and `[quick]` keys
/// (whatever the study's kind: meta.json records every table as resolved), resolved by
/// `[quick]` in quick mode; and the kind that measures it.
fn read_file(
    ctx: &Context,
    quick: bool,
) -> Result<(StudyFile, &'static str, Vec<Omission>), StudyError> {
    let parse_error = |e: toml::de::Error| StudyError::Parse {
        path: ctx.path.to_owned(),
        message: softbench_core::quote::clip_source(e.to_string().trim_end()),
    };
    let mut file: StudyFile = toml::from_str(ctx.text).map_err(parse_error)?;
    check_keys(ctx.text, ctx)?;
    let unregistered_peers = take_peer_blocks(&mut file, ctx)?;
    for k in crate::study::kinds::planning() {
        if !k.table_names().is_empty() {
            let table = k.parse_table(ctx.text).map_err(parse_error)?;
            file.tables.insert(k.name(), table);
        }
        let quick = k.parse_quick(ctx.text).map_err(parse_error)?;
        file.quick.keys.extend(quick);
    }
    let kind = check_settings(&file, ctx)?;
    let measured_by = crate::study::kinds::plan(kind);
    measured_by.check_quick(&file, ctx)?;
    crate::study::plan::own_keys::check(&file, ctx, measured_by)?;
    if quick {
        for k in crate::study::kinds::planning() {
            k.quick_table(&mut file, ctx)?;
        }
    }
    Ok((file, kind, unregistered_peers))
}

/// The parameter columns of the grid (every key an axis varies but the method and the
/// solver, in order of appearance) and those that go into the run ids (more than one value).
fn parameters(method_axes: &[Vec<Axis>]) -> (Vec<String>, Vec<String>) {
    let mut parameters: Vec<String> = Vec::new();
    let mut distinct: HashMap<String, BTreeSet<String>> = HashMap::new();
    for entry in method_axes {
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
    let in_id = parameters
        .iter()
        .filter(|k| distinct.get(*k).is_some_and(|s| s.len() > 1))
        .cloned()
        .collect();
    (parameters, in_id)
}

/// A study's grid, checked and bounded, ready to expand into runs.
struct Grid<'a> {
    ctx: &'a Context<'a>,
    file: &'a StudyFile,
    quick: bool,
    kind: &'static str,
    data: &'a DataPaths,
    scenes: &'a [SceneSource],
    /// Each `[[methods]]` entry's axes.
    method_axes: &'a [Vec<Axis>],
    /// The parameter columns, and those that go into the run ids.
    parameters: &'a [String],
    in_id: &'a [String],
}

impl Grid<'_> {
    /// Every run of the grid: each scene by each entry's combinations, resolved, named and
    /// hashed; a run repeated by two entries once.
    fn expand(&self) -> Result<Vec<RunSpec>, StudyError> {
        let measured_by = crate::study::kinds::plan(self.kind);
        let mut runs: Vec<RunSpec> = Vec::new();
        let mut seen = BTreeSet::new();
        for source in self.scenes {
            for entry in self.method_axes {
                for combo in product(entry) {
                    stop_if_requested()?;
                    let Some((method, linear_solver, loaded)) = resolve_run(
                        self.ctx, self.file, self.quick, self.kind, source, &combo, entry,
                    )?
                    else {
                        continue;
                    };
                    let id = self.run_id(source, method, linear_solver, &combo)?;
                    let hash = run_hash(
                        &loaded.config,
                        self.kind,
                        measured_by.settings_json(self.file),
                        self.quick.then_some(&self.file.quick),
                    );
                    // The same run twice (an entry repeated) is run once; two different runs
                    // under one id would overwrite each other's series, so that is an error.
                    if !seen.insert(id.clone()) {
                        if runs.iter().any(|r| r.id == id && r.hash == hash) {
                            continue;
                        }
                        return Err(StudyError::Invalid {
                            path: self.ctx.path.to_owned(),
                            line: source.line,
                            key: "methods".into(),
                            message: format!(
                                "two different runs get the id `{id}`: give the settings that \
                                 tell them apart as grid or [[methods]] values"
                            ),
                        });
                    }
                    let parameters = self
                        .parameters
                        .iter()
                        .map(|p| combo.iter().find(|(k, _)| k == p).map(|(_, v)| v.clone()))
                        .collect();
                    let physics = physics_hash(&loaded.config);
                    let estimated_steps = measured_by.estimated_steps(self.file, &loaded.config);
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
                        estimated_steps,
                        data: self.data.clone(),
                    });
                }
            }
        }
        Ok(runs)
    }

    /// A run's id: its scene, method, solver and the values of the parameters that tell runs
    /// apart, made safe as a file name and at most [`MAX_RUN_ID`] long.
    fn run_id(
        &self,
        source: &SceneSource,
        method: Method,
        linear_solver: Option<LinearSolverKind>,
        combo: &[(String, toml::Value)],
    ) -> Result<String, StudyError> {
        let mut id = vec![source.name.clone(), method.name().to_owned()];
        if let Some(solver) = linear_solver {
            id.push(solver.name().to_owned());
        }
        for key in self.in_id {
            if let Some((_, v)) = combo.iter().find(|(k, _)| k == key) {
                let short = key.rsplit('.').next().unwrap_or(key);
                id.push(format!("{short}={}", value_text(v)));
            }
        }
        let id = sanitize(&id.join("-"));
        if id.len() > MAX_RUN_ID {
            return Err(StudyError::Invalid {
                path: self.ctx.path.to_owned(),
                line: source.line,
                key: "scenes".into(),
                message: format!(
                    "run id `{}...` is {} characters long; at most {MAX_RUN_ID} (it names the \
                     run's series file): use a shorter scene name",
                    id.chars().take(40).collect::<String>(),
                    id.len()
                ),
            });
        }
        Ok(id)
    }
}

/// Stop loading if a signal has arrived (loading a large grid or its meshes takes a while).
fn stop_if_requested() -> Result<(), StudyError> {
    softbench_core::interrupt::requested().map_or(Ok(()), |s| Err(StudyError::Interrupted(s)))
}

/// Every reference solution the study will compute fits the step budget (checked here, before
/// any work, rather than when a reference of 10^10 steps has started).
fn check_reference_steps(study: &Study, ctx: &Context) -> Result<(), StudyError> {
    let kind = crate::study::kinds::measure(study.kind);
    let table = crate::study::kinds::plan(study.kind)
        .table_names()
        .first()
        .copied()
        .unwrap_or("reference");
    for spec in &study.runs {
        stop_if_requested()?;
        let Some(w) = kind.reference_settings(&study.file, spec) else {
            continue;
        };
        let dt = kind.reference_dt(study, &w, spec);
        let halved = !w.reference.same_dt;
        if let Err(e) = crate::study::vocabulary::settings::check_steps(w.horizon, dt, halved) {
            let key = if w.reference.dt.is_some() {
                format!("{table}.reference.dt")
            } else {
                format!("{table}.reference.dt_factor")
            };
            return Err(ctx.invalid(
                0,
                &key,
                format!(
                    "the reference of scene `{}` steps {dt:e} s{} over the {} s horizon: {e}",
                    spec.scene,
                    if halved { " and half that" } else { "" },
                    w.horizon
                ),
            ));
        }
        if let Some(i) = &w.reference.independent
            && let Err(e) = crate::study::vocabulary::settings::check_steps(w.horizon, i.dt, false)
        {
            return Err(ctx.invalid(
                0,
                &format!("{table}.reference.independent.dt"),
                format!(
                    "the independent solution of scene `{}` steps {:e} s over the {} s \
                     horizon: {e}",
                    spec.scene, i.dt, w.horizon
                ),
            ));
        }
    }
    Ok(())
}

/// The scenes the study names, read and parsed (not yet validated: the grid may complete
/// them). A path that names a folder stands for every `*.toml` file in it, by file name;
/// `extra` (the kind's own, relative to the study file) come after the study's.
fn scene_sources(
    file: &StudyFile,
    ctx: &Context,
    extra: &[String],
) -> Result<Vec<SceneSource>, StudyError> {
    if file.scenes.is_empty() && extra.is_empty() {
        return Err(ctx.invalid(0, "scenes", "name at least one scene file"));
    }
    let base = ctx.path.parent().unwrap_or(Path::new("."));
    let mut sources: Vec<SceneSource> = Vec::new();
    let named = file
        .scenes
        .iter()
        .enumerate()
        .map(|(i, e)| (format!("scenes[{i}]"), e.span().start, e.get_ref().clone()));
    let added = extra.iter().enumerate().map(|(i, p)| {
        (
            format!("{} scene folder {i}", ctx.path.display()),
            0,
            Value::String(p.clone()),
        )
    });
    for (key, at, entry) in named.chain(added) {
        let line = line_of(ctx.text, at);
        let scene_error = |error| StudyError::Scene {
            path: ctx.path.to_owned(),
            line,
            key: key.clone(),
            error: Box::new(error),
        };
        let mut found = Vec::new();
        match entry {
            Value::String(rel) => {
                let path = base.join(&rel);
                let files = if path.is_dir() {
                    let files = toml_files(&path).map_err(|error| {
                        scene_error(SceneError::Io {
                            path: path.clone(),
                            error,
                        })
                    })?;
                    if files.is_empty() {
                        return Err(ctx.invalid(
                            at,
                            &key,
                            format!("the folder {} holds no .toml scene file", path.display()),
                        ));
                    }
                    files
                } else {
                    vec![path]
                };
                for path in files {
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
                    found.push(SceneSource {
                        name,
                        path,
                        text: Some(text),
                        table,
                        line,
                    });
                }
            }
            Value::Table(table) => found.push(SceneSource {
                name: table
                    .get("name")
                    .and_then(Value::as_str)
                    .map_or_else(|| format!("scene{}", sources.len()), str::to_owned),
                path: ctx.path.to_owned(),
                text: None,
                table: table.clone(),
                line,
            }),
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
        }
        for source in found {
            if let Some(first) = sources.iter().find(|s| s.name == source.name) {
                return Err(ctx.invalid(
                    at,
                    &key,
                    format!(
                        "two scenes are named `{}` ({} and {}); give one a different `name`",
                        source.name,
                        first.path.display(),
                        source.path.display()
                    ),
                ));
            }
            sources.push(source);
        }
    }
    Ok(sources)
}

/// The `*.toml` files of a folder, sorted by file name.
fn toml_files(folder: &Path) -> std::io::Result<Vec<PathBuf>> {
    let mut files: Vec<PathBuf> = std::fs::read_dir(folder)?
        .map(|e| e.map(|e| e.path()))
        .collect::<std::io::Result<Vec<_>>>()?
        .into_iter()
        .filter(|p| p.is_file() && p.extension().is_some_and(|e| e == "toml"))
        .collect();
    files.sort();
    Ok(files)
}

type ResolvedRun = (Method, Option<LinearSolverKind>, LoadedScene);

/// The resolved scene of one combination, or `None` when the combination makes no sense
/// (a second linear solver or Newton setting for an explicit method).
fn resolve_run(
    ctx: &Context,
    file: &StudyFile,
    quick: bool,
    kind: &'static str,
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
    // A kind that leaves out what a method cannot run learns a peer's refusals when the
    // scenes are built (`check_scenes_build`), as omissions.
    let leave_out = leaves_out(file, crate::study::kinds::plan(kind));
    let config = match configure(source, &assignments, file, quick, leave_out) {
        Ok(c) => c,
        Err(error) => {
            // Find the assignment at fault: the first that fails on its own.
            for (key, value, line) in &assignments {
                if let Err(e) = configure(source, &[(key, value, *line)], file, false, leave_out) {
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
    crate::study::kinds::plan(kind).configure(ctx, file, &mut config, axes, quick)?;
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
    leave_out: bool,
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
    if leave_out {
        scene::from_table_leaving_refusals(table, source.text.as_deref(), &source.path)
    } else {
        scene::from_table(table, source.text.as_deref(), &source.path)
    }
}

/// Build each distinct scene once, so a missing mesh file or a bad mesh is reported before
/// anything runs; record each run's free degrees of freedom. A run's pictures show the
/// scene's `[display]` mesh, which each run reads and skins itself: here it is only found.
///
/// With `leave_out` (see `Kind::leaves_out_what_cannot_run`), each scene is built with the
/// default method and every run's method is asked whether it can run the model: a run whose
/// method refuses it, and every run of an optional problem whose data files are missing, are
/// removed from `runs` and returned with the reason, instead of failing the load.
fn check_scenes_build(
    runs: &mut Vec<RunSpec>,
    scenes: &[SceneSource],
    ctx: &Context,
    data: &DataPaths,
    leave_out: bool,
) -> Result<Vec<Omission>, StudyError> {
    let mut built: HashMap<u64, usize> = HashMap::new();
    let mut omitted: Vec<Omission> = Vec::new();
    // The scene last built with the default method, for the applicability checks.
    let mut current: Option<(u64, scene::Scene)> = None;
    let mut kept = Vec::with_capacity(runs.len());
    for mut run in std::mem::take(runs) {
        stop_if_requested()?;
        if omitted
            .iter()
            .any(|o| o.scene == run.scene && o.method.is_none())
        {
            continue;
        }
        let fail = |run: &RunSpec, error: SceneError| StudyError::Scene {
            path: ctx.path.to_owned(),
            line: scene_line(scenes, run),
            key: format!("scene `{}` (run {})", run.scene, run.id),
            error: Box::new(error),
        };
        if leave_out {
            if current.as_ref().is_none_or(|(p, _)| *p != run.physics) {
                let mut loaded = run.loaded.clone();
                loaded.config.integrator = Default::default();
                match scene::build(&loaded, data, Parallelism::Sequential) {
                    Ok(scene) => current = Some((run.physics, scene)),
                    Err(error @ (SceneError::Data { .. } | SceneError::InitialData { .. }))
                        if run
                            .loaded
                            .config
                            .problem
                            .as_ref()
                            .is_some_and(|p| p.optional.is_some()) =>
                    {
                        let why = run
                            .loaded
                            .config
                            .problem
                            .as_ref()
                            .and_then(|p| p.optional.clone());
                        omitted.push(Omission {
                            scene: run.scene.clone(),
                            method: None,
                            reason: format!("{}: {error}", why.unwrap_or_default())
                                .replace('\n', " "),
                        });
                        current = None;
                        continue;
                    }
                    Err(error) => return Err(fail(&run, error)),
                }
            }
            let (_, scene) = current.as_ref().expect("built above");
            if let Err(reason) = scene::applicable(&run.loaded.config, scene) {
                // One line per method and scene, whatever its settings.
                let method = Some(run.method.name().to_owned());
                if !omitted
                    .iter()
                    .any(|o| o.scene == run.scene && o.method == method)
                {
                    omitted.push(Omission {
                        scene: run.scene.clone(),
                        method,
                        reason,
                    });
                }
                continue;
            }
            run.dofs = scene.model.num_dofs();
            built.insert(run.physics, run.dofs);
        } else if let Some(&dofs) = built.get(&run.physics) {
            run.dofs = dofs;
        } else {
            match scene::build(&run.loaded, data, Parallelism::Sequential) {
                Ok(scene) => {
                    run.dofs = scene.model.num_dofs();
                    built.insert(run.physics, run.dofs);
                }
                Err(error) => return Err(fail(&run, error)),
            }
        }
        if let Some(display) = &run.loaded.config.display
            && let Err(error) = data.resolve(&display.file, Some(run.loaded.base_dir()))
        {
            return Err(StudyError::Invalid {
                path: ctx.path.to_owned(),
                line: scene_line(scenes, &run),
                key: format!("scene `{}` (run {}): display.file", run.scene, run.id),
                message: error.to_string(),
            });
        }
        kept.push(run);
    }
    *runs = kept;
    Ok(omitted)
}

/// Every top-level key of the study file is one of [`STUDY_KEYS`] or a registered kind's
/// table (serde does not refuse the others, since the kinds' tables are not `StudyFile`'s).
fn check_keys(text: &str, ctx: &Context) -> Result<(), StudyError> {
    let top: toml::Table = toml::from_str(text).map_err(|e| StudyError::Parse {
        path: ctx.path.to_owned(),
        message: softbench_core::quote::clip_source(e.to_string().trim_end()),
    })?;
    let mut valid: Vec<&str> = STUDY_KEYS.to_vec();
    for k in crate::study::kinds::planning() {
        valid.extend(k.table_names());
    }
    if let Some(unknown) = top.keys().find(|k| !valid.contains(&k.as_str())) {
        let line = text
            .lines()
            .position(|l| {
                let l = l.trim_start();
                let name = l.trim_start_matches('[').trim_start_matches('"');
                name.starts_with(unknown.as_str())
                    && name[unknown.len()..]
                        .trim_start_matches('"')
                        .trim_start()
                        .starts_with(['=', ']', '.'])
            })
            .map_or(1, |i| i + 1);
        let hint = softbench_core::names::closest(unknown, &valid)
            .map_or(String::new(), |c| format!("; did you mean `{c}`?"));
        return Err(StudyError::Invalid {
            path: ctx.path.to_owned(),
            line,
            key: softbench_core::quote::clip_message(unknown),
            message: format!(
                "unknown field `{}`{hint} (expected one of: {})",
                softbench_core::quote::clip_message(unknown),
                valid.join(", ")
            ),
        });
    }
    if let Some(toml::Value::Table(quick)) = top.get("quick") {
        let mut valid: Vec<&str> = vec!["set"];
        for key in crate::study::kinds::planning().flat_map(|k| k.quick_keys()) {
            if !valid.contains(key) {
                valid.push(key);
            }
        }
        if let Some(unknown) = quick.keys().find(|k| !valid.contains(&k.as_str())) {
            let hint = softbench_core::names::closest(unknown, &valid)
                .map_or(String::new(), |c| format!("; did you mean `{c}`?"));
            let shown = softbench_core::quote::clip_message(unknown);
            return Err(StudyError::Invalid {
                path: ctx.path.to_owned(),
                line: ctx.line_of_key(unknown),
                key: format!("quick.{shown}"),
                message: format!(
                    "unknown field `{shown}`{hint} (expected one of: {})",
                    valid.join(", ")
                ),
            });
        }
    }
    Ok(())
}

/// The registered kind that measures each run (a sweep's inner kind), after checking the
/// study's kind names and that the kind's settings are present and sane.
fn check_settings(file: &StudyFile, ctx: &Context) -> Result<&'static str, StudyError> {
    crate::study::vocabulary::settings::check_name(&file.name)
        .map_err(|m| ctx.invalid(0, "name", m))?;
    let names = crate::study::kinds::names();
    let unknown = |key: &str, line: usize, name: &str, valid: &[&str]| StudyError::Invalid {
        path: ctx.path.to_owned(),
        line,
        key: key.to_owned(),
        message: softbench_core::names::unknown_name_message("study kind", name, valid),
    };
    let study = file.study.get_ref().as_str();
    // The sweep's own table (its kind, parameter and metrics) is about the sweep, not a kind,
    // so it is checked here; the measured kind then checks its own table.
    let kind = if study == SWEEP {
        let Some(sweep) = &file.sweep else {
            return Err(ctx.invalid(
                0,
                "sweep",
                "a sweep study needs a [sweep] table with `kind` and `parameter`",
            ));
        };
        let kind = crate::study::kinds::plan_named(&sweep.kind)
            .ok_or_else(|| unknown("sweep.kind", ctx.line_of_key("kind"), &sweep.kind, &names))?;
        if !file.grid.contains_key(&sweep.parameter)
            && !file
                .methods
                .iter()
                .any(|m| m.get_ref().contains_key(&sweep.parameter))
        {
            return Err(StudyError::Invalid {
                path: ctx.path.to_owned(),
                line: ctx.line_of_key("parameter"),
                key: "sweep.parameter".into(),
                message: format!(
                    "`{}` is not a key of [grid]; the swept parameter must be one",
                    sweep.parameter
                ),
            });
        }
        // A sweep plots its metrics against the parameter: one value is one point.
        let mut values: Vec<&Value> = Vec::new();
        let given = file
            .grid
            .get(&sweep.parameter)
            .map(|v| v.get_ref())
            .into_iter()
            .chain(
                file.methods
                    .iter()
                    .filter_map(|m| m.get_ref().get(&sweep.parameter)),
            );
        for v in given {
            for v in v.as_array().map_or_else(|| vec![v], |a| a.iter().collect()) {
                if !values.contains(&v) {
                    values.push(v);
                }
            }
        }
        if values.len() < 2 {
            return Err(StudyError::Invalid {
                path: ctx.path.to_owned(),
                line: ctx.line_of_key("parameter"),
                key: "sweep.parameter".into(),
                message: format!(
                    "`{}` has {} value{} in the grid; a sweep plots its metrics against the \
                     parameter, so give it at least two",
                    sweep.parameter,
                    values.len(),
                    if values.len() == 1 { "" } else { "s" }
                ),
            });
        }
        let columns = crate::study::kinds::measure(kind.name()).columns();
        if let Some(metric) = sweep
            .metrics
            .iter()
            .find(|m| !columns.contains(&m.as_str()))
        {
            return Err(StudyError::Invalid {
                path: ctx.path.to_owned(),
                line: ctx.line_of_key("metrics"),
                key: "sweep.metrics".into(),
                message: softbench_core::names::unknown_name_message(
                    &format!("{} metric", kind.name()),
                    metric,
                    columns,
                ),
            });
        }
        kind
    } else {
        let kind = crate::study::kinds::plan_named(study).ok_or_else(|| {
            let mut valid = names.clone();
            valid.push(SWEEP);
            unknown(
                "study",
                line_of(ctx.text, file.study.span().start),
                study,
                &valid,
            )
        })?;
        // Only a sweep reads [sweep]: in another study its kind, parameter and metrics
        // would be ignored.
        if file.sweep.is_some() {
            return Err(StudyError::Invalid {
                path: ctx.path.to_owned(),
                line: ctx
                    .text
                    .lines()
                    .position(|l| l.trim() == "[sweep]")
                    .map_or(1, |i| i + 1),
                key: "sweep".into(),
                message: format!(
                    "a [sweep] table is read only by study = \"{SWEEP}\", and this study is \
                     \"{study}\": remove it, or make the study a sweep of `{study}`"
                ),
            });
        }
        kind
    };
    let line = |key: &str| ctx.line_of_key(key);
    let bad = |key: &str, message: String| StudyError::Invalid {
        path: ctx.path.to_owned(),
        line: line(key.rsplit('.').next().unwrap_or(key)),
        key: key.to_owned(),
        message,
    };
    kind.check(file, ctx, &bad)?;
    // Every kind's `[quick]` keys, whatever the study's kind, so a study file is valid or not.
    for k in crate::study::kinds::planning() {
        k.check_quick_values(file, &bad)?;
    }
    Ok(kind.name())
}

/// The line of the study that names `run`'s scene.
fn scene_line(scenes: &[SceneSource], run: &RunSpec) -> usize {
    scenes
        .iter()
        .find(|s| s.name == run.scene)
        .map_or(1, |s| s.line)
}
