//! Registries of pluggable families (integration methods, linear solvers, ...): one table per
//! family that parsing, "did you mean", `softbench list` and the docs are generated from.
//!
//! A family is a [`Registry`] of entries, each a name, a one-line description and the facts the
//! rest of the code asks of it (an integrator's order, whether it is explicit, how to build
//! it). The built-in entries are a `static` slice, one line each; a program that depends on
//! softbench adds its own with [`Registry::register`] before it loads scenes, and they are then
//! found by name exactly like the built-in ones.
//!
//! A family's value type is a [`Handle`]: a `Copy` reference to its entry that compares,
//! hashes, prints and (de)serializes by name. [`registry_handle!`](crate::registry_handle) declares one.

use std::sync::RwLock;

/// What every registered entry has.
pub trait Entry: Send + Sync + 'static {
    /// The name scene and study files use (unique within the family).
    fn name(&self) -> &'static str;
    /// One line on what it is, for `softbench list` and the README.
    fn description(&self) -> &'static str;
    /// The facts the rest of the code asks of it, for `softbench list` ("order", "2").
    fn facts(&self) -> Vec<Fact> {
        Vec::new()
    }
}

/// An unknown name in a family: the message suggests the closest name and lists the valid ones.
#[derive(Clone, Debug, PartialEq, Eq, thiserror::Error)]
#[error("{}", crate::names::unknown_name_message(self.what, &self.name, &self.valid))]
pub struct UnknownName {
    /// The family, e.g. "integrator".
    pub what: &'static str,
    /// The name asked for.
    pub name: String,
    /// Every registered name, in listing order.
    pub valid: Vec<&'static str>,
}

impl crate::error_class::Classify for UnknownName {
    fn class(&self) -> crate::error_class::ErrorClass {
        crate::error_class::ErrorClass::BadInput
    }
}

/// Why [`Registry::register`] refused an entry.
#[derive(Clone, Debug, PartialEq, Eq, thiserror::Error)]
pub enum RegisterError {
    /// The name is taken (by a built-in or an earlier registration).
    #[error("a {what} named `{name}` is already registered")]
    Duplicate { what: &'static str, name: String },
    /// Names are lowercase ASCII letters, digits and '-', starting with a letter.
    #[error(
        "`{name}` is not a valid {what} name: use lowercase letters, digits and '-', starting \
         with a letter"
    )]
    InvalidName { what: &'static str, name: String },
}

impl crate::error_class::Classify for RegisterError {
    /// A program registering a name that is taken or malformed: the program's failure.
    fn class(&self) -> crate::error_class::ErrorClass {
        crate::error_class::ErrorClass::Failure
    }
}

/// One family: its built-in table plus the entries registered at run time.
pub struct Registry<E: Entry> {
    what: &'static str,
    builtin: &'static [E],
    added: RwLock<Vec<&'static E>>,
}

impl<E: Entry> Registry<E> {
    /// A family called `what` (for messages) with these built-in entries.
    pub const fn new(what: &'static str, builtin: &'static [E]) -> Self {
        Self {
            what,
            builtin,
            added: RwLock::new(Vec::new()),
        }
    }

    /// What the family is called in messages ("integrator", "linear solver", ...).
    pub fn what(&self) -> &'static str {
        self.what
    }

    /// Every entry: the built-in ones in table order, then the registered ones in order of
    /// registration.
    pub fn all(&self) -> Vec<&'static E> {
        let added = self.added.read().unwrap_or_else(|e| e.into_inner());
        self.builtin.iter().chain(added.iter().copied()).collect()
    }

    /// Every name, in the order of [`Self::all`].
    pub fn names(&self) -> Vec<&'static str> {
        self.all().into_iter().map(|e| e.name()).collect()
    }

    /// The entry called `name`.
    pub fn find(&self, name: &str) -> Result<&'static E, UnknownName> {
        if let Some(e) = self.builtin.iter().find(|e| e.name() == name) {
            return Ok(e);
        }
        let added = self.added.read().unwrap_or_else(|e| e.into_inner());
        added
            .iter()
            .copied()
            .find(|e| e.name() == name)
            .ok_or_else(|| UnknownName {
                what: self.what,
                name: name.to_owned(),
                valid: self.names(),
            })
    }

    /// Add an entry under its name, for the rest of the program's life. Fails if the name is
    /// taken or malformed; registering is meant for a program's start, before scenes load.
    pub fn register(&self, entry: E) -> Result<&'static E, RegisterError> {
        let name = entry.name();
        let valid = name.starts_with(|c: char| c.is_ascii_lowercase())
            && name
                .chars()
                .all(|c| c.is_ascii_lowercase() || c.is_ascii_digit() || c == '-');
        if !valid {
            return Err(RegisterError::InvalidName {
                what: self.what,
                name: name.to_owned(),
            });
        }
        let mut added = self.added.write().unwrap_or_else(|e| e.into_inner());
        let taken =
            self.builtin.iter().any(|e| e.name() == name) || added.iter().any(|e| e.name() == name);
        if taken {
            return Err(RegisterError::Duplicate {
                what: self.what,
                name: name.to_owned(),
            });
        }
        let entry: &'static E = Box::leak(Box::new(entry));
        added.push(entry);
        Ok(entry)
    }
}

