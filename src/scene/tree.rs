//! The scene file as a tree of TOML values that remember where they were written: a position
//! in the file, or the `--set` override that put them there. Validation reads this tree, so
//! every error can point at the key or value it is about.

use std::collections::BTreeMap;
use std::io::Read;
use std::path::Path;

use toml::de::{DeTable, DeValue};
use toml::Spanned;

use super::error::{SceneError, SceneErrorKind};
use crate::vocab::echo;

/// The largest scene file read: 16 MiB. A scene is a page of keys (data lives in the files
/// `field.path` names); anything larger is a mistake, such as a data file given as the
/// scene, and is refused before it is read.
pub const MAX_SCENE_BYTES: u64 = 16 << 20;

/// Reads the scene file at `path` (`name` in errors) as text. Only a regular file of at most
/// [`MAX_SCENE_BYTES`] is read: `/dev/zero` would never end and a FIFO would block until
/// someone writes to it, so both are refused, from the file's type, before it is opened.
pub(crate) fn read_scene(path: &Path, name: &str) -> Result<String, SceneError> {
    let fail = |what: String| {
        SceneError::new(SceneErrorKind::Io, name, None, format!("cannot read scene: {what}"))
    };
    let io = |e: std::io::Error| {
        fail(match e.kind() {
            std::io::ErrorKind::NotFound => "file not found".to_string(),
            std::io::ErrorKind::PermissionDenied => "permission denied".to_string(),
            _ => e.to_string(),
        })
    };
    let too_large = |bytes: String| {
        fail(format!(
            "{bytes} bytes is over the {} MiB a scene file may have (data goes in the file that \
             field.path names)",
            MAX_SCENE_BYTES >> 20
        ))
    };
    let meta = std::fs::metadata(path).map_err(io)?;
    if let Some(kind) = crate::vocab::special_file(&meta) {
        return Err(fail(format!("is {kind}, not a scene file")));
    }
    if meta.len() > MAX_SCENE_BYTES {
        return Err(too_large(meta.len().to_string()));
    }
    // The file may have grown since: read one byte past the cap at most. It may also have been
    // replaced by a FIFO since (a server reads its scene again later): opened without waiting.
    let mut bytes = Vec::new();
    crate::vocab::open_regular(path, "a scene file")
        .and_then(|f| f.take(MAX_SCENE_BYTES + 1).read_to_end(&mut bytes))
        .map_err(io)?;
    if bytes.len() as u64 > MAX_SCENE_BYTES {
        return Err(too_large(format!("more than {MAX_SCENE_BYTES}")));
    }
    String::from_utf8(bytes).map_err(|e| {
        // Point at the line of the first invalid byte.
        let valid = &e.as_bytes()[..e.utf8_error().valid_up_to()];
        let line = valid.iter().filter(|&&b| b == b'\n').count() + 1;
        SceneError::new(
            SceneErrorKind::Syntax,
            format!("{name}:{line}"),
            None,
            "invalid TOML: the file is not UTF-8",
        )
    })
}

/// Where a key or value was written.
#[derive(Clone, Copy, Debug, PartialEq, Eq, PartialOrd, Ord)]
pub(crate) enum Origin {
    /// 1-based line and column (in characters) in the scene file.
    File { line: usize, col: usize },
    /// The `--set` override with this index.
    Override(usize),
}

impl Origin {
    /// The start of the file, for errors about something absent from it.
    pub(crate) const START: Origin = Origin::File { line: 1, col: 1 };
}

/// A TOML value and where it was written.
#[derive(Clone, Debug)]
pub(crate) struct Node {
    pub value: Value,
    pub at: Origin,
}

#[derive(Clone, Debug)]
pub(crate) enum Value {
    String(String),
    Integer(i64),
    Float(f64),
    Boolean(bool),
    Datetime(String),
    Array(Vec<Node>),
    Table(Table),
}

impl Value {
    /// The TOML type's name, for messages.
    pub(crate) fn type_name(&self) -> &'static str {
        match self {
            Value::String(_) => "string",
            Value::Integer(_) => "integer",
            Value::Float(_) => "float",
            Value::Boolean(_) => "boolean",
            Value::Datetime(_) => "datetime",
            Value::Array(_) => "array",
            Value::Table(_) => "table",
        }
    }
}

/// A TOML table; entries are kept with the position of their key.
#[derive(Clone, Debug, Default)]
pub(crate) struct Table {
    pub entries: BTreeMap<String, Entry>,
}

#[derive(Clone, Debug)]
pub(crate) struct Entry {
    /// Where the key was written.
    pub key_at: Origin,
    pub node: Node,
}

impl Table {
    pub(crate) fn get(&self, key: &str) -> Option<&Node> {
        self.entries.get(key).map(|e| &e.node)
    }
}

