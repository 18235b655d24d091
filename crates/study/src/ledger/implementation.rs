//! Which implementation a verdict is about. A claim about a method (its `subject`, `vbd`) is
//! judged on softbench's own implementation and on each of the field's own (`[[originals]]`:
//! peer methods such as `pbat-vbd`, see `docs/peers.md`), with the same rule: the subject's
//! method name in every filter becomes the original's (and so does any other method the
//! package implements, `also = { xpbd = "pbat-xpbd" }`, so "VBD beats XPBD" is judged on one
//! package's pair), and the columns the original names differently
//! (`integrator.vbd.iterations` → `integrator.peer.iterations`) are renamed. A
//! claim its paper makes about speed on a GPU (`claimed_on = "gpu"`) and whose rule reads a
//! time gets, for each implementation that can run on a GPU, a GPU verdict of its own: judged
//! on the rows run there (`integrator.peer.device = "cuda"`), open while there are none; its
//! CPU verdict then reads the CPU rows alone (a table without the device column ran every
//! peer on its default device, the CPU).

use super::rule::RuleSpec;
use std::collections::BTreeMap;

/// The column a peer's device is recorded in when a study sweeps or sets it.
pub const DEVICE_COLUMN: &str = "integrator.peer.device";

/// Where a verdict's rows ran.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum Device {
    Cpu,
    Gpu,
}

impl Device {
    pub fn name(self) -> &'static str {
        match self {
            Self::Cpu => "CPU",
            Self::Gpu => "GPU",
        }
    }
}

/// One `[[originals]]` entry of a claim file: a peer method implementing the claim's subject.
#[derive(Clone, Debug, serde::Deserialize)]
#[serde(deny_unknown_fields)]
pub struct Original {
    /// The peer method (`pbat-vbd`).
    pub method: String,
    /// Its package (`pbatoolkit`).
    pub package: String,
    /// The package's implementations of the other methods the rule names (`xpbd =
    /// "pbat-xpbd"`).
    #[serde(default)]
    pub also: BTreeMap<String, String>,
    /// Columns the subject's rule reads that the peer writes under another name.
    #[serde(default)]
    pub columns: BTreeMap<String, String>,
    /// Whether its code runs on a GPU through its `device` setting (Newton's: `cuda`).
    #[serde(default)]
    pub gpu: bool,
}

/// One implementation a claim is judged on, with the rule as it reads that implementation's
/// rows.
#[derive(Clone, Debug, PartialEq)]
pub struct Implementation {
    /// The method whose rows are judged (`vbd`, `pbat-vbd`).
    pub method: String,
    /// The other methods the rule reads in this implementation (`pbat-xpbd`).
    pub also: Vec<String>,
    /// The package whose code it runs; `None` for softbench's own.
    pub package: Option<String>,
    /// Where its rows ran (or must run, for an open GPU verdict).
    pub device: Device,
    pub rule: RuleSpec,
}

impl Implementation {
    /// How the ledger names it: "softbench's `vbd`", "pbatoolkit's `pbat-vbd`", with the device
    /// when the verdict reads a time.
    pub fn label(&self, timed: bool) -> String {
        let methods = std::iter::once(&self.method)
            .chain(&self.also)
            .map(|m| format!("`{m}`"))
            .collect::<Vec<_>>()
            .join(" and ");
        let whose = match &self.package {
            None => format!("softbench's {methods}"),
            Some(p) => format!("{p}'s {methods}"),
        };
        if timed {
            format!("{whose}, {}", self.device.name())
        } else {
            whose
        }
    }
}

/// The implementations `rule` (written for `subject`) is judged on: softbench's own, then each
/// original on the CPU and, for a timed claim its paper makes on a GPU, on a GPU.
pub fn implementations(
    subject: &str,
    rule_table: &toml::Table,
    rule: &RuleSpec,
    originals: &[Original],
    gpu_claim: bool,
) -> Result<Vec<Implementation>, String> {
    let timed = gpu_claim && rule.reads_time();
    let own_also: Vec<String> =
        originals
            .iter()
            .flat_map(|o| o.also.keys().cloned())
            .fold(Vec::new(), |mut v, m| {
                if !v.contains(&m) {
                    v.push(m);
                }
                v
            });
    let mut out = vec![Implementation {
        method: subject.to_owned(),
        also: own_also,
        package: None,
        device: Device::Cpu,
        rule: rule.clone(),
    }];
    for original in originals {
        if original.method == subject {
            return Err(format!(
                "originals: `{}` is the subject itself; an original is a peer method",
                original.method
            ));
        }
        let parse = |t: &toml::Table| {
            RuleSpec::parse(t).map_err(|e| format!("rule, judged on `{}`: {e}", original.method))
        };
        // An original that can run on either device is judged on each device's rows apart.
        let devices: &[(Device, Option<&str>)] = if timed && original.gpu {
            &[(Device::Cpu, Some("cpu")), (Device::Gpu, Some("cuda"))]
        } else {
            &[(Device::Cpu, None)]
        };
        for &(device, setting) in devices {
            out.push(Implementation {
                method: original.method.clone(),
                also: original.also.values().cloned().collect(),
                package: Some(original.package.clone()),
                device,
                rule: parse(&substitute(rule_table, subject, original, setting))?,
            });
        }
    }
    Ok(out)
}