/// A `Copy` handle to an entry of a registry: what scene settings hold.
pub trait Handle: Copy + 'static {
    /// The entry type.
    type Entry: Entry;
    /// The family's registry.
    fn registry() -> &'static Registry<Self::Entry>;
    /// The handle of an entry.
    fn from_entry(entry: &'static Self::Entry) -> Self;
    /// The entry.
    fn entry(self) -> &'static Self::Entry;
}

/// Declares a handle type `$ty` over the entries `$entry` of the registry `$registry`: `Copy`,
/// equal and hashed by name, shown and (de)serialized as its name, parsed with "did you mean".
#[macro_export]
macro_rules! registry_handle {
    ($(#[$doc:meta])* $vis:vis struct $ty:ident($entry:ty) in $registry:path;) => {
        $(#[$doc])*
        #[derive(Clone, Copy, serde::Serialize, serde::Deserialize)]
        #[serde(try_from = "String", into = "String")]
        $vis struct $ty(&'static $entry);

        impl $crate::registry::Handle for $ty {
            type Entry = $entry;
            fn registry() -> &'static $crate::registry::Registry<$entry> {
                &$registry
            }
            fn from_entry(entry: &'static $entry) -> Self {
                Self(entry)
            }
            fn entry(self) -> &'static $entry {
                self.0
            }
        }

        impl $ty {
            /// The entry named `name`.
            pub fn from_name(name: &str) -> Result<Self, $crate::registry::UnknownName> {
                $registry.find(name).map(Self)
            }

            /// Every registered value, built-in first.
            pub fn all() -> Vec<Self> {
                $registry.all().into_iter().map(Self).collect()
            }

            /// Every registered name, for messages.
            pub fn names() -> Vec<&'static str> {
                $registry.names()
            }

            /// The name files use.
            pub fn name(self) -> &'static str {
                $crate::registry::Entry::name(self.0)
            }

            /// One line on what it is.
            pub fn description(self) -> &'static str {
                $crate::registry::Entry::description(self.0)
            }

            /// The registry entry with every fact about it.
            pub fn entry(self) -> &'static $entry {
                self.0
            }
        }

        impl PartialEq for $ty {
            fn eq(&self, other: &Self) -> bool {
                self.name() == other.name()
            }
        }

        impl Eq for $ty {}

        impl std::hash::Hash for $ty {
            fn hash<H: std::hash::Hasher>(&self, state: &mut H) {
                self.name().hash(state);
            }
        }

        impl std::fmt::Debug for $ty {
            fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
                write!(f, "{}({:?})", stringify!($ty), self.name())
            }
        }

        impl std::fmt::Display for $ty {
            fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
                f.write_str(self.name())
            }
        }

        impl std::str::FromStr for $ty {
            type Err = $crate::registry::UnknownName;
            fn from_str(s: &str) -> Result<Self, Self::Err> {
                Self::from_name(s)
            }
        }

        impl TryFrom<String> for $ty {
            type Error = $crate::registry::UnknownName;
            fn try_from(s: String) -> Result<Self, Self::Error> {
                Self::from_name(&s)
            }
        }

        impl From<$ty> for String {
            fn from(v: $ty) -> String {
                v.name().to_owned()
            }
        }
    };
}

