//! softbench studies: a study file becomes a grid of runs measured by a study kind, written as
//! `runs.csv`, series, plots and a report ([`study`]); the claims ledger judges published claims
//! on committed study tables ([`ledger`]); [`slurm`] writes the job scripts of a sharded study.
//! Built on `softbench-core` and `softbench-run`.

pub mod ledger;
pub mod slurm;
pub mod study;
