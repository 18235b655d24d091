//! Quoting user input in error messages: at most a short line of it.
//!
//! Messages quote what they found (`` found `abc` ``), and the TOML parser shows the offending
//! line with a caret; for a file that is one huge line — `/proc/self/environ`, a binary, a
//! minified dump — that would print the whole file. [`clip_message`] keeps quotes and lines
//! short.

/// Longest line of a message, in characters.
pub const MAX_LINE: usize = 500;
/// Longest line of a parser's message, which echoes lines of the file itself.
pub const MAX_SOURCE_LINE: usize = 160;
/// Longest `` `quoted` `` span of a message, in characters.
pub const MAX_QUOTE: usize = 60;

/// `message` with every backtick-quoted span cut to [`MAX_QUOTE`] characters, every line to
/// [`MAX_LINE`] (cuts marked with `...`), at most 12 lines, and control characters other
/// than tabs and newlines shown as `?`.
pub fn clip_message(message: &str) -> String {
    clip(message, MAX_LINE)
}

/// [`clip_message`] for a parser's message (TOML), which shows lines of the file: each line is
/// cut to [`MAX_SOURCE_LINE`] characters.
pub fn clip_source(message: &str) -> String {
    clip(message, MAX_SOURCE_LINE)
}

fn clip(message: &str, max_line: usize) -> String {
    let mut out = Vec::new();
    for (i, line) in message.lines().enumerate() {
        if i == 12 {
            out.push("...".to_owned());
            break;
        }
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
    fn a_long_line_is_clipped_and_nul_bytes_hidden() {
        let long = format!("a\0b{}", "x".repeat(10_000));
        let clipped = clip_source(&long);
        assert!(clipped.len() < MAX_SOURCE_LINE + 10);
        assert!(clipped.starts_with("a?b"));
        assert!(clipped.ends_with("..."));
    }

    #[test]
    fn a_long_quote_is_clipped_and_the_rest_of_the_message_kept() {
        let message = format!("found `{}` at the end", "y".repeat(5_000));
        let clipped = clip_message(&message);
        assert!(clipped.ends_with("...` at the end"), "{clipped}");
        assert!(clipped.len() < 100);
    }
}