/// A fact about an entry, for `softbench list`: what it is and its value ("order", "2").
pub type Fact = (&'static str, String);

/// One entry of a family as `softbench list` shows it.
#[derive(Clone, Debug, PartialEq, Eq)]
pub struct Listing {
    pub name: &'static str,
    pub description: &'static str,
    pub facts: Vec<Fact>,
}

impl Listing {
    /// The facts as `key=value` words, space-separated (empty when there are none).
    pub fn facts_text(&self) -> String {
        self.facts
            .iter()
            .map(|(k, v)| format!("{k}={v}"))
            .collect::<Vec<_>>()
            .join(" ")
    }
}

impl<E: Entry> Registry<E> {
    /// Every entry with its description and facts, in the order of [`Self::all`].
    pub fn listing(&self) -> Vec<Listing> {
        self.all()
            .into_iter()
            .map(|e| Listing {
                name: e.name(),
                description: e.description(),
                facts: e.facts(),
            })
            .collect()
    }
}

/// The facts of a closed family's variants (see [`named_enum!`](crate::named_enum)), as listed.
pub trait ListFacts {
    /// The facts as `(what, value)` pairs.
    fn list(&self) -> Vec<Fact>;
}

impl ListFacts for () {
    fn list(&self) -> Vec<Fact> {
        Vec::new()
    }
}

/// A closed family declared with [`named_enum!`](crate::named_enum): the enum is the table.
pub trait NamedEnum: Copy + 'static {
    /// What the family is called in messages ("obstacle kind", ...).
    const WHAT: &'static str;
    /// Every value, in table order.
    fn all_values() -> &'static [Self];
    /// The name files use.
    fn name(self) -> &'static str;
    /// One line on what it is.
    fn description(self) -> &'static str;
    /// The facts, for listing.
    fn listed_facts(self) -> Vec<Fact>;

    /// Every value with its description and facts.
    fn listing() -> Vec<Listing> {
        Self::all_values()
            .iter()
            .map(|&v| Listing {
                name: v.name(),
                description: v.description(),
                facts: v.listed_facts(),
            })
            .collect()
    }
}

