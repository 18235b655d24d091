//! Peer methods in a scene (see [`softbench_core::integrate::peer`]): their `[integrator.peer]`
//! settings resolved with the package's defaults, and everything a peer cannot run refused when
//! the scene is loaded, naming the key and the package — never approximated.

use super::{Refusal, SceneConfig};
use softbench_core::integrate::peer::{PeerFacts, PeerSettings};
use softbench_core::model::MassKind;

fn refuse(key: &str, message: String) -> Refusal {
    Refusal {
        key: key.to_owned(),
        message,
    }
}

/// Fill a peer method's settings with its defaults (so the resolved scene records every one),
/// or refuse `[integrator.peer]` under a method that is not a peer.
pub(super) fn resolve(c: &mut SceneConfig) -> Result<(), Refusal> {
    let method = c.integrator.method;
    let Some(facts) = method.entry().peer else {
        if let Some(key) = c.integrator.peer.values().keys().next() {
            return Err(refuse(
                &format!("integrator.peer.{key}"),
                format!(
                    "`[integrator.peer]` holds a peer method's own settings; `{method}` is \
                     softbench's own method (peer methods: {})",
                    peer_names().join(", ")
                ),
            ));
        }
        return Ok(());
    };
    let resolved = facts
        .resolve(method.name(), c.integrator.peer.values())
        .map_err(|e| refuse(&e.key, e.message))?;
    c.integrator.peer = PeerSettings::new(resolved);
    Ok(())
}

/// The registered peer methods, for messages.
fn peer_names() -> Vec<&'static str> {
    softbench_core::integrate::Method::all()
        .into_iter()
        .filter(|m| m.entry().peer.is_some())
        .map(|m| m.name())
        .collect()
}

/// Refuse what the scene's peer method cannot run. Peers run one elastic tet body with a lumped
/// mass, gravity and fixed vertices; every refusal names the key to change.
pub(super) fn validate(c: &SceneConfig) -> Result<(), Refusal> {
    let method = c.integrator.method.name();
    let Some(facts) = c.integrator.method.entry().peer else {
        return Ok(());
    };
    let peer = |what: &str| {
        format!(
            "`{method}` runs {}'s own implementation, which {what}",
            facts.package
        )
    };
    if facts.version.is_none() {
        return Err(refuse(
            "integrator.method",
            format!(
                "`{method}` runs {}'s own code, which is not installed here: {}",
                facts.package, facts.install
            ),
        ));
    }
    if c.springs.is_some() || c.jello.is_some() {
        let key = if c.springs.is_some() {
            "springs"
        } else {
            "jello"
        };
        return Err(refuse(key, peer("has no mass-spring bodies")));
    }
    let Some(material) = &c.material else {
        return Err(refuse("material", peer("needs an elastic tet body")));
    };
    check_material(facts, method, &material.model)?;
    if material.mass == MassKind::Consistent {
        return Err(refuse(
            "material.mass",
            peer("has a lumped mass only: set material.mass = \"lumped\""),
        ));
    }
    if c.damping.rayleigh.is_some() {
        return Err(refuse(
            "damping.rayleigh",
            peer("has no Rayleigh damping of softbench's form"),
        ));
    }
    if c.damping.strain_rate.is_some() {
        return Err(refuse(
            "damping.strain_rate",
            peer("has no strain-rate damping"),
        ));
    }
    if !c.drag.is_empty() {
        return Err(refuse("drag", peer("has no drag springs")));
    }
    if !c.obstacles.is_empty() {
        return Err(refuse(
            "obstacles[0]",
            peer("is run without contact here: softbench passes it no obstacles"),
        ));
    }
    if c.contact.ipc.self_contact && c.contact.response.facts().self_contact {
        return Err(refuse(
            "contact.ipc.self_contact",
            peer("is run without contact here: softbench passes it no self-contact"),
        ));
    }
    Ok(())
}

fn check_material(facts: &PeerFacts, method: &str, model: &str) -> Result<(), Refusal> {
    if facts.materials.iter().any(|m| m == model) {
        return Ok(());
    }
    Err(refuse(
        "material.model",
        format!(
            "`{method}` runs {}'s own implementation, which has no \"{model}\" material; it has \
             \"{}\"",
            facts.package,
            facts.materials.join("\", \"")
        ),
    ))
}
