//! Against a real Slurm: a one-node cluster (Debian's slurm-wlm) on a private configuration
//! in a temporary folder — munged on its own socket and key, slurmctld and slurmd on their
//! own ports — runs the quickstart study (quick mode) as `softbench slurm --submit`: a
//! 3-task job array plus the merge job after it. Its `runs.csv` and series must equal a
//! local `softbench run` of the same study in every column but timings. The daemons started
//! here are stopped by their pid files, whatever happens.
//!
//! Where Slurm cannot be started (not installed, not root), the test says so on stderr
//! (`skipped: ...`) and returns; under CI (`CI` set) it fails instead, as `.ci/run`
//! installs slurm-wlm.

mod common;

use common::results::assert_same_study;
use common::{TempDir, run_study_ok};
use std::io::Write;
use std::path::{Path, PathBuf};
use std::process::{Command, Output};
use std::time::{Duration, Instant};

/// A one-node Slurm cluster started by this test.
struct Cluster {
    dir: TempDir,
    conf: PathBuf,
    /// Pid files of the daemons started, in start order.
    pid_files: Vec<PathBuf>,
}

fn output(program: &str, args: &[&str]) -> Result<Output, String> {
    Command::new(program)
        .args(args)
        .output()
        .map_err(|e| format!("cannot run {program} ({e}); `apt-get install slurm-wlm` provides it"))
}

fn checked(program: &str, args: &[&str]) -> Result<String, String> {
    let o = output(program, args)?;
    if !o.status.success() {
        return Err(format!(
            "{program} {} failed: {}",
            args.join(" "),
            String::from_utf8_lossy(&o.stderr).trim()
        ));
    }
    Ok(String::from_utf8_lossy(&o.stdout).trim().to_owned())
}

/// The last lines of a log file, for an error message.
fn tail(path: &Path) -> String {
    let text = std::fs::read_to_string(path).unwrap_or_default();
    let lines: Vec<&str> = text.lines().collect();
    lines[lines.len().saturating_sub(5)..].join(" | ")
}

fn wait_for(what: &str, timeout: Duration, mut ready: impl FnMut() -> bool) -> Result<(), String> {
    let start = Instant::now();
    while start.elapsed() < timeout {
        if ready() {
            return Ok(());
        }
        std::thread::sleep(Duration::from_millis(250));
    }
    Err(format!("{what} within {} s", timeout.as_secs()))
}