/// Declares a closed family as an enum from one table: each variant's name, one-line
/// description and (optionally) a facts value of the type named after the error type. It
/// generates `ALL`, `name`, `description`, `facts`, `names`, parsing (`FromStr`, serde) with
/// "did you mean", `Display`, the unknown-name error type and [`NamedEnum`] (for listing).
///
/// ```
/// softbench_core::named_enum! {
///     /// The shape of an obstacle.
///     pub enum Shape: "shape", UnknownShape {
///         /// A half-space below a plane.
///         Plane = "plane", "a half-space below a plane (point, outward normal)",
///         /// A ball.
///         Sphere = "sphere", "a ball (center, radius)",
///     }
/// }
/// assert_eq!(Shape::ALL, &[Shape::Plane, Shape::Sphere]);
/// assert_eq!("sphere".parse::<Shape>().unwrap(), Shape::Sphere);
/// assert_eq!(Shape::Plane.description(), "a half-space below a plane (point, outward normal)");
/// let unknown = "spehre".parse::<Shape>().unwrap_err().to_string();
/// assert!(unknown.contains("sphere"), "{unknown}");
/// ```
#[macro_export]
macro_rules! named_enum {
    ($(#[$doc:meta])* $vis:vis enum $ty:ident : $what:literal, $err:ident {
        $($(#[$vdoc:meta])* $variant:ident = $name:literal, $desc:literal,)+
    }) => {
        $crate::named_enum! {
            $(#[$doc])* $vis enum $ty : $what, $err, () {
                $($(#[$vdoc])* $variant = $name, $desc, (),)+
            }
        }
    };
    ($(#[$doc:meta])* $vis:vis enum $ty:ident : $what:literal, $err:ident, $facts:ty {
        $($(#[$vdoc:meta])* $variant:ident = $name:literal, $desc:literal, $fact:expr,)+
    }) => {
        $(#[$doc])*
        #[derive(Clone, Copy, Debug, PartialEq, Eq, Hash, serde::Serialize, serde::Deserialize)]
        #[serde(try_from = "String", into = "String")]
        $vis enum $ty {
            $($(#[$vdoc])* $variant,)+
        }

        impl $ty {
            /// Every value, in table order.
            pub const ALL: &'static [$ty] = &[$($ty::$variant,)+];

            /// The name files use.
            pub fn name(self) -> &'static str {
                match self {
                    $($ty::$variant => $name,)+
                }
            }

            /// One line on what it is (for `softbench list`).
            pub fn description(self) -> &'static str {
                match self {
                    $($ty::$variant => $desc,)+
                }
            }

            /// The facts the rest of the code asks of it.
            #[allow(clippy::unused_unit)]
            pub fn facts(self) -> $facts {
                match self {
                    $($ty::$variant => $fact,)+
                }
            }

            /// Every name, for messages.
            pub fn names() -> Vec<&'static str> {
                Self::ALL.iter().map(|v| v.name()).collect()
            }
        }

        impl $crate::registry::NamedEnum for $ty {
            const WHAT: &'static str = $what;
            fn all_values() -> &'static [Self] {
                Self::ALL
            }
            fn name(self) -> &'static str {
                $ty::name(self)
            }
            fn description(self) -> &'static str {
                $ty::description(self)
            }
            fn listed_facts(self) -> Vec<$crate::registry::Fact> {
                $crate::registry::ListFacts::list(&self.facts())
            }
        }

        #[doc = concat!("An unknown ", $what, " name; the message lists the valid ones.")]
        #[derive(Clone, Debug, PartialEq, Eq, thiserror::Error)]
        #[error("{}", $crate::names::unknown_name_message($what, .0, &$ty::names()))]
        $vis struct $err(pub String);

        $crate::classify_all!(BadInput: $err);

        impl std::str::FromStr for $ty {
            type Err = $err;
            fn from_str(s: &str) -> Result<Self, Self::Err> {
                Self::ALL
                    .iter()
                    .copied()
                    .find(|v| v.name() == s)
                    .ok_or_else(|| $err(s.to_owned()))
            }
        }

        impl TryFrom<String> for $ty {
            type Error = $err;
            fn try_from(s: String) -> Result<Self, Self::Error> {
                s.parse()
            }
        }

        impl From<$ty> for String {
            fn from(v: $ty) -> String {
                v.name().to_owned()
            }
        }

        impl std::fmt::Display for $ty {
            fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
                f.write_str(self.name())
            }
        }
    };
}

#[cfg(test)]
mod tests {
    use super::*;

    struct Thing {
        name: &'static str,
    }

    impl Entry for Thing {
        fn name(&self) -> &'static str {
            self.name
        }
        fn description(&self) -> &'static str {
            "a thing"
        }
    }

    static THINGS: Registry<Thing> = Registry::new("thing", &[Thing { name: "alpha" }]);

    registry_handle! {
        /// A test handle.
        struct ThingHandle(Thing) in THINGS;
    }

    #[test]
    fn registered_entries_are_found_listed_and_unique() {
        assert_eq!(ThingHandle::from_name("alpha").unwrap().name(), "alpha");
        THINGS.register(Thing { name: "beta-2" }).unwrap();
        assert_eq!(THINGS.names(), ["alpha", "beta-2"]);
        assert_eq!(ThingHandle::names(), ["alpha", "beta-2"]);
        let all = ThingHandle::all();
        assert_eq!(all[1].entry().name, "beta-2");
        assert_eq!(all[0].description(), "a thing");
        let beta: ThingHandle = "beta-2".parse().unwrap();
        assert_eq!(beta, ThingHandle::from_name("beta-2").unwrap());
        assert!(matches!(
            THINGS.register(Thing { name: "alpha" }),
            Err(RegisterError::Duplicate { .. })
        ));
        assert!(matches!(
            THINGS.register(Thing { name: "Bad Name" }),
            Err(RegisterError::InvalidName { .. })
        ));
        let err = ThingHandle::from_name("alpa").unwrap_err().to_string();
        assert!(err.contains("did you mean `alpha`?"), "{err}");
    }

    #[test]
    fn a_handle_lists_its_family_and_describes_its_entry() {
        let alpha = ThingHandle::from_name("alpha").unwrap();
        assert_eq!(alpha.description(), "a thing");
        assert_eq!(alpha.entry().name, "alpha");
        assert!(ThingHandle::all().contains(&alpha));
        assert_eq!(ThingHandle::names()[0], "alpha");
        let listing = THINGS.listing();
        assert_eq!(listing[0].name, "alpha");
        assert_eq!(listing[0].facts_text(), "");
    }
}
