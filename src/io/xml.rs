//! Text for the XML that kinechain writes (URDF from `convert`, SVG from `render`).

use std::fmt::Write as _;

/// Whether an XML 1.0 document can hold `c` at all (escaped or not).
fn allowed(c: char) -> bool {
    !matches!(c, '\u{0}'..='\u{8}' | '\u{b}' | '\u{c}' | '\u{e}'..='\u{1f}' | '\u{fffe}' | '\u{ffff}')
}

/// `text` for element content or a double-quoted attribute value: `&`, `<`, `>` and `"` escaped,
/// and tab, line feed and carriage return as character references (which an attribute keeps;
/// written as they are, a reader turns them into spaces). A character that no XML 1.0 document
/// can hold (the other control characters, U+FFFE and U+FFFF) is passed to `invalid`, which
/// gives what to write instead or the error.
fn escape_with<E>(text: &str, invalid: impl Fn(char) -> Result<char, E>) -> Result<String, E> {
    let mut out = String::with_capacity(text.len());
    for c in text.chars() {
        match c {
            '&' => out.push_str("&amp;"),
            '<' => out.push_str("&lt;"),
            '>' => out.push_str("&gt;"),
            '"' => out.push_str("&quot;"),
            // (Writing to a `String` cannot fail.)
            '\t' | '\n' | '\r' => {
                let _ = write!(out, "&#{};", u32::from(c));
            }
            c if !allowed(c) => out.push(invalid(c)?),
            c => out.push(c),
        }
    }
    Ok(out)
}

/// [`escape_with`] for text that must be kept exactly (a URDF name).
///
/// # Errors
/// The first character that no XML 1.0 document can hold.
pub(crate) fn escape(text: &str) -> Result<String, char> {
    escape_with(text, Err)
}

/// [`escape_with`] for text that is only shown (names in a drawing): a character XML cannot hold
/// becomes U+FFFD, the replacement character.
pub(crate) fn escape_shown(text: &str) -> String {
    match escape_with(text, |_| Ok::<_, std::convert::Infallible>('\u{fffd}')) {
        Ok(shown) => shown,
        Err(never) => match never {},
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn markup_and_control_characters() {
        assert_eq!(
            escape("a&b<c>\"d\"").unwrap(),
            "a&amp;b&lt;c&gt;&quot;d&quot;"
        );
        assert_eq!(escape("a\tb\nc\r").unwrap(), "a&#9;b&#10;c&#13;");
        assert_eq!(escape("a\u{1}b"), Err('\u{1}'));
        assert_eq!(escape("\u{ffff}"), Err('\u{ffff}'));
        assert_eq!(escape_shown("a\u{1}<b"), "a\u{fffd}&lt;b");
    }
}
