//! The runs of an invocation, `jobs` at a time: each run measured by its kind on a worker
//! thread (in the study's pool), each result handed back on the calling thread as it arrives.

use crate::study::execute::progress::Progress;
use crate::study::execute::shared::{SharedWork, Workers};
use crate::study::kind::{Measure, RunInputs};
use crate::study::vocabulary::error::RunError;
use crate::study::vocabulary::measured::Measured;
use crate::study::vocabulary::spec::{RunSpec, Study};
use softbench_core::interrupt;

/// Why [`execute`] stopped early.
pub(in crate::study) enum Stop {
    Interrupted(softbench_core::interrupt::Signal),
    Failed(RunError),
}

/// Measure `pending` (each with its index in the progress's plan), `jobs` at a time,
/// handing each result to `keep` as it arrives (in this thread). Stops handing out runs at
/// the first failure or stop request; the runs already running finish, and after a stop
/// request their results are dropped (they were cut short; a resume redoes them).
pub(in crate::study) fn execute(
    study: &Study,
    pending: &[(usize, &RunSpec)],
    shared: &SharedWork,
    workers: &Workers,
    progress: &Progress,
    mut keep: impl FnMut(&RunSpec, &Measured) -> Result<(), RunError>,
) -> Result<(), Stop> {
    let Workers {
        parallelism,
        threads,
        jobs,
    } = *workers;
    let (sender, receiver) = std::sync::mpsc::channel::<(usize, Result<Measured, String>)>();
    let next = std::sync::atomic::AtomicUsize::new(0);
    let mut stop: Option<Stop> = None;
    std::thread::scope(|scope| {
        for _ in 0..jobs.max(1).min(pending.len().max(1)) {
            let sender = sender.clone();
            let next = &next;
            scope.spawn(move || {
                loop {
                    if interrupt::requested().is_some() {
                        break;
                    }
                    let i = next.fetch_add(1, std::sync::atomic::Ordering::SeqCst);
                    let Some(&(run, spec)) = pending.get(i) else {
                        break;
                    };
                    progress.start_run(run, &spec.id);
                    let inputs = RunInputs {
                        meter: Some(progress.meter(run)),
                        ..shared.of(spec)
                    };
                    let result = threads.install(|| {
                        crate::study::kinds::measure(study.kind).measure(
                            study,
                            spec,
                            &inputs,
                            parallelism,
                        )
                    });
                    progress.finish_run(run, &spec.id);
                    if sender.send((i, result)).is_err() {
                        break;
                    }
                }
            });
        }
        drop(sender);
        for (i, result) in receiver {
            if let Some(signal) = interrupt::requested() {
                if stop.is_none() {
                    stop = Some(Stop::Interrupted(signal));
                }
                next.store(usize::MAX / 2, std::sync::atomic::Ordering::SeqCst);
                continue;
            }
            if matches!(stop, Some(Stop::Interrupted(_))) {
                continue;
            }
            let spec = pending[i].1;
            let kept = match result {
                Ok(m) => keep(spec, &m).map(|()| {
                    progress.line(&progress.run_line(
                        &spec.id,
                        &summary_line(crate::study::kinds::measure(study.kind), &m),
                    ));
                    progress.inc();
                }),
                Err(message) => Err(RunError::Run(format!("run {}: {message}", spec.id))),
            };
            if let Err(e) = kept {
                stop.get_or_insert(Stop::Failed(e));
                // Stop handing out runs; the ones running finish.
                next.store(usize::MAX / 2, std::sync::atomic::Ordering::SeqCst);
            }
        }
    });
    stop.map_or(Ok(()), Err)
}

/// One line per finished run.
fn summary_line(kind: &dyn Measure, m: &Measured) -> String {
    let extra = kind.progress(m);
    format!("{}{}", m.outcome, extra.unwrap_or_default())
}
