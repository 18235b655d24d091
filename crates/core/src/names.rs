//! Choosing among named options: the message for an unknown name lists the valid ones and
//! suggests the closest (by edit distance), so `rk5` gets "did you mean `rk4`?".

/// Levenshtein distance between two strings (by chars).
fn edit_distance(a: &str, b: &str) -> usize {
    let b: Vec<char> = b.chars().collect();
    let mut row: Vec<usize> = (0..=b.len()).collect();
    for (i, ca) in a.chars().enumerate() {
        let mut diagonal = row[0];
        row[0] = i + 1;
        for (j, &cb) in b.iter().enumerate() {
            let substitute = diagonal + usize::from(ca != cb);
            diagonal = row[j + 1];
            row[j + 1] = substitute.min(row[j] + 1).min(row[j + 1] + 1);
        }
    }
    row[b.len()]
}

/// The candidate closest to `name`, if it is close enough to be a plausible typo (at most a
/// third of the name's length, and at least 1, edits away).
pub fn closest<'a>(name: &str, candidates: &[&'a str]) -> Option<&'a str> {
    let limit = (name.chars().count() / 3).max(1);
    candidates
        .iter()
        .map(|c| (edit_distance(&name.to_lowercase(), c), *c))
        .filter(|(d, _)| *d <= limit)
        .min_by_key(|(d, _)| *d)
        .map(|(_, c)| c)
}

/// "unknown {what} `name`; did you mean `x`? (valid: a, b, c)".
pub fn unknown_name_message(what: &str, name: &str, candidates: &[&str]) -> String {
    let hint =
        closest(name, candidates).map_or(String::new(), |c| format!("; did you mean `{c}`?"));
    format!(
        "unknown {what} `{name}`{hint} (valid: {})",
        candidates.join(", ")
    )
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn suggests_the_closest_name_for_a_typo() {
        let names = ["rk4", "midpoint", "backward-euler", "bdf2"];
        assert_eq!(closest("rk5", &names), Some("rk4"));
        assert_eq!(closest("backward_euler", &names), Some("backward-euler"));
        assert_eq!(closest("Midpoint", &names), Some("midpoint"));
        assert_eq!(closest("verlet", &names), None);
    }

    #[test]
    fn message_lists_every_valid_name() {
        let msg = unknown_name_message("integrator", "rk5", &["rk4", "bdf2"]);
        assert_eq!(
            msg,
            "unknown integrator `rk5`; did you mean `rk4`? (valid: rk4, bdf2)"
        );
    }
}