impl Cluster {
    fn start() -> Result<Self, String> {
        // SAFETY: geteuid has no preconditions.
        if unsafe { libc::geteuid() } != 0 {
            return Err(
                "not root: munged must be started as the munge user and slurmd as root".into(),
            );
        }
        for program in ["munged", "slurmctld", "slurmd"] {
            output(program, &["-V"])?;
        }
        for program in ["sbatch", "squeue", "sinfo", "scontrol", "runuser"] {
            output(program, &["--version"])?;
        }
        let uid: u32 = checked("id", &["-u", "munge"])?
            .parse()
            .map_err(|e| format!("{e}"))?;
        let gid: u32 = checked("id", &["-g", "munge"])?
            .parse()
            .map_err(|e| format!("{e}"))?;
        let host = checked("hostname", &["-s"])?;
        let cpus = std::thread::available_parallelism().map_or(1, |n| n.get());
        let dir = TempDir::new("slurm-cluster");
        let conf = dir.path().join("slurm.conf");
        let mut cluster = Cluster {
            dir,
            conf,
            pid_files: Vec::new(),
        };
        let d = cluster.dir.path().to_owned();
        let io = |e: std::io::Error| e.to_string();
        // munged checks its folders: the key's private to munge, the socket's open to all.
        use std::os::unix::fs::PermissionsExt;
        for (sub, mode, munge) in [
            ("munge", 0o700, true),
            ("run", 0o755, true),
            ("state", 0o755, false),
            ("spool", 0o755, false),
            ("log", 0o755, false),
        ] {
            let p = d.join(sub);
            std::fs::create_dir_all(&p).map_err(io)?;
            std::fs::set_permissions(&p, std::fs::Permissions::from_mode(mode)).map_err(io)?;
            if munge {
                std::os::unix::fs::chown(&p, Some(uid), Some(gid)).map_err(io)?;
            }
        }
        std::fs::set_permissions(&d, std::fs::Permissions::from_mode(0o755)).map_err(io)?;
        let key = d.join("munge/munge.key");
        let mut bytes = vec![0u8; 1024];
        std::fs::File::open("/dev/urandom")
            .and_then(|mut f| std::io::Read::read_exact(&mut f, &mut bytes))
            .map_err(io)?;
        std::fs::write(&key, &bytes).map_err(io)?;
        std::fs::set_permissions(&key, std::fs::Permissions::from_mode(0o600)).map_err(io)?;
        std::os::unix::fs::chown(&key, Some(uid), Some(gid)).map_err(io)?;
        let socket = d.join("run/munge.sock");
        let munged_pid = d.join("run/munged.pid");
        let arg = |name: &str, p: &Path| format!("--{name}={}", p.display());
        let o = output(
            "runuser",
            &[
                "-u",
                "munge",
                "--",
                "munged",
                &arg("socket", &socket),
                &arg("key-file", &key),
                &arg("pid-file", &munged_pid),
                &arg("log-file", &d.join("munge/munged.log")),
                &arg("seed-file", &d.join("munge/munged.seed")),
            ],
        )?;
        if !o.status.success() {
            return Err(format!(
                "munged did not start: {}",
                String::from_utf8_lossy(&o.stderr).trim()
            ));
        }
        cluster.pid_files.push(munged_pid.clone());
        wait_for("munged's pid file", Duration::from_secs(10), || {
            munged_pid.exists()
        })?;

        // Private ports, so a cluster already on this machine is not disturbed.
        let port = 20_000 + (std::process::id() % 10_000) * 2;
        let conf = format!(
            "ClusterName=softbench-test\n\
             SlurmctldHost={host}\n\
             SlurmctldPort={port}\n\
             SlurmdPort={}\n\
             AuthType=auth/munge\n\
             CredType=cred/munge\n\
             AuthInfo=socket={}\n\
             ProctrackType=proctrack/linuxproc\n\
             TaskPlugin=task/none\n\
             SelectType=select/cons_tres\n\
             SelectTypeParameters=CR_Core\n\
             JobAcctGatherType=jobacct_gather/none\n\
             ReturnToService=2\n\
             SlurmUser=root\n\
             SlurmdUser=root\n\
             MpiDefault=none\n\
             StateSaveLocation={d}/state\n\
             SlurmdSpoolDir={d}/spool\n\
             SlurmctldPidFile={d}/slurmctld.pid\n\
             SlurmdPidFile={d}/slurmd.pid\n\
             SlurmctldLogFile={d}/log/slurmctld.log\n\
             SlurmdLogFile={d}/log/slurmd.log\n\
             NodeName={host} CPUs={cpus} State=UNKNOWN\n\
             PartitionName=test Nodes={host} Default=YES MaxTime=INFINITE State=UP\n",
            port + 1,
            socket.display(),
            d = d.display()
        );
        // (No cgroup.conf: slurm 22.05 exits on `CgroupPlugin=disabled`.)
        std::fs::write(&cluster.conf, conf).map_err(io)?;
        let conf = cluster.conf.display().to_string();
        for (daemon, log) in [("slurmctld", "slurmctld"), ("slurmd", "slurmd")] {
            let pid_file = d.join(format!("{daemon}.pid"));
            let o = output(daemon, &["-f", &conf])?;
            if !o.status.success() {
                return Err(format!(
                    "{daemon} did not start: {} {}",
                    String::from_utf8_lossy(&o.stderr).trim(),
                    tail(&d.join(format!("log/{log}.log")))
                ));
            }
            cluster.pid_files.push(pid_file.clone());
            wait_for(
                &format!("{daemon}'s pid file"),
                Duration::from_secs(15),
                || pid_file.exists(),
            )
            .map_err(|e| format!("{e}: {}", tail(&d.join(format!("log/{log}.log")))))?;
        }
        wait_for("the node idle", Duration::from_secs(60), || {
            cluster
                .command("sinfo", &["-h", "-o", "%T"])
                .is_ok_and(|s| s.trim() == "idle")
        })
        .map_err(|e| {
            format!(
                "{e}: slurmctld: {} slurmd: {}",
                tail(&d.join("log/slurmctld.log")),
                tail(&d.join("log/slurmd.log"))
            )
        })?;
        Ok(cluster)
    }

    /// A Slurm client command against this cluster; its stdout.
    fn command(&self, program: &str, args: &[&str]) -> Result<String, String> {
        let o = Command::new(program)
            .args(args)
            .env("SLURM_CONF", &self.conf)
            .output()
            .map_err(|e| e.to_string())?;
        if !o.status.success() {
            return Err(String::from_utf8_lossy(&o.stderr).into_owned());
        }
        Ok(String::from_utf8_lossy(&o.stdout).into_owned())
    }
}

