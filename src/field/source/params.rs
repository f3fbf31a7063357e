//! What a field source reads its keys through. A source parses its own keys next to its
//! implementation (pbrt-v4's `ParameterDictionary`), without knowing TOML: the scene implements
//! [`Params`] over its `[field]` table, so every mistake is still reported at `file:line:col`
//! with the key's full path (`field.radius`), and every message reads as before.

use std::path::{Path, PathBuf};

use glam::DVec3;

use crate::field::{DataAccess, FieldError, GridLimits};

/// Whether a key must be present, and its default if not.
#[derive(Clone, Copy, Debug)]
pub enum Need<'h, T> {
    /// Required; the text says what to write (`missing (HINT)`).
    Required(&'h str),
    /// Optional, with this default.
    Or(T),
}

/// A condition on a value and the message when it fails (`must be positive`, followed by
/// `, got VALUE`).
#[derive(Clone, Copy)]
pub struct Rule<'r, T> {
    pub ok: &'r dyn Fn(T) -> bool,
    pub message: &'r str,
}

/// The keys of a `[field]` table, typed. Each read checks the TOML type, that numbers are
/// finite, and the range or [`Rule`]; errors are the implementor's (the scene's, with positions).
pub trait Params {
    type Error;

    /// The folder relative data paths are resolved against.
    fn base_dir(&self) -> &Path;
    /// The grid memory cap.
    fn limits(&self) -> &GridLimits;
    /// Which files `path` keys may name.
    fn access(&self) -> &DataAccess;

    fn number(
        &self,
        key: &str,
        need: Need<f64>,
        rule: Option<Rule<f64>>,
    ) -> Result<f64, Self::Error>;
    fn vec3(
        &self,
        key: &str,
        need: Need<DVec3>,
        rule: Option<Rule<DVec3>>,
    ) -> Result<DVec3, Self::Error>;
    /// Exactly 8 finite numbers.
    fn numbers8(&self, key: &str, need: Need<[f64; 8]>) -> Result<[f64; 8], Self::Error>;
    /// Grid points along x, y, z: 3 integers, each at least 2.
    fn points3(&self, key: &str, need: Need<[usize; 3]>) -> Result<[usize; 3], Self::Error>;
    /// An integer in `lo..=hi`.
    fn integer(&self, key: &str, need: Need<i64>, lo: i64, hi: i64) -> Result<i64, Self::Error>;
    fn string(&self, key: &str, need: Need<&str>) -> Result<String, Self::Error>;
    /// One of `options`' names.
    fn choice<T: Copy>(
        &self,
        key: &str,
        need: Need<T>,
        options: &[(&str, T)],
    ) -> Result<T, Self::Error>;

    /// Fails on the first key (in file order) not in `allowed`; `explain` may give a specific
    /// message for some keys.
    fn check_keys(
        &self,
        allowed: &[&str],
        explain: &dyn Fn(&str) -> Option<String>,
    ) -> Result<(), Self::Error>;
    /// Whether `key` is written (for keys another part of the table reads, such as `bounds`).
    fn has(&self, key: &str) -> bool;
    /// A bad value of `key`, at the value (or at the table when absent).
    fn value_error(&self, key: &str, message: String) -> Self::Error;
    /// A data error (file, expression, memory cap) about `key`, at its value.
    fn data_error(&self, key: &str, error: FieldError) -> Self::Error;
}

/// `resolution`, required, checked against the memory cap.
pub(super) fn resolution<P: Params>(p: &P) -> Result<[usize; 3], P::Error> {
    let res =
        p.points3("resolution", Need::Required("grid points along x, y, z, e.g. [48, 48, 48]"))?;
    p.limits()
        .check(res.map(|n| n as u64), "field.resolution")
        .map_err(|e| p.data_error("resolution", e))?;
    Ok(res)
}

/// `path`, required, not empty, resolved against the scene file's folder and admitted by
/// [`Params::access`] (every data path passes here, so this is where `serve` confines them).
pub(super) fn data_path<P: Params>(p: &P) -> Result<PathBuf, P::Error> {
    data_path_named(p).map(|(_, admitted)| admitted)
}

/// [`data_path`], with the path as written (against the scene's folder) first: what a format
/// is told from. `serve` admits a link as its resolved target, whose name may say nothing
/// (`v.nrrd` -> `volume.data`); the command line reads the same file by the name written.
pub(super) fn data_path_named<P: Params>(p: &P) -> Result<(PathBuf, PathBuf), P::Error> {
    let path = p.string("path", Need::Required("the data file, relative to the scene file"))?;
    if path.is_empty() {
        return Err(p.value_error("path", "must not be empty".into()));
    }
    let named = p.base_dir().join(path);
    let admitted = p.access().admit(&named).map_err(|m| p.value_error("path", m))?;
    Ok((named, admitted))
}
