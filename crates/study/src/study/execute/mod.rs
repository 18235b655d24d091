//! Running a study: `runner` runs the planned runs that are not already done — the whole
//! study, or one shard of it — then finishes the folder (its table, plots, report and
//! metadata, or the shard's record and the merge of a shard that finds every run done);
//! `shared` computes the work the runs share (highest modes, references) once per physics;
//! `rows` reads and orders the rows earlier invocations left; `progress` and `eta` show how
//! far it is; `merge` merges the shards of a sharded study.

pub mod eta;
pub mod merge;
pub mod progress;
pub mod rows;
pub mod runner;
pub mod shared;
