//! The `softbench` command line. Each subcommand is one variant of [`Command`] and one
//! function; exit code 0 on success, 2 for bad input (a file that is missing or malformed),
//! 1 for anything else (such as a closed output pipe).

use std::io::Write;
use std::path::{Path, PathBuf};
use std::process::ExitCode;

use anyhow::Context;
use clap::{Args, Parser, Subcommand};
use serde::Serialize;
use softbench::data::{DataError, DataPaths};
use softbench::mesh::{AnyMesh, MeshError, MeshFormat, MeshReport, read_mesh};

/// A harness for research on time integrators and solvers for deformable bodies.
#[derive(Parser)]
#[command(name = "softbench", version, about)]
struct Cli {
    #[command(subcommand)]
    command: Command,
}

#[derive(Subcommand)]
enum Command {
    /// Report counts, extent, volumes, quality and surface topology of a mesh file.
    MeshInfo(MeshInfoArgs),
}

#[derive(Args)]
struct MeshInfoArgs {
    /// Mesh file: MEDIT or plain .mesh, TetGen .node/.ele, or .obj. Looked up in the current
    /// folder, then in the folder named by SOFTBENCH_DATA.
    file: PathBuf,
    /// Print one JSON object instead of text.
    #[arg(long)]
    json: bool,
}

fn main() -> ExitCode {
    let cli = Cli::parse();
    let result = match cli.command {
        Command::MeshInfo(args) => mesh_info(&args),
    };
    match result {
        Ok(()) => ExitCode::SUCCESS,
        Err(err) => {
            eprintln!("error: {err:#}");
            if is_bad_input(&err) {
                ExitCode::from(2)
            } else {
                ExitCode::FAILURE
            }
        }
    }
}

/// Whether an error comes from the user's input files rather than from softbench or the system.
fn is_bad_input(err: &anyhow::Error) -> bool {
    err.chain()
        .any(|e| e.is::<MeshError>() || e.is::<DataError>())
}

/// The JSON form of `mesh-info`: the report plus where it came from.
#[derive(Serialize)]
struct MeshInfo<'a> {
    file: &'a Path,
    format: MeshFormat,
    #[serde(flatten)]
    report: &'a MeshReport,
}

fn mesh_info(args: &MeshInfoArgs) -> anyhow::Result<()> {
    let path = DataPaths::from_env()
        .resolve_from_cwd(&args.file)
        .context("cannot find the mesh")?;
    let (format, mesh) = read_mesh(&path).context("cannot read the mesh")?;
    let report = match &mesh {
        AnyMesh::Tet(m) => MeshReport::for_tet_mesh(m),
        AnyMesh::Surface(m) => MeshReport::for_surface(m),
    };
    let mut out = std::io::stdout().lock();
    if args.json {
        let info = MeshInfo {
            file: &path,
            format,
            report: &report,
        };
        serde_json::to_writer_pretty(&mut out, &info).context("cannot write the report")?;
        writeln!(out)?;
    } else {
        writeln!(out, "file                {}", path.display())?;
        writeln!(out, "format              {format}")?;
        write!(out, "{report}")?;
    }
    out.flush().context("cannot write the report")?;
    Ok(())
}
