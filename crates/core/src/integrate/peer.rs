//! Peer methods: another package's own implementation of a method (pbatoolkit's VBD, Newton's
//! XPBD, ...) run under softbench's protocol, so that studies compare the originals with
//! softbench's implementations on the same problems.
//!
//! A peer is registered at run time (the Python package registers the ones it knows) as an
//! ordinary [`super::MethodEntry`] whose `peer` is a [`PeerFacts`]: the package and its
//! version, the softbench method it implements (its twin), the material models it has, and its
//! own settings with the package's defaults. Scenes set those under `[integrator.peer]`; a scene
//! is resolved with every default filled in, so the run's configuration records every setting.
//! What a peer cannot do is refused when the scene is loaded (the scene crate asks these facts).

use std::collections::BTreeMap;
use std::sync::Mutex;

/// One value of a peer's setting, as TOML writes it.
#[derive(Clone, Debug, PartialEq, serde::Serialize, serde::Deserialize)]
#[serde(untagged)]
pub enum PeerValue {
    Bool(bool),
    Int(i64),
    Float(f64),
    Text(String),
}

impl PeerValue {
    /// The type's name, for messages.
    pub fn type_name(&self) -> &'static str {
        match self {
            Self::Bool(_) => "a boolean",
            Self::Int(_) => "an integer",
            Self::Float(_) => "a number",
            Self::Text(_) => "a string",
        }
    }

    /// `given` as this value's type (an integer is taken where a number is asked), or `None`.
    fn coerce(&self, given: &PeerValue) -> Option<PeerValue> {
        match (self, given) {
            (Self::Float(_), Self::Int(i)) => Some(Self::Float(*i as f64)),
            (Self::Bool(_), Self::Bool(_))
            | (Self::Int(_), Self::Int(_))
            | (Self::Float(_), Self::Float(_))
            | (Self::Text(_), Self::Text(_)) => Some(given.clone()),
            _ => None,
        }
    }
}

impl std::fmt::Display for PeerValue {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        match self {
            Self::Bool(b) => write!(f, "{b}"),
            Self::Int(i) => write!(f, "{i}"),
            Self::Float(x) => write!(f, "{x:?}"),
            Self::Text(s) => write!(f, "\"{s}\""),
        }
    }
}

/// One of a peer's own settings.
#[derive(Clone, Debug, PartialEq)]
pub struct PeerSetting {
    /// The key under `[integrator.peer]`.
    pub key: String,
    /// The package's own default (its type is the setting's type).
    pub default: PeerValue,
    /// The values a text setting may take (empty: any; numbers must be positive when
    /// `positive`).
    pub choices: Vec<String>,
    /// A number that must be > 0 (iterations, substeps).
    pub positive: bool,
    /// One line on what it does.
    pub description: String,
    /// The scene key of the twin method's matching setting (`integrator.vbd.iterations`), if
    /// it has one.
    pub twin_key: Option<String>,
    /// How values translate to the twin's (`"Inertia"` → `"inertia"`); empty: the same value.
    /// A value not listed has no twin equivalent.
    pub twin_values: Vec<(PeerValue, PeerValue)>,
    /// The value at which the setting changes nothing the twin would need to match (one
    /// substep); any other value without a twin equivalent is reported unmatched.
    pub neutral: Option<PeerValue>,
}

/// A peer's resolved settings as its twin's: the overrides that match them (`key=value`), and
/// the settings that have no equivalent (`key=value`).
#[derive(Clone, Debug, Default, PartialEq)]
pub struct TwinSettings {
    pub overrides: Vec<String>,
    pub unmatched: Vec<String>,
}

impl PeerFacts {
    /// The twin's settings matching `resolved` (see [`TwinSettings`]).
    pub fn twin_settings(&self, resolved: &BTreeMap<String, PeerValue>) -> TwinSettings {
        let mut twin = TwinSettings::default();
        for s in &self.settings {
            let Some(value) = resolved.get(&s.key) else {
                continue;
            };
            let mapped = match &s.twin_key {
                None => None,
                Some(key) if s.twin_values.is_empty() => Some((key, value.clone())),
                Some(key) => s
                    .twin_values
                    .iter()
                    .find(|(from, _)| from == value)
                    .map(|(_, to)| (key, to.clone())),
            };
            match mapped {
                Some((key, to)) => twin.overrides.push(format!("{key}={}", toml_value(&to))),
                None if s.neutral.as_ref() == Some(value) => {}
                None => twin.unmatched.push(format!("{}={value}", s.key)),
            }
        }
        twin
    }
}

/// `value` as a TOML literal (strings quoted), for a `key=value` override.
fn toml_value(value: &PeerValue) -> String {
    match value {
        PeerValue::Text(t) => format!("\"{t}\""),
        other => other.to_string(),
    }
}

