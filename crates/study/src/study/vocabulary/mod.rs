//! What every study kind and every phase speaks: the study file's schema (`config`, its text
//! for error lines `context`, `settings` checks, the grid's axes `grid`), the runs (`spec`,
//! their ids and hashes `identity`), errors (`error`), numbers and times (`format`), tables
//! (`table`) and `runs.csv`'s columns (`columns`), a measured time's spread (`spread`), one
//! run's result and the pieces every kind shares to produce it (`measured`, `meter`),
//! reference solutions and errors against them (`reference`), the work the runs share on disk
//! (`shared_store`), shards (`shard`, `shard_record`) and `meta.json` (`meta`, `machine`).

pub mod columns;
pub mod config;
pub mod context;
pub mod error;
pub mod format;
pub mod grid;
pub mod identity;
pub mod machine;
pub mod measured;
pub mod meta;
pub mod meter;
pub mod modal;
pub mod reference;
pub mod settings;
pub mod shard;
pub mod shard_record;
pub mod shared_store;
pub mod spec;
pub mod spread;
pub mod table;
