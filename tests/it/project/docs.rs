//! The documentation's links lead somewhere. README.md and every `docs/*.md` are read for
//! Markdown links and images (`[text](target)`, `![alt](target)`, `[label]: target`) and the
//! HTML `src`/`href` attributes the pages use; every relative target must exist, and a
//! `#anchor` must be a heading of its page as GitHub slugs it. Links inside code (fenced blocks,
//! code spans) are text, not links. Also: every page of the guide is linked from the README or
//! the guide's index, and the README stays short.

use std::collections::BTreeSet;
use std::path::{Path, PathBuf};

/// The issue's "reads in five minutes": the README's length, in lines.
const README_MAX_LINES: usize = 400;

fn root() -> PathBuf {
    PathBuf::from(env!("CARGO_MANIFEST_DIR"))
}

/// README.md and docs/*.md (not the notes under docs/_pending/, which are not pages yet).
fn pages() -> Vec<PathBuf> {
    let root = root();
    let mut out = vec![root.join("README.md")];
    let mut guide: Vec<PathBuf> = std::fs::read_dir(root.join("docs"))
        .expect("docs/ exists")
        .map(|e| e.unwrap().path())
        .filter(|p| p.is_file() && p.extension().is_some_and(|x| x == "md"))
        .collect();
    guide.sort();
    out.extend(guide);
    out
}

/// The text with fenced code blocks and code spans blanked out (same length, newlines kept),
/// so that offsets still give line numbers and nothing in code reads as a link or heading.
fn without_code(text: &str) -> String {
    let mut out = String::with_capacity(text.len());
    let mut fence: Option<String> = None;
    for line in text.split_inclusive('\n') {
        let trimmed = line.trim_start();
        let marker: String = trimmed.chars().take_while(|&c| c == '`' || c == '~').collect();
        let opens =
            marker.len() >= 3 && marker.chars().all(|c| c == marker.chars().next().unwrap());
        match &fence {
            Some(open) => {
                // A fence closes with a run of the same character, at least as long.
                if opens
                    && marker.starts_with(open.as_str())
                    && trimmed[marker.len()..].trim().is_empty()
                {
                    fence = None;
                }
                out.push_str(&blank(line));
            }
            None if opens => {
                fence = Some(marker);
                out.push_str(&blank(line));
            }
            None => out.push_str(line),
        }
    }
    blank_code_spans(&out)
}

/// Spaces for every character but newlines.
fn blank(s: &str) -> String {
    s.chars().map(|c| if c == '\n' { '\n' } else { ' ' }).collect()
}

/// Blanks each code span: a run of N backticks up to the next run of exactly N (a span may
/// cross a line break, as in CommonMark). A run with no closing run is literal text.
fn blank_code_spans(text: &str) -> String {
    let chars: Vec<char> = text.chars().collect();
    let run_at = |i: usize| chars[i..].iter().take_while(|&&c| c == '`').count();
    let mut out = String::with_capacity(text.len());
    let mut i = 0;
    while i < chars.len() {
        if chars[i] != '`' {
            out.push(chars[i]);
            i += 1;
            continue;
        }
        let n = run_at(i);
        let mut j = i + n;
        let close = loop {
            if j >= chars.len() {
                break None;
            }
            if chars[j] == '`' {
                let m = run_at(j);
                if m == n {
                    break Some(j);
                }
                j += m;
            } else {
                j += 1;
            }
        };
        match close {
            Some(j) => {
                let span: String = chars[i..j + n].iter().collect();
                out.push_str(&blank(&span));
                i = j + n;
            }
            None => {
                out.extend(&chars[i..i + n]);
                i += n;
            }
        }
    }
    out
}

/// Line number (1-based) of byte offset `at`.
fn line_of(text: &str, at: usize) -> usize {
    text[..at].matches('\n').count() + 1
}

