//! Quoting user input in error messages: at most a short line of it.
//!
//! Messages quote what they found (`` found `abc` ``), and the TOML parser shows the offending
//! line with a caret; for a file that is one huge line — `/proc/self/environ`, a binary, a
//! minified dump — that would print the whole file. [`clip_message`] keeps quotes and lines
//! short.

/// Longest line of a message, in characters.
pub const MAX_LINE: usize = 1000;
/// Longest line of a parser's message that echoes a line of the file itself (`12 | ...`).
pub const MAX_SOURCE_LINE: usize = 80;
/// Longest `` `quoted` `` span of a message, in characters.
pub const MAX_QUOTE: usize = 60;

/// `message` with every backtick-quoted span cut to [`MAX_QUOTE`] characters, every line to
/// [`MAX_LINE`] (cuts marked with `...`), at most 12 lines, and control characters other
/// than tabs and newlines shown as `?`.
pub fn clip_message(message: &str) -> String {
    clip(message, MAX_LINE)
}

/// [`clip_message`] for a parser's message (TOML), which shows lines of the file as
/// `12 | text`: those are cut to [`MAX_SOURCE_LINE`] characters.
pub fn clip_source(message: &str) -> String {
    clip(message, MAX_SOURCE_LINE)
}

/// Whether a line of a TOML parser message echoes the file (`12 | text`).
fn echoes_source(line: &str) -> bool {
    let t = line.trim_start();
    let digits = t.bytes().take_while(u8::is_ascii_digit).count();
    digits > 0 && t[digits..].starts_with(" |")
}

fn clip(message: &str, max_source_line: usize) -> String {
    let mut out = Vec::new();
    for (i, line) in message.lines().enumerate() {
        if i == 12 {
            out.push("...".to_owned());
            break;
        }
        let max_line = if echoes_source(line) {
            max_source_line
        } else {
            MAX_LINE
        };
        let line = clip_quotes(line);
        let mut clipped: String = line
            .chars()
            .take(max_line)
            .map(|c| if c.is_control() && c != '\t' { '?' } else { c })
            .collect();
        if line.chars().nth(max_line).is_some() {
            clipped.push_str("...");
        }
        out.push(clipped);
    }
    out.join("\n")
}

/// Cuts the inside of each `` `...` `` span of one line to [`MAX_QUOTE`] characters.
fn clip_quotes(line: &str) -> String {
    let mut out = String::with_capacity(line.len().min(4 * MAX_LINE));
    for (i, part) in line.split('`').enumerate() {
        if i > 0 {
            out.push('`');
        }
        // Odd parts are inside quotes.
        if i % 2 == 1 && part.chars().nth(MAX_QUOTE).is_some() {
            out.extend(part.chars().take(MAX_QUOTE));
            out.push_str("...");
        } else {
            out.push_str(part);
        }
    }
    out
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn an_echoed_source_line_is_clipped_and_nul_bytes_hidden() {
        let long = format!(
            "error\n1 | a\0b{}\n  |   ^\nexpected `=`",
            "x".repeat(10_000)
        );
        let clipped = clip_source(&long);
        let echoed = clipped.lines().nth(1).unwrap();
        assert!(
            echoed.starts_with("1 | a?b") && echoed.ends_with("..."),
            "{echoed}"
        );
        assert!(echoed.len() < MAX_SOURCE_LINE + 10);
        assert!(clipped.ends_with("expected `=`"));
    }

    #[test]
    fn a_long_message_line_is_kept_up_to_max_line() {
        let list = "name, ".repeat(100);
        assert_eq!(clip_source(&list), list);
        assert!(clip_message(&"z".repeat(5000)).len() < MAX_LINE + 10);
    }

    #[test]
    fn a_long_quote_is_clipped_and_the_rest_of_the_message_kept() {
        let message = format!("found `{}` at the end", "y".repeat(5_000));
        let clipped = clip_message(&message);
        assert!(clipped.ends_with("...` at the end"), "{clipped}");
        assert!(clipped.len() < 100);
    }
}
