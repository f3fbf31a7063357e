//! The module rule (docs/contributing.md "Layout"): the `crate::` paths between the top-level modules of
//! `src/` form no cycle. Read from the source text (what a newcomer reads), unit-test modules
//! excluded: tests may use anything.

use std::collections::{BTreeMap, BTreeSet};
use std::path::Path;

/// Top-level module of every `.rs` file under `src/` -> the top-level modules it names.
fn graph(src: &Path) -> BTreeMap<String, BTreeSet<String>> {
    fn files(dir: &Path, out: &mut Vec<std::path::PathBuf>) {
        for e in std::fs::read_dir(dir).unwrap() {
            let p = e.unwrap().path();
            if p.is_dir() {
                files(&p, out);
            } else if p.extension().is_some_and(|x| x == "rs") {
                out.push(p);
            }
        }
    }
    let mut all = Vec::new();
    files(src, &mut all);
    let top = |p: &Path| {
        let first = p.strip_prefix(src).unwrap().components().next().unwrap();
        first.as_os_str().to_string_lossy().trim_end_matches(".rs").to_string()
    };
    let mods: BTreeSet<String> =
        all.iter().map(|p| top(p)).filter(|m| m != "main" && m != "lib").collect();
    let mut edges: BTreeMap<String, BTreeSet<String>> =
        mods.iter().map(|m| (m.clone(), BTreeSet::new())).collect();
    for p in &all {
        let from = top(p);
        let Some(out) = edges.get_mut(&from) else { continue };
        let text = std::fs::read_to_string(p).unwrap();
        // Unit tests at the end of a file, and files that are test modules, may use anything.
        let text = text.split("#[cfg(test)]\nmod tests").next().unwrap();
        if p.file_name().is_some_and(|f| f == "tests.rs") {
            continue;
        }
        for (i, _) in text.match_indices("crate::") {
            let name: String = text[i + 7..]
                .chars()
                .take_while(|c| c.is_ascii_alphanumeric() || *c == '_')
                .collect();
            if name != from && mods.contains(&name) {
                out.insert(name);
            }
        }
    }
    edges
}

/// A cycle through the graph, as `a -> b -> a`, if there is one.
fn cycle(g: &BTreeMap<String, BTreeSet<String>>) -> Option<String> {
    fn visit<'a>(
        g: &'a BTreeMap<String, BTreeSet<String>>,
        m: &'a str,
        path: &mut Vec<&'a str>,
        done: &mut BTreeSet<&'a str>,
    ) -> Option<String> {
        if let Some(i) = path.iter().position(|p| *p == m) {
            return Some(format!("{} -> {m}", path[i..].join(" -> ")));
        }
        if done.contains(m) {
            return None;
        }
        path.push(m);
        for n in &g[m] {
            if let Some(c) = visit(g, n, path, done) {
                return Some(c);
            }
        }
        path.pop();
        done.insert(m);
        None
    }
    let mut done = BTreeSet::new();
    g.keys().find_map(|m| visit(g, m, &mut Vec::new(), &mut done))
}

#[test]
fn top_level_modules_form_no_cycle() {
    let g = graph(&Path::new(env!("CARGO_MANIFEST_DIR")).join("src"));
    assert!(g.contains_key("scene") && g.contains_key("vocab"), "modules not found: {g:?}");
    if let Some(c) = cycle(&g) {
        panic!("module cycle {c} (docs/contributing.md \"Layout\": dependencies run one way)");
    }
    // The vocabulary depends on nothing; the scene and the field sources on no GPU code.
    assert!(g["vocab"].is_empty(), "vocab uses {:?}", g["vocab"]);
    for m in ["scene", "field", "mesh"] {
        for bad in ["render", "passes", "gpu"] {
            assert!(!g[m].contains(bad), "{m} uses {bad}");
        }
    }
}

#[test]
fn a_cycle_is_found() {
    let mut g = BTreeMap::new();
    g.insert("a".to_string(), BTreeSet::from(["b".to_string()]));
    g.insert("b".to_string(), BTreeSet::from(["c".to_string()]));
    g.insert("c".to_string(), BTreeSet::from(["a".to_string()]));
    assert_eq!(cycle(&g).as_deref(), Some("a -> b -> c -> a"));
    g.get_mut("c").unwrap().clear();
    assert_eq!(cycle(&g), None);
}