impl Drop for Cluster {
    fn drop(&mut self) {
        // Jobs left over (a failed assertion) first, then the daemons, last started first.
        if let Ok(jobs) = self.command("squeue", &["-h", "-o", "%A"]) {
            for job in jobs.split_whitespace() {
                let _ = self.command("scancel", &[job]);
            }
        }
        for pid_file in self.pid_files.iter().rev() {
            let Some(pid) = std::fs::read_to_string(pid_file)
                .ok()
                .and_then(|t| t.trim().parse::<i32>().ok())
            else {
                continue;
            };
            // SAFETY: kill has no memory preconditions; the pid is the daemon we started.
            unsafe { libc::kill(pid, libc::SIGTERM) };
            let _ = wait_for("exit", Duration::from_secs(15), || {
                !Path::new(&format!("/proc/{pid}")).exists()
            });
        }
    }
}

/// Slurm cannot be started here: fail under CI, else say so and skip.
fn skip(why: &str) {
    assert!(
        std::env::var_os("CI").is_none(),
        "CI is set but a one-node Slurm cannot be started ({why}); .ci/run installs slurm-wlm"
    );
    let test = std::thread::current().name().unwrap_or("?").to_string();
    let _ = std::io::stderr().write_all(
        format!(
            "skipped: {test}: cannot start a one-node Slurm ({why}); as root, \
             `apt-get install slurm-wlm` to run it\n"
        )
        .as_bytes(),
    );
}

/// The number after `label` in `text` (`"shards job 12 (...)"`).
fn job_id(text: &str, label: &str) -> String {
    let rest = &text[text
        .find(label)
        .unwrap_or_else(|| panic!("no `{label}` in {text}"))
        + label.len()..];
    rest.chars().take_while(char::is_ascii_digit).collect()
}

#[test]
fn quickstart_as_a_slurm_array_plus_merge_equals_a_local_run() {
    let cluster = match Cluster::start() {
        Ok(c) => c,
        Err(why) => return skip(&why),
    };
    let tmp = TempDir::new("slurm-study");
    let file = Path::new(env!("CARGO_MANIFEST_DIR")).join("experiments/quickstart.toml");
    let local = tmp.path().join("local");
    run_study_ok(&file, &local, &["--quick"]);

    let out = tmp.path().join("slurm");
    let o = Command::new(env!("CARGO_BIN_EXE_softbench"))
        .args([
            "slurm",
            file.to_str().unwrap(),
            "--out",
            out.to_str().unwrap(),
        ])
        .args(["--quick", "--shards", "3", "--time", "10", "--submit"])
        .env("SLURM_CONF", &cluster.conf)
        .output()
        .unwrap();
    let stdout = String::from_utf8_lossy(&o.stdout).into_owned();
    assert!(
        o.status.success(),
        "{stdout}{}",
        String::from_utf8_lossy(&o.stderr)
    );
    let array = job_id(&stdout, "shards job ");
    let merge = job_id(&stdout, "merge job ");
    wait_for("every job done", Duration::from_secs(300), || {
        cluster
            .command("squeue", &["-h", "-o", "%A"])
            .is_ok_and(|s| s.trim().is_empty())
    })
    .unwrap_or_else(|e| panic!("{e}: {:?}", cluster.command("squeue", &[])));
    let states = |job: &str| {
        let text = cluster.command("scontrol", &["show", "job", job]).unwrap();
        text.split_whitespace()
            .filter_map(|w| w.strip_prefix("JobState="))
            .map(str::to_owned)
            .collect::<Vec<_>>()
    };
    assert_eq!(states(&array), ["COMPLETED"; 3], "the array's tasks");
    assert_eq!(states(&merge), ["COMPLETED"], "the merge job");

    let dir = out.join("quickstart");
    assert_same_study(&local.join("quickstart"), &dir);
    let merge_log = std::fs::read_to_string(dir.join("slurm/merge.out")).unwrap();
    assert!(
        merge_log.contains("merged 12 of 12 runs from 3 shard(s)"),
        "{merge_log}"
    );
    let meta: serde_json::Value =
        serde_json::from_str(&std::fs::read_to_string(dir.join("meta.json")).unwrap()).unwrap();
    let shards = meta["shards"].as_array().unwrap();
    assert_eq!(shards.len(), 3);
    let host = softbench::lock::hostname();
    for s in shards {
        assert_eq!(s["status"], "finished");
        assert_eq!(s["host"].as_str(), Some(host.as_str()));
        // Each shard ran under the array's environment.
        assert!(
            s["command"]
                .as_array()
                .unwrap()
                .iter()
                .any(|a| a == "--shard")
        );
    }
    assert!(dir.join("report.md").is_file() && dir.join("energy-soft_beam.png").is_file());
}
