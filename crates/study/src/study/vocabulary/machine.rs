//! What a study ran on, for `meta.json`: CPU, cores, OS, compiler, commit, and the machine's
//! load when the study started (timings are only comparable on a quiet machine).

/// The machine and build of a study.
#[derive(Clone, Debug, serde::Serialize, serde::Deserialize)]
pub struct Machine {
    pub softbench_version: String,
    pub git_commit: String,
    pub rustc: String,
    pub cpu: String,
    pub cores: usize,
    pub os: String,
    /// The load average over 1, 5 and 15 minutes when this was read (the study's start), from
    /// `/proc/loadavg`; `None` where there is none.
    #[serde(default)]
    pub load_average: Option<[f64; 3]>,
}

impl Machine {
    /// Read off this machine.
    pub fn current() -> Self {
        Self {
            softbench_version: env!("CARGO_PKG_VERSION").into(),
            git_commit: env!("SOFTBENCH_GIT_COMMIT").into(),
            rustc: env!("SOFTBENCH_RUSTC_VERSION").into(),
            cpu: cpu_model().unwrap_or_else(|| std::env::consts::ARCH.into()),
            cores: std::thread::available_parallelism().map_or(1, |n| n.get()),
            os: os_name(),
            load_average: load_average(),
        }
    }
}

/// The load average over 1, 5 and 15 minutes now, from `/proc/loadavg`.
pub fn load_average() -> Option<[f64; 3]> {
    let text = std::fs::read_to_string("/proc/loadavg").ok()?;
    let mut fields = text.split_whitespace().map(|f| f.parse::<f64>().ok());
    Some([fields.next()??, fields.next()??, fields.next()??])
}

fn cpu_model() -> Option<String> {
    let info = std::fs::read_to_string("/proc/cpuinfo").ok()?;
    info.lines()
        .find(|l| l.starts_with("model name"))
        .and_then(|l| l.split_once(':'))
        .map(|(_, v)| v.trim().to_owned())
}

fn os_name() -> String {
    let pretty = std::fs::read_to_string("/etc/os-release")
        .ok()
        .and_then(|t| {
            t.lines()
                .find_map(|l| l.strip_prefix("PRETTY_NAME="))
                .map(|v| v.trim_matches('"').to_owned())
        });
    let kernel = std::fs::read_to_string("/proc/sys/kernel/osrelease")
        .ok()
        .map(|k| k.trim().to_owned());
    match (pretty, kernel) {
        (Some(p), Some(k)) => format!("{p} (Linux {k})"),
        (Some(p), None) => p,
        _ => std::env::consts::OS.into(),
    }
}
