//! Presenting a study, from its written files only: `report` (report.md and its findings,
//! `findings`), `plots` (the charts of every kind, with `charts`' helpers), `pictures` (panel
//! PNG and GIF per scene), `profiles` (performance and data profiles over a work-precision
//! table), and `redraw` (all of it again from a results folder).

pub mod charts;
pub mod findings;
pub mod pictures;
pub mod plots;
pub mod profiles;
pub mod redraw;
pub mod report;