/// `rule` with `subject` replaced by `original`: every filter's `method = subject` names the
/// original, and every other method the original implements (`also`) its implementation
/// (and, with `device`, such a filter also requires the device), and every column the original
/// renames is renamed, as a filter key and as a column-valued setting (`group_by`, `x`, ...).
fn substitute(
    rule: &toml::Table,
    subject: &str,
    original: &Original,
    device: Option<&str>,
) -> toml::Table {
    let rename = |s: &str| {
        original
            .columns
            .get(s)
            .cloned()
            .unwrap_or_else(|| s.to_owned())
    };
    let mut out = toml::Table::new();
    for (key, value) in rule {
        let value = match value {
            toml::Value::Table(filter) => {
                let mut f = toml::Table::new();
                let mut is_subject = false;
                for (column, condition) in filter {
                    let condition = match (column.as_str(), condition) {
                        ("method", toml::Value::String(m)) if m == subject => {
                            is_subject = true;
                            toml::Value::String(original.method.clone())
                        }
                        ("method", toml::Value::String(m)) if original.also.contains_key(m) => {
                            is_subject = true;
                            toml::Value::String(original.also[m].clone())
                        }
                        _ => condition.clone(),
                    };
                    f.insert(rename(column), condition);
                }
                if let (true, Some(d)) = (is_subject, device) {
                    f.insert(DEVICE_COLUMN.into(), toml::Value::String(d.into()));
                }
                toml::Value::Table(f)
            }
            toml::Value::String(s) => toml::Value::String(rename(s)),
            toml::Value::Array(items) => toml::Value::Array(
                items
                    .iter()
                    .map(|v| match v {
                        toml::Value::String(s) => toml::Value::String(rename(s)),
                        other => other.clone(),
                    })
                    .collect(),
            ),
            other => other.clone(),
        };
        out.insert(key.clone(), value);
    }
    out
}

#[cfg(test)]
mod tests {
    use super::*;

    fn rule_table(text: &str) -> toml::Table {
        toml::from_str(text).unwrap()
    }

    #[test]
    fn an_original_takes_the_subjects_place_in_every_filter_and_column() {
        let text = r#"
kind = "bound"
rows = { method = "xpbd", "integrator.xpbd.substeps" = ">= 100", outcome = "completed" }
metric = "error"
at_most = 0.01
qualify_by = ["scene", "integrator.xpbd.substeps"]
"#;
        let table = rule_table(text);
        let rule = RuleSpec::parse(&table).unwrap();
        let original = Original {
            method: "pbat-xpbd".into(),
            package: "pbatoolkit".into(),
            also: BTreeMap::new(),
            columns: [(
                "integrator.xpbd.substeps".to_owned(),
                "integrator.peer.substeps".to_owned(),
            )]
            .into(),
            gpu: false,
        };
        let all = implementations("xpbd", &table, &rule, &[original], true).unwrap();
        assert_eq!(
            all.len(),
            2,
            "no GPU verdict for a claim that reads no time"
        );
        assert_eq!(all[0].rule, rule);
        let described = all[1].rule.describe();
        assert!(described.contains("method = pbat-xpbd"), "{described}");
        assert!(
            described.contains("integrator.peer.substeps >= 100"),
            "{described}"
        );
        assert_eq!(
            all[1].rule.qualify_by,
            ["scene", "integrator.peer.substeps"]
        );
        assert_eq!(all[1].device, Device::Cpu);
    }

    #[test]
    fn a_timed_gpu_claim_gets_a_gpu_verdict_for_an_original_that_runs_on_one() {
        let text = r#"
kind = "dominates"
a = { method = "vbd" }
b = { method = "backward-euler" }
group_by = ["scene"]
cost = "wall_seconds"
error = "error"
"#;
        let table = rule_table(text);
        let rule = RuleSpec::parse(&table).unwrap();
        let originals = [
            Original {
                method: "newton-vbd".into(),
                package: "newton".into(),
                also: BTreeMap::new(),
                columns: BTreeMap::new(),
                gpu: true,
            },
            Original {
                method: "pbat-vbd".into(),
                package: "pbatoolkit".into(),
                also: [("backward-euler".to_owned(), "pbat-newton".to_owned())].into(),
                columns: BTreeMap::new(),
                gpu: false,
            },
        ];
        let all = implementations("vbd", &table, &rule, &originals, true).unwrap();
        let labels: Vec<String> = all.iter().map(|i| i.label(true)).collect();
        assert_eq!(
            labels,
            [
                "softbench's `vbd` and `backward-euler`, CPU",
                "newton's `newton-vbd`, CPU",
                "newton's `newton-vbd`, GPU",
                "pbatoolkit's `pbat-vbd` and `pbat-newton`, CPU"
            ]
        );
        // A method the package also implements is its implementation in that package's
        // verdict.
        assert!(
            all[3].rule.describe().contains("method = pbat-newton"),
            "{}",
            all[3].rule.describe()
        );
        let gpu = all[2].rule.describe();
        assert!(
            gpu.contains("integrator.peer.device = cuda") && gpu.contains("method = newton-vbd"),
            "{gpu}"
        );
        assert!(
            all[1]
                .rule
                .describe()
                .contains("integrator.peer.device = cpu"),
            "{}",
            all[1].rule.describe()
        );
        // The other side of the comparison is not the subject: it keeps its rows.
        assert!(gpu.contains("method = backward-euler"), "{gpu}");
        assert!(
            !gpu.contains("backward-euler, integrator.peer.device"),
            "{gpu}"
        );
        // Without the paper's GPU claim there is no GPU verdict.
        assert_eq!(
            implementations("vbd", &table, &rule, &originals, false)
                .unwrap()
                .len(),
            3
        );
    }
}