/// The text being parsed, for turning byte offsets into positions and positions into
/// `file:line:col` or `--set KEY=VALUE`.
pub(crate) struct Source<'a> {
    /// The file name as shown in errors.
    pub name: &'a str,
    text: &'a str,
    line_starts: Vec<usize>,
    pub overrides: &'a [String],
}

impl<'a> Source<'a> {
    pub(crate) fn new(name: &'a str, text: &'a str, overrides: &'a [String]) -> Source<'a> {
        let mut line_starts = vec![0];
        line_starts.extend(text.match_indices('\n').map(|(i, _)| i + 1));
        Source { name, text, line_starts, overrides }
    }

    /// The position of byte `offset` of the file.
    pub(crate) fn origin(&self, offset: usize) -> Origin {
        let offset = offset.min(self.text.len());
        let line = self.line_starts.partition_point(|&s| s <= offset);
        let start = self.line_starts[line - 1];
        let col = self.text.get(start..offset).map_or(offset - start, |s| s.chars().count()) + 1;
        Origin::File { line, col }
    }

    /// `file:line:col` or `--set KEY=VALUE`.
    pub(crate) fn location(&self, at: Origin) -> String {
        match at {
            Origin::File { line, col } => format!("{}:{line}:{col}", self.name),
            Origin::Override(i) => {
                format!("--set {}", echo(self.overrides.get(i).map_or("?", String::as_str)))
            }
        }
    }

    /// An error about `key` at `at`.
    pub(crate) fn err(
        &self,
        kind: SceneErrorKind,
        at: Origin,
        key: &str,
        message: impl AsRef<str>,
    ) -> SceneError {
        // A key path may come from a --set: echoed like any value the user wrote.
        let key = (!key.is_empty()).then(|| echo(key));
        SceneError::new(kind, self.location(at), key, message)
    }

    /// Parses the whole file.
    pub(crate) fn parse(&self) -> Result<Node, SceneError> {
        let doc = DeTable::parse(self.text).map_err(|e| {
            let at = self.origin(e.span().map_or(0, |s| s.start));
            SceneError::new(
                SceneErrorKind::Syntax,
                self.location(at),
                None,
                format!("invalid TOML: {}", e.message()),
            )
        })?;
        let table = self.convert_table(doc.get_ref(), "", None)?;
        Ok(Node { value: Value::Table(table), at: Origin::START })
    }

    fn convert_table(
        &self,
        table: &DeTable<'_>,
        path: &str,
        over: Option<usize>,
    ) -> Result<Table, SceneError> {
        let mut out = Table::default();
        for (k, v) in table.iter() {
            let name = k.get_ref().to_string();
            let key_path = join(path, &name);
            let key_at = match over {
                Some(i) => Origin::Override(i),
                None => self.origin(k.span().start),
            };
            let node = self.convert(v, &key_path, over)?;
            out.entries.insert(name, Entry { key_at, node });
        }
        Ok(out)
    }

    fn convert(
        &self,
        v: &Spanned<DeValue<'_>>,
        path: &str,
        over: Option<usize>,
    ) -> Result<Node, SceneError> {
        let at = match over {
            Some(i) => Origin::Override(i),
            None => self.origin(v.span().start),
        };
        let out_of_range = |what: &str| {
            // Cut: the number is the user's text, of any length (`--set` and serve's page).
            let what = crate::vocab::echo(what);
            self.err(SceneErrorKind::Value, at, path, format!("{what} is out of range"))
        };
        let value = match v.get_ref() {
            DeValue::String(s) => Value::String(s.to_string()),
            DeValue::Integer(i) => Value::Integer(
                i64::from_str_radix(i.as_str(), i.radix())
                    .map_err(|_| out_of_range(&format!("integer {i}")))?,
            ),
            DeValue::Float(f) => {
                let x: f64 = f.as_str().parse().map_err(|_| out_of_range(&format!("float {f}")))?;
                if x.is_infinite() && !f.as_str().contains("inf") {
                    return Err(out_of_range(&format!("float {f}")));
                }
                Value::Float(x)
            }
            DeValue::Boolean(b) => Value::Boolean(*b),
            DeValue::Datetime(d) => Value::Datetime(d.to_string()),
            DeValue::Array(items) => Value::Array(
                items
                    .iter()
                    .map(|item| self.convert(item, path, over))
                    .collect::<Result<_, _>>()?,
            ),
            DeValue::Table(t) => Value::Table(self.convert_table(t, path, over)?),
        };
        Ok(Node { value, at })
    }

    /// Applies override `index` (`KEY=VALUE`, VALUE in TOML syntax or else a plain string) to
    /// `root`, creating tables along the key path as needed.
    pub(crate) fn apply_override(&self, root: &mut Node, index: usize) -> Result<(), SceneError> {
        let at = Origin::Override(index);
        let text = self.overrides.get(index).map_or("", String::as_str);
        let syntax = |message: &str| self.err(SceneErrorKind::Syntax, at, "", message);
        let Some((key, value)) = text.split_once('=') else {
            return Err(syntax("expected KEY=VALUE, e.g. --set render.steps=64"));
        };
        let key = key.trim();
        let segments: Vec<&str> = key.split('.').map(str::trim).collect();
        let bare = |s: &str| {
            !s.is_empty() && s.chars().all(|c| c.is_ascii_alphanumeric() || c == '_' || c == '-')
        };
        // Scene keys are at most 3 deep (field.bounds.min); a path of thousands of segments
        // would build as many nested tables, whose recursive walks and drops overflowed the
        // stack (a 40 KB `POST /api/state` aborted `serve`).
        if segments.len() > MAX_KEY_SEGMENTS {
            return Err(syntax(&format!(
                "a key path of {} segments; scene keys have at most {MAX_KEY_SEGMENTS}",
                segments.len()
            )));
        }
        if !segments.iter().all(|s| bare(s)) {
            return Err(syntax(&format!(
                "\"{}\" is not a key path like render.steps or field.bounds.min",
                echo(key)
            )));
        }
        let value = value.trim();
        let node =
            match DeValue::parse(value) {
                Ok(v) => self.convert(&v, key, Some(index))?,
                // A quoted value that TOML refuses is a string the user meant but mistyped: taken
                // bare, its quotes would be echoed inside the message's own (`""bo\u{1b}g""`).
                Err(_) if value.starts_with(['"', '\'']) => return Err(syntax(
                    "the value is quoted but not a TOML string (a quote left open, or a control \
                     character that TOML strings must escape, e.g. \\u001b)",
                )),
                Err(_) => Node { value: Value::String(value.to_string()), at },
            };

        let Value::Table(root_table) = &mut root.value else {
            return Err(syntax("the scene is not a table"));
        };
        let mut table: &mut Table = root_table;
        let (last, parents) = segments.split_last().ok_or_else(|| syntax("empty key"))?;
        let mut path = String::new();
        for seg in parents {
            path = join(&path, seg);
            let entry = table.entries.entry(seg.to_string()).or_insert_with(|| Entry {
                key_at: at,
                node: Node { value: Value::Table(Table::default()), at },
            });
            match &mut entry.node.value {
                Value::Table(t) => table = t,
                other => {
                    let ty = other.type_name();
                    return Err(self.err(
                        SceneErrorKind::Type,
                        at,
                        &path,
                        format!("is {} {ty}, not a table", article(ty)),
                    ));
                }
            }
        }
        table.entries.insert(last.to_string(), Entry { key_at: at, node });
        Ok(())
    }
}

/// Most dot-separated segments a `--set` key path may have: every scene key has 3 or fewer.
pub const MAX_KEY_SEGMENTS: usize = 16;

/// `a.b` from `a` and `b` (just `b` at the root).
pub(crate) fn join(path: &str, key: &str) -> String {
    if path.is_empty() {
        key.to_string()
    } else {
        format!("{path}.{key}")
    }
}

/// "a" or "an" before a type name.
pub(crate) fn article(word: &str) -> &'static str {
    if word.starts_with(['a', 'e', 'i', 'o', 'u']) {
        "an"
    } else {
        "a"
    }
}

