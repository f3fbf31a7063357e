//! Typed reads from the value tree: each checks the TOML type and the range, and reports a
//! mistake at the value's position with its full key path.

use glam::DVec3;

use super::error::{SceneError, SceneErrorKind};
use super::tree::{article, join, show, Node, Origin, Source, Table, Value};

pub(crate) type Result<T> = std::result::Result<T, SceneError>;

/// A table of the scene (possibly absent, then every key takes its default).
#[derive(Clone)]
pub(crate) struct View<'a> {
    pub src: &'a Source<'a>,
    /// Dotted path of the table (`camera`, `field.bounds`); empty for the root.
    pub path: String,
    pub table: Option<&'a Table>,
    /// Where the table was written (for "missing key" errors).
    pub at: Origin,
}

impl<'a> View<'a> {
    pub(crate) fn get(&self, key: &str) -> Option<&'a Node> {
        self.table.and_then(|t| t.get(key))
    }

    /// The dotted path of `key` in this table.
    pub(crate) fn key(&self, key: &str) -> String {
        join(&self.path, key)
    }

    /// The subtable `key`, or an absent view if there is none.
    pub(crate) fn table(&self, key: &str) -> Result<View<'a>> {
        let path = self.key(key);
        match self.get(key) {
            None => Ok(View { src: self.src, path, table: None, at: self.at }),
            Some(node) => match &node.value {
                Value::Table(t) => Ok(View { src: self.src, path, table: Some(t), at: node.at }),
                _ => Err(type_error(self.src, &path, node, "a table")),
            },
        }
    }

    /// Fails on the first key (in file order) that is not in `allowed`.
    pub(crate) fn check_keys(&self, allowed: &[&str]) -> Result<()> {
        self.check_keys_with(allowed, |_| None)
    }

    /// Like [`View::check_keys`], with `explain` giving a specific message for some keys
    /// (e.g. keys that belong to another field source).
    pub(crate) fn check_keys_with(
        &self,
        allowed: &[&str],
        explain: impl Fn(&str) -> Option<String>,
    ) -> Result<()> {
        let Some(table) = self.table else {
            return Ok(());
        };
        let first_bad = table
            .entries
            .iter()
            .filter(|(k, _)| !allowed.contains(&k.as_str()))
            .min_by_key(|(_, e)| e.key_at);
        let Some((key, entry)) = first_bad else {
            return Ok(());
        };
        let message = explain(key).unwrap_or_else(|| {
            let what = if self.path.is_empty() { "unknown table or key" } else { "unknown key" };
            match suggest(key, allowed) {
                Some(s) => format!("{what} (did you mean \"{s}\"?)"),
                None if self.path.is_empty() => format!(
                    "{what} (a scene has the tables {})",
                    allowed.iter().map(|k| format!("[{k}]")).collect::<Vec<_>>().join(", ")
                ),
                None => format!("{what} ([{}] has {})", self.path, allowed.join(", ")),
            }
        });
        Err(self.src.err(SceneErrorKind::UnknownKey, entry.key_at, &self.key(key), message))
    }

    /// An error about `key` of this table, at the value if present, else at the table.
    pub(crate) fn err(
        &self,
        kind: SceneErrorKind,
        key: &str,
        message: impl AsRef<str>,
    ) -> SceneError {
        let at = self.get(key).map_or(self.at, |n| n.at);
        self.src.err(kind, at, &self.key(key), message)
    }

    /// The "missing key" error.
    pub(crate) fn missing(&self, key: &str, hint: &str) -> SceneError {
        self.src.err(SceneErrorKind::Missing, self.at, &self.key(key), format!("missing ({hint})"))
    }

    /// Reads `key` with `read`, or returns `default` when it is absent.
    pub(crate) fn or<T>(
        &self,
        key: &str,
        default: T,
        read: impl FnOnce(&Source, &str, &Node) -> Result<T>,
    ) -> Result<T> {
        match self.get(key) {
            None => Ok(default),
            Some(node) => read(self.src, &self.key(key), node),
        }
    }

    /// Reads the required `key` with `read`.
    pub(crate) fn required<T>(
        &self,
        key: &str,
        hint: &str,
        read: impl FnOnce(&Source, &str, &Node) -> Result<T>,
    ) -> Result<T> {
        match self.get(key) {
            None => Err(self.missing(key, hint)),
            Some(node) => read(self.src, &self.key(key), node),
        }
    }
}