/// Every link target in a page, with its line: inline links and images, reference
/// definitions, and HTML `src="..."` / `href="..."`.
fn links(text: &str) -> Vec<(usize, String)> {
    let text = without_code(text);
    let mut out = Vec::new();
    for (at, _) in text.match_indices("](") {
        let rest = &text[at + 2..];
        let Some(end) = rest.find(')') else { continue };
        // `(target "title")`: the target is the first word; `<...>` may wrap it.
        let target = rest[..end].split_whitespace().next().unwrap_or("");
        let target = target.trim_start_matches('<').trim_end_matches('>');
        out.push((line_of(&text, at), target.to_string()));
    }
    let mut offset = 0;
    for line in text.split_inclusive('\n') {
        let t = line.trim_start();
        if let Some(close) = t.strip_prefix('[').and_then(|r| r.find("]:")) {
            let target = t[1 + close + 2..].split_whitespace().next().unwrap_or("");
            out.push((line_of(&text, offset), target.to_string()));
        }
        offset += line.len();
    }
    for attr in ["src=\"", "href=\""] {
        for (at, _) in text.match_indices(attr) {
            let rest = &text[at + attr.len()..];
            let end = rest.find('"').unwrap_or(rest.len());
            out.push((line_of(&text, at), rest[..end].to_string()));
        }
    }
    out.sort();
    out
}

/// The anchor GitHub gives a heading: its text as rendered (code marks, emphasis marks and
/// link targets gone), lower-cased, spaces to hyphens, every other character that is not a
/// letter, digit, `-` or `_` dropped.
fn slug(heading: &str) -> String {
    let mut text = String::new();
    let mut rest = heading;
    // `[text](url)` renders as `text`.
    while let Some(open) = rest.find('[') {
        let Some(mid) = rest[open..].find("](") else { break };
        let Some(close) = rest[open + mid..].find(')') else { break };
        text.push_str(&rest[..open]);
        text.push_str(&rest[open + 1..open + mid]);
        rest = &rest[open + mid + close + 1..];
    }
    text.push_str(rest);
    text.chars()
        .flat_map(char::to_lowercase)
        .filter_map(|c| match c {
            ' ' => Some('-'),
            '-' | '_' => Some(c),
            c if c.is_alphanumeric() => Some(c),
            _ => None,
        })
        .collect()
}

/// The anchors of a page's ATX headings, with GitHub's `-1`, `-2` for repeated ones. A
/// heading's text is read from the page as written (a code span's text is part of its anchor),
/// at the lines `without_code` leaves as headings (a `#` line in a code block is not one).
fn page_anchors(text: &str) -> BTreeSet<String> {
    let kept = without_code(text);
    let mut seen = BTreeSet::new();
    for (orig, plain) in text.lines().zip(kept.lines()) {
        let hashes = plain.chars().take_while(|&c| c == '#').count();
        if !(1..=6).contains(&hashes) || !plain[hashes..].starts_with(' ') {
            continue;
        }
        let base = slug(orig[hashes..].trim().trim_end_matches('#').trim());
        let mut anchor = base.clone();
        let mut n = 0;
        while seen.contains(&anchor) {
            n += 1;
            anchor = format!("{base}-{n}");
        }
        seen.insert(anchor);
    }
    seen
}

/// What is wrong with `target`, linked from `page`; None when it leads somewhere.
fn broken(page: &Path, target: &str) -> Option<String> {
    if target.is_empty() {
        return Some("empty link target".into());
    }
    if target.contains("://") || target.starts_with("mailto:") {
        return None; // not checked offline
    }
    let (path, anchor) = match target.split_once('#') {
        Some((p, a)) => (p, Some(a)),
        None => (target, None),
    };
    let file = if path.is_empty() {
        page.to_path_buf()
    } else if let Some(from_root) = path.strip_prefix('/') {
        root().join(from_root)
    } else {
        page.parent().unwrap().join(path)
    };
    if !file.exists() {
        return Some(format!("{} does not exist", file.display()));
    }
    let anchor = anchor?;
    if !file.extension().is_some_and(|x| x == "md") {
        return Some(format!("#{anchor} on {}, which is not a Markdown page", file.display()));
    }
    let text = std::fs::read_to_string(&file).unwrap();
    if page_anchors(&text).contains(anchor) {
        None
    } else {
        Some(format!("no heading with the anchor #{anchor} in {}", file.display()))
    }
}