/// What a peer method is and what it can run.
#[derive(Clone, Debug, PartialEq)]
pub struct PeerFacts {
    /// The package whose code runs (`pbatoolkit`, `newton`).
    pub package: String,
    /// Its installed version, or `None` when it is not installed here.
    pub version: Option<String>,
    /// How to install it (`pip install pbatoolkit==0.0.11`), for the message when it is
    /// missing.
    pub install: String,
    /// The softbench method it implements, if any (`vbd` for `pbat-vbd`).
    pub twin: Option<String>,
    /// The material models (softbench's names) it implements.
    pub materials: Vec<String>,
    /// Its own settings.
    pub settings: Vec<PeerSetting>,
}

/// Why a scene's `[integrator.peer]` table was refused: the key and the message.
#[derive(Clone, Debug, PartialEq)]
pub struct PeerSettingError {
    pub key: String,
    pub message: String,
}

impl PeerFacts {
    /// `given` with every default filled in, or the first key that is unknown, of the wrong
    /// type or out of range (the message lists what is valid).
    pub fn resolve(
        &self,
        method: &str,
        given: &BTreeMap<String, PeerValue>,
    ) -> Result<BTreeMap<String, PeerValue>, PeerSettingError> {
        let error = |key: &str, message: String| PeerSettingError {
            key: format!("integrator.peer.{key}"),
            message,
        };
        if let Some(unknown) = given
            .keys()
            .find(|k| !self.settings.iter().any(|s| &s.key == *k))
        {
            let known: Vec<&str> = self.settings.iter().map(|s| s.key.as_str()).collect();
            return Err(error(
                unknown,
                format!(
                    "`{method}` ({}) has no setting `{unknown}`; its settings are: {}",
                    self.package,
                    known.join(", ")
                ),
            ));
        }
        let mut resolved = BTreeMap::new();
        for s in &self.settings {
            let value = match given.get(&s.key) {
                None => s.default.clone(),
                Some(v) => s.default.coerce(v).ok_or_else(|| {
                    error(
                        &s.key,
                        format!(
                            "must be {} for `{method}` (got {v}; {}'s default is {})",
                            s.default.type_name(),
                            self.package,
                            s.default
                        ),
                    )
                })?,
            };
            s.check(&value).map_err(|m| error(&s.key, m))?;
            resolved.insert(s.key.clone(), value);
        }
        Ok(resolved)
    }
}

impl PeerSetting {
    fn check(&self, value: &PeerValue) -> Result<(), String> {
        match value {
            PeerValue::Text(t) if !self.choices.is_empty() && !self.choices.contains(t) => {
                Err(format!(
                    "must be one of \"{}\" (got \"{t}\")",
                    self.choices.join("\", \"")
                ))
            }
            PeerValue::Int(i) if self.positive && *i <= 0 => {
                Err(format!("must be a positive integer (got {i})"))
            }
            PeerValue::Float(x) if !x.is_finite() || (self.positive && *x <= 0.0) => {
                Err(format!("must be a finite positive number (got {x})"))
            }
            _ => Ok(()),
        }
    }
}

/// What a peer's own code says of its problem, each where its API exposes it: the lumped
/// mass of every vertex, the fixed vertices, the elastic energy and the elastic forces at
/// given positions (every vertex, `3 n` values, force = −gradient).
#[derive(Clone, Debug, Default, PartialEq)]
pub struct PeerConventions {
    pub masses: Option<Vec<f64>>,
    pub fixed: Option<Vec<usize>>,
    pub elastic_energy: Option<f64>,
    pub elastic_forces: Option<Vec<f64>>,
    /// Where the peer's API exposes neither energy nor forces: what it offers instead.
    pub note: Option<String>,
}

