//! The command line's arguments: one clap struct per subcommand, with the help texts
//! `softbench --help` prints.

use std::path::PathBuf;

use clap::{Args, Parser, Subcommand};

use softbench_core::mesh::MeshFormat;
use softbench_study::study;

/// A harness for research on time integrators and solvers for deformable bodies.
#[derive(Parser)]
#[command(name = "softbench", version, about)]
pub(super) struct Cli {
    #[command(subcommand)]
    pub(super) command: Command,
}

#[derive(Subcommand)]
pub(super) enum Command {
    /// Report counts, extent, volumes, quality and surface topology of a mesh file.
    #[command(after_help = mesh_formats_help())]
    MeshInfo(MeshInfoArgs),
    /// Run one scene with one integrator; write trajectory.csv (a row every run.sample_every
    /// steps), final_positions.csv and summary.json to the output folder. Exit code 1 when
    /// the run does not complete (it blew up or a solver failed); what it did is written.
    Simulate(SimulateArgs),
    /// Run a study: every run of its grid, then runs.csv, series/, plots, pictures,
    /// report.md and meta.json in <OUT>/<study name>/. Runs already complete with the same
    /// configuration are reused. A run that blows up is a result (runs.csv says how it
    /// ended), not an error.
    Run(RunArgs),
    /// Merge a study run as shards (`run --shard K/N`), or redo the tables of a local run:
    /// runs.csv, plots, report.md and meta.json from the shards' tables; says which runs are
    /// missing (exit code 1 then). The study file the shards ran is loaded again, so it and
    /// its meshes must still be found. Merging again gives the same files.
    Merge(MergeArgs),
    /// Write Slurm job scripts for a study (a job array of shards plus a merge job after
    /// it) into <OUT>/<study name>/slurm/, and with --submit submit them with sbatch. The
    /// jobs get SOFTBENCH_DATA (made absolute) if it is set here.
    Slurm(SlurmArgs),
    /// Redraw the plots of a study's results folder from runs.csv, series/ and meta.json, and
    /// refresh the findings, the plots section and the list of runs that did not finish
    /// cleanly in its report.md (its provenance stays that of the run).
    Plot(PlotArgs),
    /// Performance and data profiles of a work-precision study's results folder: for each
    /// scene and accuracy target, each method's cheapest run that completed within the target,
    /// in wall time and in force + Hessian evaluations; writes profiles.csv, costs.csv,
    /// profiles.md and four charts into <DIR>/profiles/ (or --out).
    Profiles(ProfilesArgs),
    /// Evaluate the claims ledger: every claim file in CLAIMS against the committed results
    /// under --results, each verdict computed by its rule, and write the ledger page (default
    /// <RESULTS>/suite/ledger.md). With --check, write nothing and exit 1 if the page on disk
    /// differs from the computed one.
    Ledger(LedgerArgs),
    /// Draw pictures of the bodies from stored snapshots: for a `simulate --render` folder its
    /// filmstrip.png and animation.gif; for a study folder one panel PNG and one GIF per scene.
    Render(RenderArgs),
    /// List the integrators, linear solvers, materials, contact responses, obstacle kinds,
    /// export and mesh formats (with their facts), the study kinds, and the scenes and studies
    /// in experiments/ (of the current folder, else of the softbench source tree).
    List,
}

#[derive(Args)]
pub(super) struct RunArgs {
    /// Study file (TOML).
    pub(super) study: PathBuf,
    /// Parent folder of the study's results folder.
    #[arg(long, default_value = "results")]
    pub(super) out: PathBuf,
    /// Only the runs whose id contains PATTERN; a PATTERN with `*` (any text) must match the
    /// whole id, e.g. `jello*-rk4`.
    #[arg(long, value_name = "PATTERN")]
    pub(super) only: Option<String>,
    /// Runs to execute in parallel. With more than one, each run's element loops and linear
    /// solvers use one thread; with one, they use rayon's pool (RAYON_NUM_THREADS, else one
    /// thread per core).
    #[arg(long, default_value_t = 1)]
    pub(super) jobs: usize,
    /// Threads of the study's pool, which a run uses when --jobs is 1 (default:
    /// RAYON_NUM_THREADS, else one per core). The results are the same for any count.
    #[arg(long)]
    pub(super) threads: Option<usize>,
    /// Apply the study's [quick] settings (fewer steps, shorter horizons and ladders): a smoke
    /// test.
    #[arg(long)]
    pub(super) quick: bool,
    /// Redo runs that are already complete.
    #[arg(long)]
    pub(super) force: bool,
    /// If another softbench is writing the study's folder, wait for it instead of stopping.
    #[arg(long)]
    pub(super) wait: bool,
    /// Run only the K-th of N parts of the grid (K counts from 0), balanced by estimated
    /// cost (every shard computes the same split). The last shard to finish merges (see
    /// `merge`).
    #[arg(long, value_name = "K/N")]
    pub(super) shard: Option<study::Shard>,
    /// Draw the pictures of the bodies (panel PNG and GIF per scene, in report.md). A study
    /// always draws them; the flag is accepted so `run --render` works as `simulate --render`.
    #[arg(long)]
    pub(super) render: bool,
    /// Not an option of `run` (it is `simulate`'s): accepted only to say so, instead of
    /// clap's tip to pass it as a value.
    #[arg(long = "set", value_name = "KEY=VALUE", hide = true)]
    pub(super) set: Vec<String>,
}

#[derive(Args)]
pub(super) struct MergeArgs {
    /// The study's results folder (<OUT>/<study name>, with shards/ and series/).
    pub(super) dir: PathBuf,
    /// If another softbench is writing the study's folder (a shard merging), wait for it.
    #[arg(long)]
    pub(super) wait: bool,
}