/// `expected WHAT, got TYPE VALUE`.
pub(crate) fn type_error(src: &Source, key: &str, node: &Node, expected: &str) -> SceneError {
    let ty = node.value.type_name();
    src.err(
        SceneErrorKind::Type,
        node.at,
        key,
        format!("expected {expected}, got {} {ty} {}", article(ty), show(node)),
    )
}

/// A finite number (integer or float).
pub(crate) fn number(src: &Source, key: &str, node: &Node) -> Result<f64> {
    let x = match node.value {
        Value::Integer(i) => i as f64,
        Value::Float(f) => f,
        _ => return Err(type_error(src, key, node, "a number")),
    };
    if x.is_finite() {
        Ok(x)
    } else {
        Err(src.err(
            SceneErrorKind::Value,
            node.at,
            key,
            format!("must be a finite number, got {}", show(node)),
        ))
    }
}

/// A number with `ok(x)` true, else `rule` is the message (`must be positive`).
pub(crate) fn number_where(
    src: &Source,
    key: &str,
    node: &Node,
    ok: impl Fn(f64) -> bool,
    rule: &str,
) -> Result<f64> {
    let x = number(src, key, node)?;
    if ok(x) {
        Ok(x)
    } else {
        Err(src.err(SceneErrorKind::Value, node.at, key, format!("{rule}, got {}", show(node))))
    }
}

/// `true` or `false`.
pub(crate) fn boolean(src: &Source, key: &str, node: &Node) -> Result<bool> {
    match node.value {
        Value::Boolean(b) => Ok(b),
        _ => Err(type_error(src, key, node, "true or false")),
    }
}

/// An integer in `lo..=hi`.
pub(crate) fn integer(src: &Source, key: &str, node: &Node, lo: i64, hi: i64) -> Result<i64> {
    let Value::Integer(i) = node.value else {
        return Err(type_error(src, key, node, "an integer"));
    };
    let message = if i < lo {
        format!("must be at least {lo}, got {i}")
    } else if i > hi {
        format!("must be at most {hi}, got {i}")
    } else {
        return Ok(i);
    };
    Err(src.err(SceneErrorKind::Value, node.at, key, message))
}

/// An array of exactly `N` finite numbers.
pub(crate) fn numbers<const N: usize>(src: &Source, key: &str, node: &Node) -> Result<[f64; N]> {
    let items = array_of(src, key, node, N, "numbers")?;
    let mut out = [0.0; N];
    for (n, (o, item)) in out.iter_mut().zip(items).enumerate() {
        *o = match item.value {
            Value::Integer(i) => i as f64,
            Value::Float(f) => f,
            _ => {
                let ty = item.value.type_name();
                return Err(src.err(
                    SceneErrorKind::Type,
                    item.at,
                    key,
                    format!(
                        "expected a number at index {n}, got {} {ty} {}",
                        article(ty),
                        show(item)
                    ),
                ));
            }
        };
        if !o.is_finite() {
            return Err(src.err(
                SceneErrorKind::Value,
                item.at,
                key,
                format!("every number must be finite, got {} at index {n}", show(item)),
            ));
        }
    }
    Ok(out)
}

/// A 3-vector (`[x, y, z]`, finite).
pub(crate) fn vec3(src: &Source, key: &str, node: &Node) -> Result<DVec3> {
    numbers::<3>(src, key, node).map(DVec3::from_array)
}

