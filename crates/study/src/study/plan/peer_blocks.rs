//! `[[methods]]` blocks of peer methods (the field's own implementations, registered by the
//! Python package: see `docs/peers.md`). A block says whose code it runs with
//! `peer = "<package>"`, so a study file that names peers runs under either command: under
//! `python -m softbench` the peer is registered and the block is an ordinary method block;
//! under the `softbench` binary, which registers no peer, the block is left out of the study
//! and recorded as an omission saying how to run it — never silently dropped, and a typo in
//! a method name without `peer` is still an error.

use crate::study::vocabulary::config::StudyFile;
use crate::study::vocabulary::context::Context;
use crate::study::vocabulary::error::StudyError;
use crate::study::vocabulary::spec::Omission;
use softbench_core::integrate::Method;

/// The key of a `[[methods]]` block naming the package of a peer method.
pub const PEER_KEY: &str = "peer";

/// Take the `peer` key out of every `[[methods]]` block; drop the blocks whose peer method is
/// not registered here and return them as omissions. A `peer` naming another package than
/// the registered method's, or set on softbench's own method, is an error.
pub fn take_peer_blocks(file: &mut StudyFile, ctx: &Context) -> Result<Vec<Omission>, StudyError> {
    let mut omitted = Vec::new();
    let mut kept = Vec::with_capacity(file.methods.len());
    for (i, mut block) in std::mem::take(&mut file.methods).into_iter().enumerate() {
        let at = block.span().start;
        let key = format!("methods[{i}].{PEER_KEY}");
        let Some(package) = block.get_mut().remove(PEER_KEY) else {
            kept.push(block);
            continue;
        };
        let Some(package) = package.as_str().map(str::to_owned) else {
            return Err(ctx.invalid(
                at,
                &key,
                "must be the peer's package as a string (`peer = \"pbatoolkit\"`)",
            ));
        };
        let Some(name) = block
            .get_ref()
            .get("method")
            .and_then(toml::Value::as_str)
            .map(str::to_owned)
        else {
            return Err(ctx.invalid(at, &key, "a peer block needs `method = \"...\"`"));
        };
        match Method::from_name(&name) {
            Ok(method) => match method.entry().peer {
                Some(facts) if facts.package == package => kept.push(block),
                Some(facts) => {
                    return Err(ctx.invalid(
                        at,
                        &key,
                        format!(
                            "`{name}` runs {}'s code, not {package}'s: set `peer = \"{}\"`",
                            facts.package, facts.package
                        ),
                    ));
                }
                None => {
                    return Err(ctx.invalid(
                        at,
                        &key,
                        format!(
                            "`{name}` is softbench's own method: `peer` names the package of a \
                             peer method (see docs/peers.md)"
                        ),
                    ));
                }
            },
            Err(_) => omitted.push(Omission {
                scene: String::new(),
                method: Some(name.clone()),
                reason: format!(
                    "a peer method ({package}'s own code), not registered by this command: \
                     run the study with `python -m softbench` after `pip install \".[peers]\"` \
                     (docs/peers.md)"
                ),
            }),
        }
    }
    if kept.is_empty() && !omitted.is_empty() {
        let names: Vec<&str> = omitted.iter().filter_map(|o| o.method.as_deref()).collect();
        return Err(ctx.invalid(
            0,
            "methods",
            format!(
                "every [[methods]] block names a peer method this command has not registered \
                 ({}), so nothing is left to run: run the study with `python -m softbench` \
                 after `pip install \".[peers]\"` (docs/peers.md)",
                names.join(", ")
            ),
        ));
    }
    file.methods = kept;
    Ok(omitted)
}