#[derive(Args)]
pub(super) struct SlurmArgs {
    /// Study file (TOML).
    pub(super) study: PathBuf,
    /// Parent folder of the study's results folder (on a file system every node sees).
    #[arg(long, default_value = "results")]
    pub(super) out: PathBuf,
    /// Tasks of the job array, one shard each (default: 4, or the number of runs if fewer).
    #[arg(long, value_name = "N")]
    pub(super) shards: Option<usize>,
    /// Slurm partition (default: the cluster's default partition).
    #[arg(long, value_name = "P")]
    pub(super) partition: Option<String>,
    /// Time limit of each task: minutes, HH:MM:SS, D-HH:MM, ... (default: the partition's).
    #[arg(long, value_name = "T")]
    pub(super) time: Option<String>,
    /// CPUs of each task; each shard runs this many runs at a time (`run --jobs`).
    #[arg(long, value_name = "C", default_value_t = 1)]
    pub(super) cpus_per_task: usize,
    /// The shards run the study with `--quick`.
    #[arg(long)]
    pub(super) quick: bool,
    /// Submit the scripts with sbatch (the merge with --dependency=afterok on the array) and
    /// print the job ids.
    #[arg(long)]
    pub(super) submit: bool,
}

#[derive(Args)]
pub(super) struct PlotArgs {
    /// A study's results folder (with runs.csv, meta.json and series/).
    pub(super) dir: PathBuf,
}

#[derive(Args)]
pub(super) struct ProfilesArgs {
    /// A work-precision study's results folder (with runs.csv).
    pub(super) dir: PathBuf,
    /// Accuracy targets: the errors a run must reach to solve a problem, comma-separated.
    /// Default every decade from 1e-1 to 1e-8.
    #[arg(long, value_delimiter = ',')]
    pub(super) targets: Vec<f64>,
    /// Where to write (default <DIR>/profiles).
    #[arg(long)]
    pub(super) out: Option<PathBuf>,
}

#[derive(Args)]
pub(super) struct LedgerArgs {
    /// The folder of claim files (one TOML file per claim).
    #[arg(default_value = "claims")]
    pub(super) claims: PathBuf,
    /// The results folder the claims' studies are in (`<RESULTS>/<study>/`).
    #[arg(long, default_value = "results")]
    pub(super) results: PathBuf,
    /// Where to write the page (default <RESULTS>/suite/ledger.md).
    #[arg(long)]
    pub(super) out: Option<PathBuf>,
    /// Compare with the page on disk instead of writing it: exit 1 if it differs.
    #[arg(long)]
    pub(super) check: bool,
}

#[derive(Args)]
pub(super) struct RenderArgs {
    /// A `simulate --render` output folder (with run.snapshots) or a study's results folder.
    pub(super) dir: PathBuf,
    /// Body colour: `j` (det F of the tet under each face), `energy` (its elastic energy
    /// density, white at 0, dark red at the largest drawn together) or `plain`. A surface
    /// that is not the boundary of elastic tets (a [display] mesh, a mass-spring body) is
    /// drawn plain.
    #[arg(long, default_value = "j", value_parser = ["j", "energy", "plain"])]
    pub(super) color: String,
}

#[derive(Args)]
pub(super) struct SimulateArgs {
    /// Scene file (TOML).
    pub(super) scene: PathBuf,
    /// Output folder (created if needed; files of a previous run are replaced).
    #[arg(long)]
    pub(super) out: PathBuf,
    /// Override a scene key by its dotted path, e.g. --set integrator.method=rk4 (repeatable).
    #[arg(long = "set", value_name = "KEY=VALUE")]
    pub(super) set: Vec<String>,
    /// Threads for element loops and linear solvers (default: RAYON_NUM_THREADS, else one
    /// per core).
    #[arg(long)]
    pub(super) threads: Option<usize>,
    /// Write frames to <OUT>/frames/: `vtu` (the tets with velocity, displacement, J and,
    /// with an elastic material, energy and energy density; plus series.pvd) or `obj` (the
    /// boundary surface, or the scene's [display] mesh skinned onto the tets).
    #[arg(long, value_name = "FORMAT")]
    pub(super) export: Option<String>,
    /// With --export: a frame every K steps (and at step 0 and the last step). Default 1.
    #[arg(long, value_name = "K", requires = "export")]
    pub(super) every: Option<usize>,
    /// If another softbench is writing the output folder, wait for it instead of stopping.
    #[arg(long)]
    pub(super) wait: bool,
    /// Keep the body's surface (the scene's [display] mesh if it has one) at up to 31 times
    /// (run.snapshots) and draw filmstrip.png (6 of them) and animation.gif into the output
    /// folder.
    #[arg(long)]
    pub(super) render: bool,
}

#[derive(Args)]
pub(super) struct MeshInfoArgs {
    /// Mesh file, of any format below. Looked up in the current folder, then in the folder
    /// named by SOFTBENCH_DATA.
    pub(super) file: PathBuf,
    /// Print one JSON object instead of text.
    #[arg(long)]
    pub(super) json: bool,
}

/// The formats `mesh-info` reads, from the format table: name, title, extensions and
/// description, one line each.
pub(super) fn mesh_formats_help() -> String {
    let mut help = String::from("Formats (told apart by content first, extension second):\n");
    for format in MeshFormat::all() {
        let e = format.entry();
        let extensions: Vec<String> = e.extensions.iter().map(|x| format!(".{x}")).collect();
        help += &format!(
            "  {:6} {:18} {:11} {}\n",
            e.name,
            e.title,
            extensions.join(" "),
            e.description
        );
    }
    help
}
