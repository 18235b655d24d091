//! How numbers and times are written in tables, ids and reports.

/// A number as short as it stays exact enough to read: `0.01`, `2.5e-5`, `6e5`, `1.234`.
pub fn short(x: f64) -> String {
    if x == 0.0 || !x.is_finite() {
        return format!("{x}");
    }
    // Four significant digits, written plainly when that is short.
    let exp = tidy_exp(&format!("{x:.3e}"));
    let plain = exp
        .parse::<f64>()
        .map(|v| format!("{v}"))
        .unwrap_or_default();
    if !plain.is_empty() && plain.len() <= exp.len() + 1 {
        plain
    } else {
        exp
    }
}

/// `2.500e-5` -> `2.5e-5`.
fn tidy_exp(s: &str) -> String {
    match s.split_once('e') {
        Some((m, e)) => {
            let m = if m.contains('.') {
                m.trim_end_matches('0').trim_end_matches('.')
            } else {
                m
            };
            format!("{m}e{e}")
        }
        None => s.to_owned(),
    }
}

/// A number for a CSV cell: full precision, empty for "no value".
pub fn cell(x: Option<f64>) -> String {
    match x {
        Some(v) if v.is_finite() => format!("{v:e}"),
        Some(v) => format!("{v}"),
        None => String::new(),
    }
}

/// Seconds since the Unix epoch as an ISO 8601 UTC time, `2026-11-21T10:02:03Z`.
pub fn utc(seconds: u64) -> String {
    let days = (seconds / 86_400) as i64;
    let rem = seconds % 86_400;
    // Civil date from days since 1970-01-01 (H. Hinnant's algorithm).
    let z = days + 719_468;
    let era = z.div_euclid(146_097);
    let doe = z - era * 146_097;
    let yoe = (doe - doe / 1460 + doe / 36_524 - doe / 146_096) / 365;
    let doy = doe - (365 * yoe + yoe / 4 - yoe / 100);
    let mp = (5 * doy + 2) / 153;
    let d = doy - (153 * mp + 2) / 5 + 1;
    let m = if mp < 10 { mp + 3 } else { mp - 9 };
    let y = yoe + era * 400 + i64::from(m <= 2);
    format!(
        "{y:04}-{m:02}-{d:02}T{:02}:{:02}:{:02}Z",
        rem / 3600,
        rem % 3600 / 60,
        rem % 60
    )
}

/// The current time as [`utc`].
pub fn now_utc() -> String {
    let s = std::time::SystemTime::now()
        .duration_since(std::time::UNIX_EPOCH)
        .map_or(0, |d| d.as_secs());
    utc(s)
}

/// Seconds since the Unix epoch.
pub fn epoch_seconds() -> u64 {
    std::time::SystemTime::now()
        .duration_since(std::time::UNIX_EPOCH)
        .map_or(0, |d| d.as_secs())
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn short_numbers() {
        assert_eq!(short(0.01), "0.01");
        assert_eq!(short(2.5e-5), "2.5e-5");
        assert_eq!(short(6e5), "6e5");
        assert_eq!(short(1.5), "1.5");
        assert_eq!(short(0.00125), "0.00125");
        assert_eq!(short(100.0), "100");
    }

    #[test]
    fn utc_dates() {
        assert_eq!(utc(0), "1970-01-01T00:00:00Z");
        assert_eq!(utc(951_782_400), "2000-02-29T00:00:00Z");
        assert_eq!(utc(1_795_262_523), "2026-11-21T12:02:03Z");
    }
}
