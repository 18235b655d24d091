//! Running a study: `runner` runs the planned runs that are not already done — the whole
//! study (`local`), or one shard of it (`sharded`), the two `strategy`s — `jobs` at a time
//! (`workers`), writing each finished run (`record`), then `finish` ends the invocation the
//! same way for both: the table, the columns no run filled, a stop, or the strategy's end
//! (plots, report and metadata; or the shard's record and the merge of the last shard);
//! `shared` computes the work the runs share (highest modes, references) once per physics;
//! `rows` reads and orders the rows earlier invocations left; `progress` and `eta` show how
//! far it is; `merge` merges the shards of a sharded study.

pub mod eta;
pub mod finish;
pub mod invocation;
pub mod local;
pub mod merge;
pub mod progress;
pub mod record;
pub mod rows;
pub mod runner;
pub mod sharded;
pub mod shared;
pub mod strategy;
pub mod workers;