/// The items of an array that must have exactly `len` of them.
pub(crate) fn array_of<'n>(
    src: &Source,
    key: &str,
    node: &'n Node,
    len: usize,
    what: &str,
) -> Result<&'n [Node]> {
    match &node.value {
        Value::Array(items) if items.len() == len => Ok(items),
        Value::Array(items) => Err(src.err(
            SceneErrorKind::Type,
            node.at,
            key,
            format!("expected an array of {len} {what}, got {} ({})", items.len(), show(node)),
        )),
        _ => Err(type_error(src, key, node, &format!("an array of {len} {what}"))),
    }
}

/// Grid points per axis: 3 integers, each at least 2.
pub(crate) fn points3(src: &Source, key: &str, node: &Node) -> Result<[usize; 3]> {
    let items = array_of(src, key, node, 3, "integers")?;
    let mut out = [0usize; 3];
    for (n, (o, item)) in out.iter_mut().zip(items).enumerate() {
        let Value::Integer(i) = item.value else {
            let ty = item.value.type_name();
            return Err(src.err(
                SceneErrorKind::Type,
                item.at,
                key,
                format!(
                    "expected an integer at index {n}, got {} {ty} {}",
                    article(ty),
                    show(item)
                ),
            ));
        };
        if i < 2 {
            return Err(src.err(
                SceneErrorKind::Value,
                node.at,
                key,
                format!("every axis needs at least 2 points, got {}", show(node)),
            ));
        }
        *o = usize::try_from(i).map_err(|_| {
            src.err(SceneErrorKind::Value, node.at, key, format!("{i} points is too many"))
        })?;
    }
    Ok(out)
}

/// A string.
pub(crate) fn string<'n>(src: &Source, key: &str, node: &'n Node) -> Result<&'n str> {
    match &node.value {
        Value::String(s) => Ok(s),
        _ => Err(type_error(src, key, node, "a string")),
    }
}

/// One of a fixed set of names.
pub(crate) fn choice<T: Copy>(
    src: &Source,
    key: &str,
    node: &Node,
    options: &[(&str, T)],
) -> Result<T> {
    let names = || {
        let quoted: Vec<String> = options.iter().map(|(n, _)| format!("\"{n}\"")).collect();
        match quoted.split_last() {
            Some((last, rest)) if !rest.is_empty() => format!("{} or {last}", rest.join(", ")),
            _ => quoted.join(""),
        }
    };
    let s = match &node.value {
        Value::String(s) => s,
        _ => return Err(type_error(src, key, node, &format!("one of {}", names()))),
    };
    match options.iter().find(|(n, _)| n == s) {
        Some(&(_, v)) => Ok(v),
        None => {
            let hint = suggest(s, &options.iter().map(|(n, _)| *n).collect::<Vec<_>>())
                .map(|m| format!("; did you mean \"{m}\"?"))
                .unwrap_or_default();
            Err(src.err(
                SceneErrorKind::Value,
                node.at,
                key,
                format!("unknown value \"{}\" (expected {}){hint}", crate::vocab::echo(s), names()),
            ))
        }
    }
}

/// The closest name to `word` within edit distance 2 (for "did you mean").
pub(crate) fn suggest<'n>(word: &str, names: &[&'n str]) -> Option<&'n str> {
    // The distance is at least the difference of the lengths: names more than 2 characters
    // longer or shorter are not compared (a 15 MiB unknown key in a scene file took 10 s of
    // edit distances, the words' product a name).
    let len = word.chars().count();
    names
        .iter()
        .filter(|n| n.chars().count().abs_diff(len) <= 2)
        .map(|n| (edit_distance(word, n), *n))
        .filter(|&(d, n)| d <= 2 && d < n.len())
        .min_by_key(|&(d, _)| d)
        .map(|(_, n)| n)
}

fn edit_distance(a: &str, b: &str) -> usize {
    let b: Vec<char> = b.chars().collect();
    let mut prev: Vec<usize> = (0..=b.len()).collect();
    for (i, ca) in a.chars().enumerate() {
        let mut cur = vec![i + 1; b.len() + 1];
        for (j, &cb) in b.iter().enumerate() {
            cur[j + 1] = (prev[j] + usize::from(ca != cb)).min(prev[j + 1] + 1).min(cur[j] + 1);
        }
        prev = cur;
    }
    prev[b.len()]
}
