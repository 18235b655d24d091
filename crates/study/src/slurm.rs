//! Slurm job scripts for a study: a job array whose task K runs `softbench run --shard K/N`
//! (`$SLURM_ARRAY_TASK_ID/$SLURM_ARRAY_TASK_COUNT`) and a merge job that starts when every
//! task has succeeded (`--dependency=afterok`), plus `submit.sh`, which submits both. The
//! shards and the merge are ordinary softbench commands, so any other scheduler (or a shell
//! loop) can run the same shards.

use std::path::{Path, PathBuf};
use std::process::Command;

/// What the job scripts ask of Slurm.
#[derive(Clone, Debug)]
pub struct SlurmJob {
    /// The study file (absolute).
    pub study_file: PathBuf,
    /// The study's name (the results folder's name, and the job name).
    pub name: String,
    /// The parent of the study's results folder (absolute), as `run --out`.
    pub out: PathBuf,
    /// The command the jobs run softbench with: the binary (absolute; on a file system every
    /// node sees), or a host and its arguments (`python3 -m softbench`, for peer methods).
    pub exe: Vec<PathBuf>,
    /// Tasks of the array: shards of the study.
    pub shards: usize,
    /// `--partition`, if any (else the cluster's default partition).
    pub partition: Option<String>,
    /// `--time` of each task, if any (else the partition's default limit).
    pub time: Option<String>,
    /// `--cpus-per-task`, also each shard's `--jobs`.
    pub cpus_per_task: usize,
    /// `run --quick`.
    pub quick: bool,
    /// `SOFTBENCH_DATA` for the jobs (absolute), if set.
    pub data: Option<PathBuf>,
}

/// A bad `softbench slurm` option, or a failed submission.
#[derive(Debug, thiserror::Error)]
pub enum SlurmError {
    #[error(
        "--time {0}: not a Slurm time limit; use minutes, MM:SS, HH:MM:SS, D-HH, D-HH:MM or D-HH:MM:SS (e.g. 30, 2:00:00, 1-12)"
    )]
    Time(String),
    #[error("--partition {0}: a partition name has no spaces, quotes or control characters")]
    Partition(String),
    #[error(
        "{0}: a path in an #SBATCH line cannot hold whitespace, quotes or control characters; \
         move the results (--out) to a path without them"
    )]
    Path(PathBuf),
    #[error(
        "cannot run sbatch ({error}): is this a Slurm login node? The scripts are written; \
         submit them with {submit} where sbatch is available"
    )]
    NoSbatch {
        error: std::io::Error,
        submit: PathBuf,
    },
    #[error("sbatch {script} failed ({status}): {stderr}")]
    Sbatch {
        script: PathBuf,
        status: String,
        stderr: String,
    },
}

impl softbench_core::error_class::Classify for SlurmError {
    /// A time, partition or path that a job script cannot hold is the input's; `sbatch`
    /// missing or refusing the job is the cluster's.
    fn class(&self) -> softbench_core::error_class::ErrorClass {
        softbench_core::error_class::ErrorClass::bad_input_if(!matches!(
            self,
            Self::NoSbatch { .. } | Self::Sbatch { .. }
        ))
    }
}

/// Checks a `--time` value against the formats sbatch accepts.
pub fn check_time(time: &str) -> Result<(), SlurmError> {
    let bad = || SlurmError::Time(softbench_core::quote::clip_message(time));
    let numbers = |s: &str| -> Option<Vec<u64>> {
        s.split(':')
            .map(|p| {
                (!p.is_empty() && p.bytes().all(|b| b.is_ascii_digit()))
                    .then(|| p.parse().ok())
                    .flatten()
            })
            .collect()
    };
    let ok = match time.split_once('-') {
        // D-HH, D-HH:MM, D-HH:MM:SS
        Some((days, rest)) => {
            numbers(days).is_some_and(|d| d.len() == 1)
                && numbers(rest).is_some_and(|r| (1..=3).contains(&r.len()))
        }
        // minutes, MM:SS, HH:MM:SS
        None => numbers(time).is_some_and(|r| (1..=3).contains(&r.len())),
    } || ["infinite", "unlimited"].contains(&time);
    if ok { Ok(()) } else { Err(bad()) }
}

