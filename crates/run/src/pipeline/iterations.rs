//! `iterations.csv`: every Newton iteration of a run (with
//! `integrator.newton.log_iterations`), one row per iterate with the step it belongs to, the
//! residuals, decrement, energy, step, backtracks, linear work, time and every criterion's
//! scale ([`softbench_core::integrate::newton::log`]), so the run can be re-scored under another
//! criterion. An [`Observer`] around the caller's rows, written as the run goes.

use std::io::{self, Write};

use crate::run::{Observer, Sample};
use softbench_core::integrate::State;
use softbench_core::integrate::newton::{IterationRecord, log::CSV_HEADER};
use softbench_core::model::Model;

/// The file name in a run's output folder.
pub const ITERATIONS_CSV: &str = "iterations.csv";

/// Writes the iteration records to `csv` and passes everything to `inner`.
pub struct IterationRows<'a, W: Write> {
    inner: &'a mut dyn Observer,
    csv: csv::Writer<W>,
    /// Rows written.
    pub rows: usize,
}

impl<'a, W: Write> IterationRows<'a, W> {
    /// Rows into `out` (the header written now) around `inner`.
    pub fn new(inner: &'a mut dyn Observer, out: W) -> io::Result<Self> {
        let mut csv = csv::Writer::from_writer(out);
        csv.write_record(CSV_HEADER)?;
        Ok(Self {
            inner,
            csv,
            rows: 0,
        })
    }

    /// Flush the rows.
    pub fn flush(&mut self) -> io::Result<()> {
        self.csv.flush()
    }
}

impl<W: Write> Observer for IterationRows<'_, W> {
    fn sample(&mut self, sample: &Sample) -> io::Result<()> {
        self.inner.sample(sample)
    }

    fn after_step(&mut self, step: usize, model: &Model, state: &State) -> io::Result<()> {
        self.inner.after_step(step, model, state)
    }

    fn newton_iterations(&mut self, step: usize, records: &[IterationRecord]) -> io::Result<()> {
        for r in records {
            self.csv.write_record(r.csv_cells(step))?;
            self.rows += 1;
        }
        self.inner.newton_iterations(step, records)
    }
}