/// A scene's `[integrator.peer]` table, interned so that the integrator settings stay `Copy`
/// (a study holds thousands of them; the distinct tables are few).
#[derive(Clone, Copy, Debug, PartialEq, Default)]
pub struct PeerSettings(Option<&'static BTreeMap<String, PeerValue>>);

static INTERNED: Mutex<Vec<&'static BTreeMap<String, PeerValue>>> = Mutex::new(Vec::new());

impl PeerSettings {
    /// The table `values`, interned.
    pub fn new(values: BTreeMap<String, PeerValue>) -> Self {
        if values.is_empty() {
            return Self(None);
        }
        let mut interned = INTERNED.lock().unwrap_or_else(|e| e.into_inner());
        if let Some(found) = interned.iter().find(|t| ***t == values) {
            return Self(Some(found));
        }
        let leaked: &'static BTreeMap<String, PeerValue> = Box::leak(Box::new(values));
        interned.push(leaked);
        Self(Some(leaked))
    }

    /// The settings, by key.
    pub fn values(&self) -> &BTreeMap<String, PeerValue> {
        static EMPTY: BTreeMap<String, PeerValue> = BTreeMap::new();
        self.0.unwrap_or(&EMPTY)
    }

    /// No setting given.
    pub fn is_empty(&self) -> bool {
        self.values().is_empty()
    }
}

impl serde::Serialize for PeerSettings {
    fn serialize<S: serde::Serializer>(&self, s: S) -> Result<S::Ok, S::Error> {
        self.values().serialize(s)
    }
}

impl<'de> serde::Deserialize<'de> for PeerSettings {
    fn deserialize<D: serde::Deserializer<'de>>(d: D) -> Result<Self, D::Error> {
        BTreeMap::<String, PeerValue>::deserialize(d).map(Self::new)
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    fn facts() -> PeerFacts {
        let setting = |key: &str, default: PeerValue| PeerSetting {
            key: key.into(),
            default,
            choices: Vec::new(),
            positive: true,
            description: String::new(),
            twin_key: None,
            twin_values: Vec::new(),
            neutral: None,
        };
        PeerFacts {
            package: "pkg".into(),
            version: Some("1.0".into()),
            install: "pip install pkg".into(),
            twin: Some("vbd".into()),
            materials: vec!["stvk".into()],
            settings: vec![
                setting("iterations", PeerValue::Int(20)),
                setting("omega", PeerValue::Float(1.0)),
                PeerSetting {
                    choices: vec!["cpu".into(), "cuda".into()],
                    ..setting("device", PeerValue::Text("cpu".into()))
                },
            ],
        }
    }

    #[test]
    fn resolving_fills_defaults_and_names_the_key_of_a_bad_setting() {
        let f = facts();
        let mut given = BTreeMap::new();
        given.insert("omega".to_owned(), PeerValue::Int(2));
        let r = f.resolve("m", &given).unwrap();
        assert_eq!(r["iterations"], PeerValue::Int(20));
        assert_eq!(r["omega"], PeerValue::Float(2.0));
        assert_eq!(r["device"], PeerValue::Text("cpu".into()));

        let bad = |k: &str, v: PeerValue| {
            let mut g = BTreeMap::new();
            g.insert(k.to_owned(), v);
            f.resolve("m", &g).unwrap_err()
        };
        let e = bad("iteratons", PeerValue::Int(3));
        assert_eq!(e.key, "integrator.peer.iteratons");
        assert!(
            e.message.contains("iterations, omega, device"),
            "{}",
            e.message
        );
        let e = bad("iterations", PeerValue::Float(2.5));
        assert!(e.message.contains("must be an integer"), "{}", e.message);
        let e = bad("iterations", PeerValue::Int(0));
        assert!(e.message.contains("positive"), "{}", e.message);
        let e = bad("device", PeerValue::Text("gpu".into()));
        assert!(e.message.contains("\"cpu\", \"cuda\""), "{}", e.message);
    }

    #[test]
    fn twin_settings_translate_values_and_report_what_has_no_twin() {
        let mut f = facts();
        f.settings[0].twin_key = Some("integrator.vbd.iterations".into());
        f.settings[1].neutral = Some(PeerValue::Float(1.0));
        f.settings[2].twin_key = Some("integrator.x.device".into());
        f.settings[2].twin_values =
            vec![(PeerValue::Text("cpu".into()), PeerValue::Text("c".into()))];
        let resolved = f.resolve("m", &BTreeMap::new()).unwrap();
        let t = f.twin_settings(&resolved);
        assert_eq!(
            t.overrides,
            ["integrator.vbd.iterations=20", "integrator.x.device=\"c\""]
        );
        assert!(t.unmatched.is_empty(), "{:?}", t.unmatched);
        let mut given = BTreeMap::new();
        given.insert("omega".to_owned(), PeerValue::Float(2.0));
        given.insert("device".to_owned(), PeerValue::Text("cuda".into()));
        let t = f.twin_settings(&f.resolve("m", &given).unwrap());
        assert_eq!(t.unmatched, ["omega=2.0", "device=\"cuda\""]);
    }

    #[test]
    fn interned_tables_are_equal_by_content_and_serialize_as_tables() {
        let mut t = BTreeMap::new();
        t.insert("iterations".to_owned(), PeerValue::Int(5));
        let a = PeerSettings::new(t.clone());
        let b = PeerSettings::new(t);
        assert_eq!(a, b);
        assert!(PeerSettings::default().is_empty());
        let text = toml::to_string(&a).unwrap();
        assert_eq!(text.trim(), "iterations = 5");
        let back: PeerSettings = toml::from_str(&text).unwrap();
        assert_eq!(back, a);
    }
}