/// Checks a `--partition` value (it goes into an `#SBATCH` line).
pub fn check_partition(partition: &str) -> Result<(), SlurmError> {
    let ok = !partition.is_empty()
        && partition
            .chars()
            .all(|c| c.is_ascii_alphanumeric() || "-_.,".contains(c));
    if ok {
        Ok(())
    } else {
        Err(SlurmError::Partition(softbench_core::quote::clip_message(
            partition,
        )))
    }
}

/// A path for a shell command line, single-quoted.
impl SlurmJob {
    /// The command, each word quoted for the shell.
    fn command(&self) -> String {
        let words: Vec<String> = self.exe.iter().map(|w| shell_quote(w)).collect();
        words.join(" ")
    }
}

fn shell_quote(path: &Path) -> String {
    format!("'{}'", path.display().to_string().replace('\'', r"'\''"))
}

/// A path for an `#SBATCH` line (no quoting is possible there).
fn sbatch_path(path: &Path) -> Result<String, SlurmError> {
    let text = path.display().to_string();
    if text
        .chars()
        .any(|c| c.is_whitespace() || c.is_control() || "'\"\\".contains(c))
    {
        return Err(SlurmError::Path(path.to_owned()));
    }
    Ok(text)
}

impl SlurmJob {
    /// The study's results folder.
    pub fn study_dir(&self) -> PathBuf {
        self.out.join(&self.name)
    }

    /// The folder the scripts go to: `<study folder>/slurm`.
    pub fn script_dir(&self) -> PathBuf {
        self.study_dir().join("slurm")
    }

    /// The study's name as a job name (safe in an `#SBATCH` line).
    fn job_name(&self) -> String {
        self.name
            .chars()
            .map(|c| {
                if c.is_ascii_alphanumeric() || "-_.".contains(c) {
                    c
                } else {
                    '_'
                }
            })
            .collect()
    }

    /// The `#SBATCH` lines both jobs share.
    fn common(&self, lines: &mut Vec<String>) -> Result<(), SlurmError> {
        if let Some(p) = &self.partition {
            check_partition(p)?;
            lines.push(format!("#SBATCH --partition={p}"));
        }
        if let Some(t) = &self.time {
            check_time(t)?;
            lines.push(format!("#SBATCH --time={t}"));
        }
        lines.push(format!(
            "#SBATCH --chdir={}",
            sbatch_path(&self.script_dir())?
        ));
        Ok(())
    }

    fn environment(&self, lines: &mut Vec<String>) {
        lines.push("set -euo pipefail".into());
        if let Some(data) = &self.data {
            lines.push(format!("export SOFTBENCH_DATA={}", shell_quote(data)));
        }
    }

    /// The job array: task K runs shard K of N.
    pub fn array_script(&self) -> Result<String, SlurmError> {
        let mut lines = vec![
            "#!/bin/bash".to_owned(),
            format!(
                "# Written by `softbench slurm` for study {}: task K of this array runs shard K \
                 of {} (softbench run --shard K/N); submit with submit.sh, which adds the merge.",
                self.name, self.shards
            ),
            format!("#SBATCH --job-name=softbench-{}", self.job_name()),
            format!("#SBATCH --array=0-{}", self.shards.saturating_sub(1)),
            format!("#SBATCH --cpus-per-task={}", self.cpus_per_task),
            "#SBATCH --output=shard-%a.out".into(),
        ];
        self.common(&mut lines)?;
        self.environment(&mut lines);
        lines.push(format!(
            "exec {} run {} --out {} --shard \"$SLURM_ARRAY_TASK_ID/$SLURM_ARRAY_TASK_COUNT\" \
             --jobs {}{}",
            self.command(),
            shell_quote(&self.study_file),
            shell_quote(&self.out),
            self.cpus_per_task,
            if self.quick { " --quick" } else { "" }
        ));
        Ok(lines.join("\n") + "\n")
    }

