//! The `softbench` command: the library's command line with the built-in registries. A
//! program that registers its own methods or solvers calls [`softbench::cli::main`] the same
//! way after registering them.

fn main() -> std::process::ExitCode {
    softbench::cli::main()
}