/// A short rendering of a value for messages: `"abc"`, `[1, 48, 48]`, `{min = [0, 0, 0]}`
/// (cut by [`echo`] when long).
pub(crate) fn show(node: &Node) -> String {
    let s = match &node.value {
        Value::String(s) => format!("{s:?}"),
        Value::Integer(i) => i.to_string(),
        Value::Float(f) => show_float(*f),
        Value::Boolean(b) => b.to_string(),
        Value::Datetime(d) => d.clone(),
        Value::Array(items) => {
            format!("[{}]", items.iter().map(show).collect::<Vec<_>>().join(", "))
        }
        Value::Table(t) => format!(
            "{{{}}}",
            t.entries
                .iter()
                .map(|(k, e)| format!("{k} = {}", show(&e.node)))
                .collect::<Vec<_>>()
                .join(", ")
        ),
    };
    echo(&s)
}

/// A float as TOML would write it (`1.0`, `0.25`, `inf`, `nan`).
pub(crate) fn show_float(f: f64) -> String {
    if f.is_nan() {
        "nan".into()
    } else if f.is_infinite() {
        if f > 0.0 { "inf" } else { "-inf" }.into()
    } else if f == f.trunc() && f.abs() < 1e15 {
        format!("{f:.1}")
    } else if f.abs() >= 1e15 || f.abs() < 1e-5 {
        format!("{f:e}")
    } else {
        f.to_string()
    }
}