    /// The merge job (submitted with `--dependency=afterok:<array job>`). It waits for the
    /// study folder if the last shard is merging at that moment (a merge is idempotent).
    pub fn merge_script(&self) -> Result<String, SlurmError> {
        let mut lines = vec![
            "#!/bin/bash".to_owned(),
            format!(
                "# Written by `softbench slurm` for study {}: merges the shards into runs.csv, \
                 plots, report.md and meta.json once every task of the array has succeeded.",
                self.name
            ),
            format!("#SBATCH --job-name=softbench-{}-merge", self.job_name()),
            "#SBATCH --cpus-per-task=1".into(),
            "#SBATCH --output=merge.out".into(),
        ];
        self.common(&mut lines)?;
        self.environment(&mut lines);
        lines.push(format!(
            "exec {} merge {} --wait",
            self.command(),
            shell_quote(&self.study_dir())
        ));
        Ok(lines.join("\n") + "\n")
    }

    /// `submit.sh`: submits the array, then the merge after it.
    pub fn submit_script(&self) -> String {
        format!(
            "#!/bin/sh\n\
             # Submits the {n}-task array of study {name}, then its merge (after every task \
             succeeded).\n\
             set -eu\n\
             cd \"$(dirname \"$0\")\"\n\
             array=$(sbatch --parsable shards.sbatch)\n\
             array=${{array%%;*}}\n\
             merge=$(sbatch --parsable --dependency=afterok:\"$array\" merge.sbatch)\n\
             merge=${{merge%%;*}}\n\
             echo \"shards: job $array ({n} tasks); merge: job $merge (after every task succeeded)\"\n",
            n = self.shards,
            name = self.name
        )
    }

    /// Write `shards.sbatch`, `merge.sbatch` and `submit.sh` into [`Self::script_dir`];
    /// returns the folder.
    pub fn write(&self) -> std::io::Result<PathBuf> {
        let dir = self.script_dir();
        std::fs::create_dir_all(&dir)?;
        let array = self.array_script().map_err(std::io::Error::other)?;
        let merge = self.merge_script().map_err(std::io::Error::other)?;
        for (name, text) in [
            ("shards.sbatch", array),
            ("merge.sbatch", merge),
            ("submit.sh", self.submit_script()),
        ] {
            let path = dir.join(name);
            softbench_run::io::write_atomic(&path, |w| w.write_all(text.as_bytes()))?;
            #[cfg(unix)]
            {
                use std::os::unix::fs::PermissionsExt;
                std::fs::set_permissions(&path, std::fs::Permissions::from_mode(0o755))?;
            }
        }
        Ok(dir)
    }

    /// Submit the written scripts: the array, then the merge with `afterok` on it. Returns
    /// the two job ids.
    pub fn submit(&self) -> Result<(String, String), SlurmError> {
        let dir = self.script_dir();
        let array = sbatch(&dir, &["shards.sbatch"])?;
        let dependency = format!("--dependency=afterok:{array}");
        let merge = sbatch(&dir, &[&dependency, "merge.sbatch"])?;
        Ok((array, merge))
    }
}

/// `sbatch --parsable <args>` in `dir`; the job id it prints (`id` or `id;cluster`).
fn sbatch(dir: &Path, args: &[&str]) -> Result<String, SlurmError> {
    let script = dir.join(args.last().copied().unwrap_or_default());
    let out = Command::new("sbatch")
        .arg("--parsable")
        .args(args)
        .current_dir(dir)
        .output()
        .map_err(|error| SlurmError::NoSbatch {
            error,
            submit: dir.join("submit.sh"),
        })?;
    let stdout = String::from_utf8_lossy(&out.stdout);
    let id = stdout.trim().split(';').next().unwrap_or("").to_owned();
    if !out.status.success() || id.is_empty() || !id.bytes().all(|b| b.is_ascii_digit()) {
        return Err(SlurmError::Sbatch {
            script,
            status: out.status.to_string(),
            stderr: softbench_core::quote::clip_message(
                format!(
                    "{}{}",
                    String::from_utf8_lossy(&out.stderr).trim(),
                    stdout.trim()
                )
                .trim(),
            ),
        });
    }
    Ok(id)
}

