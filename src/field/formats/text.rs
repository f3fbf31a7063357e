//! Text pieces shared by the header parsers: number lists, NRRD vectors, header bytes.

use std::io::Read;

use glam::DVec3;

use super::Located;
use crate::field::FieldError;

/// Most bytes a text header may take (real headers are a few KiB).
pub const MAX_HEADER_BYTES: u64 = 1 << 20;

/// Whitespace-separated numbers (`1 0.5 2e-3`), None if any word is not one.
pub fn numbers(s: &str) -> Option<Vec<f64>> {
    s.split_ascii_whitespace().map(|w| w.parse::<f64>().ok()).collect()
}

/// Exactly three numbers.
pub fn three(s: &str) -> Option<DVec3> {
    match numbers(s)?.as_slice() {
        [x, y, z] => Some(DVec3::new(*x, *y, *z)),
        _ => None,
    }
}

/// Whitespace-separated non-negative integers.
pub fn sizes(s: &str) -> Option<Vec<u64>> {
    s.split_ascii_whitespace().map(|w| w.parse::<u64>().ok()).collect()
}

/// An NRRD vector `(1.5,0,-0.25)`, or None.
pub fn nrrd_vector(s: &str) -> Option<Vec<f64>> {
    let inner = s.trim().strip_prefix('(')?.strip_suffix(')')?;
    inner.split(',').map(|w| w.trim().parse::<f64>().ok()).collect()
}

/// Splits NRRD's space-separated vectors `(1,0,0) (0,1,0) none`; `None` entries are `none`.
pub fn nrrd_vectors(s: &str) -> Option<Vec<Option<Vec<f64>>>> {
    let mut out = Vec::new();
    let mut rest = s.trim();
    while !rest.is_empty() {
        if let Some(r) = rest.strip_prefix("none") {
            out.push(None);
            rest = r.trim_start();
            continue;
        }
        let close = rest.find(')')?;
        out.push(Some(nrrd_vector(&rest[..=close])?));
        rest = rest[close + 1..].trim_start();
    }
    Some(out)
}

/// Reads the start of `reader` (at most [`MAX_HEADER_BYTES`]) up to and including the first
/// empty line (`\n\n` or `\r\n\r\n`); returns the header text and the data's offset. With
/// `whole = true` (a detached header) the end of the file also ends the header.
pub fn header_until_blank_line(
    err: &Located,
    reader: impl Read,
    whole: bool,
) -> Result<(String, u64), FieldError> {
    let mut bytes = Vec::new();
    reader.take(MAX_HEADER_BYTES).read_to_end(&mut bytes).map_err(|e| err.io(&e))?;
    let end = blank_line(&bytes);
    let (head, offset) = match end {
        Some((h, d)) => (&bytes[..h], d as u64),
        None if whole && (bytes.len() as u64) < MAX_HEADER_BYTES => {
            (&bytes[..], bytes.len() as u64)
        }
        None => {
            return Err(
                err.bad("the header has no end (an empty line before the data) in its first MiB")
            )
        }
    };
    let text = std::str::from_utf8(head)
        .map_err(|e| err.bad(format!("the header is not text (byte {})", e.valid_up_to())))?;
    Ok((text.to_string(), offset))
}

/// Where the first empty line starts and where the bytes after it start.
fn blank_line(bytes: &[u8]) -> Option<(usize, usize)> {
    let mut line_start = 0;
    for (i, &b) in bytes.iter().enumerate() {
        if b == b'\n' {
            let line = &bytes[line_start..i];
            if line.is_empty() || line == b"\r" {
                return Some((line_start, i + 1));
            }
            line_start = i + 1;
        }
    }
    None
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn vectors_and_blank_lines() {
        assert_eq!(
            nrrd_vectors("(1,0,0) none (0, 2.5,-1)"),
            Some(vec![Some(vec![1.0, 0.0, 0.0]), None, Some(vec![0.0, 2.5, -1.0])])
        );
        assert_eq!(nrrd_vectors("(1,0,0"), None);
        assert_eq!(blank_line(b"a\nb\n\nDATA"), Some((4, 5)));
        assert_eq!(blank_line(b"a\r\n\r\nDATA"), Some((3, 5)));
        assert_eq!(blank_line(b"a\nb\n"), None);
    }
}
