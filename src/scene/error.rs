//! [`SceneError`]: one line, `FILE:LINE:COL: KEY.PATH: what is wrong`.

use crate::field::FieldError;

/// What kind of mistake a [`SceneError`] reports.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum SceneErrorKind {
    /// The scene file could not be read.
    Io,
    /// The file (or a `--set`) is not valid TOML, or a `--set` is not `KEY=VALUE`.
    Syntax,
    /// A key the scene format does not have (or not for this source / shape).
    UnknownKey,
    /// A required key is absent.
    Missing,
    /// A value of the wrong TOML type.
    Type,
    /// A value of the right type but out of range or otherwise invalid.
    Value,
    /// A data file (or expression, or the memory cap) refused the field.
    Data,
}

/// A scene that cannot be used. `Display` is one line:
///
/// ```text
/// scenes/t.toml:12:14: field.resolution: every axis needs at least 2 points, got [1, 48, 48]
/// --set render.steps=abc: render.steps: expected an integer, got string "abc"
/// scenes/t.toml:3:9: invalid TOML: unclosed array, expected `]`
/// ```
#[derive(Clone, Debug, PartialEq, thiserror::Error)]
#[error("{location}: {}{message}", key.as_ref().map(|k| format!("{k}: ")).unwrap_or_default())]
pub struct SceneError {
    /// `FILE:LINE:COL` (1-based; the column counts characters), `FILE` for errors about the
    /// whole file, or `--set KEY=VALUE` for an override.
    pub location: String,
    /// The dotted key path (`field.resolution`), when the error is about one key.
    pub key: Option<String>,
    /// What is wrong.
    pub message: String,
    pub kind: SceneErrorKind,
    /// The underlying data error, for `SceneErrorKind::Data`.
    pub field_error: Option<Box<FieldError>>,
}

impl SceneError {
    pub(crate) fn new(
        kind: SceneErrorKind,
        location: impl Into<String>,
        key: Option<String>,
        message: impl AsRef<str>,
    ) -> SceneError {
        SceneError {
            // The location holds the scene's path: a newline in it is escaped (`\n`), as in
            // every path a message names, not folded into a space by `one_line`.
            location: one_line(&crate::vocab::escape_unprintable(&location.into())),
            key,
            message: one_line(message.as_ref()),
            kind,
            field_error: None,
        }
    }
}

/// Keeps a message on one line (newlines and runs of spaces become one space).
pub(crate) fn one_line(s: &str) -> String {
    if s.contains(['\n', '\r']) {
        s.split_whitespace().collect::<Vec<_>>().join(" ")
    } else {
        s.to_string()
    }
}