#[cfg(test)]
mod tests {
    use super::*;

    fn job() -> SlurmJob {
        SlurmJob {
            study_file: "/home/me/softbench/experiments/quickstart.toml".into(),
            name: "quickstart".into(),
            out: "/scratch/me/results".into(),
            exe: vec!["/home/me/softbench/target/release/softbench".into()],
            shards: 3,
            partition: Some("short".into()),
            time: Some("0:30:00".into()),
            cpus_per_task: 2,
            quick: true,
            data: Some("/data/it's meshes".into()),
        }
    }

    #[test]
    fn the_array_runs_one_shard_per_task_and_the_merge_follows() {
        let array = job().array_script().unwrap();
        for line in [
            "#SBATCH --array=0-2",
            "#SBATCH --cpus-per-task=2",
            "#SBATCH --partition=short",
            "#SBATCH --time=0:30:00",
            "#SBATCH --chdir=/scratch/me/results/quickstart/slurm",
            "export SOFTBENCH_DATA='/data/it'\\''s meshes'",
            "exec '/home/me/softbench/target/release/softbench' run \
             '/home/me/softbench/experiments/quickstart.toml' --out '/scratch/me/results' \
             --shard \"$SLURM_ARRAY_TASK_ID/$SLURM_ARRAY_TASK_COUNT\" --jobs 2 --quick",
        ] {
            assert!(array.lines().any(|l| l == line), "no `{line}` in\n{array}");
        }
        let merge = job().merge_script().unwrap();
        assert!(merge.contains(
            "exec '/home/me/softbench/target/release/softbench' merge \
             '/scratch/me/results/quickstart' --wait"
        ));
        assert!(!merge.contains("--array"));
        let submit = job().submit_script();
        assert!(submit.contains("--dependency=afterok:\"$array\" merge.sbatch"));
    }

    #[test]
    fn a_host_command_runs_every_job_the_way_the_study_was_started() {
        // `python -m softbench slurm ...` (peer methods registered in that process) writes
        // jobs that run `python -m softbench` again.
        let job = SlurmJob {
            exe: vec!["/usr/bin/python3".into(), "-m".into(), "softbench".into()],
            ..job()
        };
        let array = job.array_script().unwrap();
        assert!(
            array
                .lines()
                .any(|l| l.starts_with("exec '/usr/bin/python3' '-m' 'softbench' run ")),
            "{array}"
        );
        let merge = job.merge_script().unwrap();
        assert!(merge.contains("exec '/usr/bin/python3' '-m' 'softbench' merge "));
    }

    #[test]
    fn bad_options_are_refused_with_what_is_valid() {
        for ok in [
            "30",
            "2:00:00",
            "10:00",
            "1-12",
            "1-12:30",
            "1-12:30:00",
            "infinite",
        ] {
            check_time(ok).unwrap();
        }
        for bad in ["", "1h", "1:2:3:4", "-5", "1-", "2:00:00\n#SBATCH --x"] {
            let e = check_time(bad).unwrap_err().to_string();
            assert!(e.contains("HH:MM:SS"), "{bad}: {e}");
        }
        check_partition("gpu-short").unwrap();
        assert!(check_partition("a b").is_err());
        let mut j = job();
        j.out = "/scratch/my results".into();
        assert!(
            j.array_script()
                .unwrap_err()
                .to_string()
                .contains("whitespace")
        );
    }
}
