//! The pre-shared token of a wall: read from a file on the station and on every node,
//! sent as `authorization: Bearer <token>` with every call, compared in constant time.

use std::path::Path;

use crate::limits::{MAX_TOKEN_FILE_BYTES, MIN_TOKEN_CHARS};

/// A wall's pre-shared secret.
#[derive(Clone)]
pub struct Token(String);

impl std::fmt::Debug for Token {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        f.write_str("Token(<hidden>)")
    }
}

/// A token file that cannot be used.
#[derive(Debug, thiserror::Error)]
pub enum TokenError {
    /// The file cannot be read.
    #[error("cannot read token file {path}: {source}")]
    Io {
        /// The file.
        path: String,
        /// The cause.
        source: std::io::Error,
    },
    /// The file's content is not a usable token.
    #[error("token file {path}: {reason}")]
    Invalid {
        /// The file.
        path: String,
        /// What is wrong.
        reason: String,
    },
}

impl Token {
    /// Reads a token file: one line of at least 16 printable ASCII characters (no
    /// spaces); surrounding whitespace and a final newline are ignored. Generate one
    /// with e.g. `head -c 24 /dev/urandom | base64 > wall.token`.
    pub fn from_file(path: &Path) -> Result<Token, TokenError> {
        let shown = path.display().to_string();
        let io = |source| TokenError::Io {
            path: shown.clone(),
            source,
        };
        let len = std::fs::metadata(path).map_err(io)?.len();
        if len > MAX_TOKEN_FILE_BYTES {
            return Err(TokenError::Invalid {
                path: shown,
                reason: format!("{len} bytes; a token file holds one short line"),
            });
        }
        let text = std::fs::read_to_string(path).map_err(io)?;
        Token::new(text.trim()).map_err(|reason| TokenError::Invalid {
            path: shown,
            reason,
        })
    }

    /// A token from its text; at least [`MIN_TOKEN_CHARS`] printable ASCII characters
    /// without spaces.
    pub fn new(text: &str) -> Result<Token, String> {
        if text.len() < MIN_TOKEN_CHARS {
            return Err(format!(
                "the token has {} characters, at least {MIN_TOKEN_CHARS} are needed",
                text.len()
            ));
        }
        if !text.bytes().all(|b| b.is_ascii_graphic()) {
            return Err("the token must be printable ASCII without spaces".into());
        }
        Ok(Token(text.to_string()))
    }

    /// The value of the `authorization` header that carries this token.
    pub fn header_value(&self) -> String {
        format!("Bearer {}", self.0)
    }

    /// Whether `header` (the `authorization` value of a call) carries this token;
    /// compared in time independent of where the first difference is.
    pub fn accepts(&self, header: &[u8]) -> bool {
        let want = self.header_value();
        let want = want.as_bytes();
        if header.len() != want.len() {
            return false;
        }
        header
            .iter()
            .zip(want)
            .fold(0u8, |acc, (a, b)| acc | (a ^ b))
            == 0
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn short_or_spaced_tokens_are_refused_and_the_right_header_is_accepted() {
        assert!(Token::new("short").is_err());
        assert!(Token::new("has a space in it!!").is_err());
        let t = Token::new("0123456789abcdefXYZ").unwrap();
        assert!(t.accepts(b"Bearer 0123456789abcdefXYZ"));
        assert!(!t.accepts(b"Bearer 0123456789abcdefXYz"));
        assert!(!t.accepts(b"0123456789abcdefXYZ"));
        assert_eq!(format!("{t:?}"), "Token(<hidden>)");
    }
}
