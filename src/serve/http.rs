//! The HTTP plumbing over `tiny_http`: replies, query strings, headers.

use std::collections::HashMap;
use std::io::Read;

use serde_json::{json, Value};

/// Largest request body read (a state is a few hundred bytes).
pub const MAX_BODY: u64 = 1 << 20;

/// A reply to send: status, content type, extra headers, body.
pub struct Reply {
    pub status: u16,
    pub content_type: &'static str,
    pub headers: Vec<(String, String)>,
    pub body: Vec<u8>,
}

impl Reply {
    pub fn bytes(content_type: &'static str, body: Vec<u8>) -> Self {
        Reply { status: 200, content_type, headers: Vec::new(), body }
    }

    pub fn json(value: &Value) -> Self {
        Reply::bytes("application/json", value.to_string().into_bytes())
    }

    pub fn text(content_type: &'static str, text: impl Into<String>) -> Self {
        Reply::bytes(content_type, text.into().into_bytes())
    }

    /// `{"error": message}` with `status`.
    pub fn error(status: u16, message: impl std::fmt::Display) -> Self {
        let mut r = Reply::json(&json!({ "error": message.to_string() }));
        r.status = status;
        r
    }

    pub fn with_status(mut self, status: u16) -> Self {
        self.status = status;
        self
    }

    pub fn header(mut self, name: &str, value: impl ToString) -> Self {
        self.headers.push((name.to_string(), value.to_string()));
        self
    }

    /// Sends the reply (a client that hung up is not an error of ours).
    pub fn send(self, request: tiny_http::Request) {
        let mut response = tiny_http::Response::from_data(self.body).with_status_code(self.status);
        let mut add = |name: &str, value: &str| {
            if let Ok(h) = tiny_http::Header::from_bytes(name.as_bytes(), value.as_bytes()) {
                response.add_header(h);
            }
        };
        add("Content-Type", self.content_type);
        add("Cache-Control", "no-store");
        add("X-Content-Type-Options", "nosniff");
        for (name, value) in &self.headers {
            add(name, value);
        }
        let _ = request.respond(response);
    }
}

/// A request's path and decoded query parameters.
pub struct Target {
    pub path: String,
    pub query: HashMap<String, String>,
}

impl Target {
    pub fn parse(url: &str) -> Self {
        let (path, query) = url.split_once('?').unwrap_or((url, ""));
        let query = query
            .split('&')
            .filter(|p| !p.is_empty())
            .map(|p| {
                let (k, v) = p.split_once('=').unwrap_or((p, ""));
                (percent_decode(k), percent_decode(v))
            })
            .collect();
        Target { path: percent_decode(path), query }
    }

    pub fn get(&self, key: &str) -> Option<&str> {
        self.query.get(key).map(String::as_str)
    }
}

/// Decodes `%XX` escapes and `+` (a space in query strings); invalid escapes stay as they are.
pub fn percent_decode(s: &str) -> String {
    let bytes = s.as_bytes();
    let mut out = Vec::with_capacity(bytes.len());
    let mut i = 0;
    while i < bytes.len() {
        match bytes[i] {
            b'%' if i + 2 < bytes.len()
                && bytes[i + 1].is_ascii_hexdigit()
                && bytes[i + 2].is_ascii_hexdigit() =>
            {
                let hex = |b: u8| (b as char).to_digit(16).unwrap_or(0) as u8;
                out.push(hex(bytes[i + 1]) * 16 + hex(bytes[i + 2]));
                i += 3;
                continue;
            }
            b'+' => out.push(b' '),
            b => out.push(b),
        }
        i += 1;
    }
    String::from_utf8_lossy(&out).into_owned()
}

/// The value of header `name` (case-insensitive), if present.
pub fn header(request: &tiny_http::Request, name: &str) -> Option<String> {
    request
        .headers()
        .iter()
        .find(|h| h.field.as_str().as_str().eq_ignore_ascii_case(name))
        .map(|h| h.value.as_str().to_string())
}

/// The request body, at most [`MAX_BODY`] bytes.
pub fn body(request: &mut tiny_http::Request) -> Result<Vec<u8>, String> {
    let mut bytes = Vec::new();
    request
        .as_reader()
        .take(MAX_BODY + 1)
        .read_to_end(&mut bytes)
        .map_err(|e| format!("cannot read the request body: {e}"))?;
    if bytes.len() as u64 > MAX_BODY {
        return Err(format!("the request body is over {MAX_BODY} bytes"));
    }
    Ok(bytes)
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn query_strings_decode() {
        let t = Target::parse("/api/probe?x=3&y=4&token=ab%2Fc&s=a+b&flag");
        assert_eq!(t.path, "/api/probe");
        assert_eq!(t.get("x"), Some("3"));
        assert_eq!(t.get("token"), Some("ab/c"));
        assert_eq!(t.get("s"), Some("a b"));
        assert_eq!(t.get("flag"), Some(""));
        assert_eq!(percent_decode("100%"), "100%");
        assert_eq!(percent_decode("%zz%41"), "%zzA");
    }
}