#[test]
fn every_link_and_image_leads_somewhere() {
    let mut problems = Vec::new();
    let mut checked = 0;
    for page in pages() {
        let text = std::fs::read_to_string(&page).unwrap();
        for (line, target) in links(&text) {
            checked += 1;
            if let Some(why) = broken(&page, &target) {
                let name = page.strip_prefix(root()).unwrap().display().to_string();
                problems.push(format!("{name}:{line}: ({target}): {why}"));
            }
        }
    }
    assert!(checked > 50, "only {checked} links found: is the parser reading the pages?");
    assert!(problems.is_empty(), "{} broken links:\n{}", problems.len(), problems.join("\n"));
}

#[test]
fn every_guide_page_is_linked_from_the_readme_or_the_index() {
    let root = root();
    let mut linked = BTreeSet::new();
    for from in [root.join("README.md"), root.join("docs/README.md")] {
        let text = std::fs::read_to_string(&from).unwrap();
        for (_, target) in links(&text) {
            let path = target.split('#').next().unwrap();
            if !path.is_empty() && !path.contains("://") {
                if let Ok(p) = from.parent().unwrap().join(path).canonicalize() {
                    linked.insert(p);
                }
            }
        }
    }
    let orphans: Vec<String> = pages()
        .into_iter()
        .filter(|p| !p.ends_with("README.md"))
        .filter(|p| !linked.contains(&p.canonicalize().unwrap()))
        .map(|p| p.strip_prefix(&root).unwrap().display().to_string())
        .collect();
    assert!(orphans.is_empty(), "pages no one links to (add them to docs/README.md): {orphans:?}");
}

#[test]
fn the_readme_reads_in_five_minutes() {
    let lines = std::fs::read_to_string(root().join("README.md")).unwrap().lines().count();
    assert!(
        lines <= README_MAX_LINES,
        "README.md has {lines} lines (at most {README_MAX_LINES}: move detail into a page of docs/)"
    );
}

#[test]
fn slugs_are_githubs() {
    // Anchors GitHub gives these headings (the README's links used them before the split).
    assert_eq!(slug("Volume files (`source = \"file\"`)"), "volume-files-source--file");
    assert_eq!(
        slug("Grids larger than memory and the device (field.residency)"),
        "grids-larger-than-memory-and-the-device-fieldresidency"
    );
    assert_eq!(slug("Picking an isovalue: isoview stats"), "picking-an-isovalue-isoview-stats");
    assert_eq!(slug("isoview's own benchmarks"), "isoviews-own-benchmarks");
    assert_eq!(slug("A [linked](x.md) heading"), "a-linked-heading");
    let page = "# Title\n## Same\n```\n# not a heading\n```\n## Same\n## `code_span` here\n";
    let a = page_anchors(page);
    let want = ["title", "same", "same-1", "code_span-here"];
    assert_eq!(a, want.iter().map(|s| s.to_string()).collect(), "{a:?}");
    assert!(!a.contains("not-a-heading"));
}

#[test]
fn links_in_code_are_text() {
    let page = "see [a](a.md) and `[b](b.md)`\n```sh\n[c](c.md)\n```\n[split\nlink](d.md#x) \
                ![img](e.png \"title\")\n[ref]: f.md\n<img src=\"g.png\"> ``[h](h.md)``\n";
    let got: Vec<String> = links(page).into_iter().map(|(_, t)| t).collect();
    assert_eq!(got, ["a.md", "d.md#x", "e.png", "f.md", "g.png"]);
    let lines: Vec<usize> = links(page).into_iter().map(|(l, _)| l).collect();
    assert_eq!(lines, [1, 6, 6, 7, 8]);
}
