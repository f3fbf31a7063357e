//! HTTP/1.1 on a `TcpStream`, bounded: the request head (request line and headers) is read
//! into a buffer of at most [`MAX_HEAD`] bytes and parsed by `httparse`; a body is read only
//! when a route asks for it (after the token check), at most [`MAX_BODY`] bytes. Every read
//! has a deadline; a head's counts from the connection's accept (a head that waited out the
//! deadline in the queue still gets one turn) and is read in turns of [`HEAD_TURN`]
//! ([`HeadReader`]), so a client that sends nothing holds no thread. One request
//! per connection: each answer says `Connection: close`.
//!
//! ```text
//!   too long a request line: 414   too large a head or too many headers: 431
//!   malformed, or Content-Length lines that disagree: 400   head not complete within
//!   HEAD_TIMEOUT: 408   body over MAX_BODY: 413
//!   a chunked body: 411 (send Content-Length)
//! ```

use std::io::{self, Read, Write};
use std::net::{Shutdown, TcpStream};
use std::time::{Duration, Instant};

use serde_json::{json, Value};

/// Largest request head: request line and headers (a browser sends 1-2 KiB).
pub const MAX_HEAD: usize = 16 << 10;
/// Most header lines in a request.
pub const MAX_HEADERS: usize = 64;
/// Largest request body read (a state is a few hundred bytes).
pub const MAX_BODY: u64 = 1 << 20;
/// Time a client has to send the whole request head, from the connection's accept.
pub const HEAD_TIMEOUT: Duration = Duration::from_secs(5);
/// Longest a worker waits on one connection's head before it puts the connection back in the
/// queue and takes the next: idle connections then cost the others at most a turn each.
pub const HEAD_TURN: Duration = Duration::from_millis(50);
/// Time a client has to send a body.
pub const BODY_TIMEOUT: Duration = Duration::from_secs(10);
/// Time a client has to take each part of an answer (a client that stops reading is dropped).
pub const WRITE_TIMEOUT: Duration = Duration::from_secs(10);

/// A reply to send: status, content type, extra headers, body.
#[derive(Debug)]
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

    /// `{"error": message}` with `status`, the message cut as stderr's lines are (a state
    /// naming a 1 MB path answered a 1 MB error).
    pub fn error(status: u16, message: impl std::fmt::Display) -> Self {
        let message = message.to_string();
        let mut r = Reply::json(&json!({ "error": crate::vocab::message_line(&message) }));
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

    /// The bytes on the wire: status line, headers, body.
    pub fn encode(&self) -> Vec<u8> {
        let mut head = format!("HTTP/1.1 {} {}\r\n", self.status, reason(self.status));
        let fixed = [
            ("Content-Type", self.content_type),
            ("Cache-Control", "no-store"),
            ("X-Content-Type-Options", "nosniff"),
            ("Connection", "close"),
        ];
        for (name, value) in fixed {
            head += &format!("{name}: {value}\r\n");
        }
        head += &format!("Content-Length: {}\r\n", self.body.len());
        for (name, value) in &self.headers {
            // Values are ours; a stray line break would split the header.
            if !name.contains(['\r', '\n']) && !value.contains(['\r', '\n']) {
                head += &format!("{name}: {value}\r\n");
            }
        }
        head += "\r\n";
        let mut bytes = head.into_bytes();
        bytes.extend_from_slice(&self.body);
        bytes
    }

    /// Sends the reply and closes the connection (a client that hung up is not an error of
    /// ours). `unread`: body bytes the client announced that were not read; some of them are
    /// drained first so that closing does not reset the connection before the client has
    /// read the answer.
    pub fn send(self, mut stream: TcpStream, unread: u64) {
        let _ = stream.set_write_timeout(Some(WRITE_TIMEOUT));
        if stream.write_all(&self.encode()).and_then(|_| stream.flush()).is_err() {
            return;
        }
        let _ = stream.shutdown(Shutdown::Write);
        if unread > 0 {
            let deadline = Instant::now() + Duration::from_secs(1);
            let mut left = unread.min(MAX_BODY);
            let mut sink = [0u8; 8192];
            while left > 0 {
                let Some(t) = deadline.checked_duration_since(Instant::now()) else { break };
                if stream.set_read_timeout(Some(t.max(Duration::from_millis(1)))).is_err() {
                    break;
                }
                match stream.read(&mut sink) {
                    Ok(0) | Err(_) => break,
                    Ok(n) => left = left.saturating_sub(n as u64),
                }
            }
        }
    }
}

/// The reason phrase of the statuses the server sends.
fn reason(status: u16) -> &'static str {
    match status {
        200 => "OK",
        204 => "No Content",
        400 => "Bad Request",
        403 => "Forbidden",
        404 => "Not Found",
        405 => "Method Not Allowed",
        408 => "Request Timeout",
        411 => "Length Required",
        413 => "Content Too Large",
        414 => "URI Too Long",
        431 => "Request Header Fields Too Large",
        500 => "Internal Server Error",
        502 => "Bad Gateway",
        503 => "Service Unavailable",
        _ => "",
    }
}

/// A byte stream with a read deadline (a `TcpStream`; tests use a buffer).
pub trait Wire: Read {
    /// Makes the next reads fail after `timeout`.
    fn set_timeout(&mut self, timeout: Duration) -> io::Result<()>;
}

impl Wire for TcpStream {
    fn set_timeout(&mut self, timeout: Duration) -> io::Result<()> {
        self.set_read_timeout(Some(timeout.max(Duration::from_millis(1))))
    }
}

/// Reads up to `buf.len()` bytes before `until`: `Some(n)` (0 at the end of the stream), or
/// `None` when `until` passed first.
fn read_until(wire: &mut impl Wire, buf: &mut [u8], until: Instant) -> io::Result<Option<usize>> {
    loop {
        let Some(left) = until.checked_duration_since(Instant::now()).filter(|d| !d.is_zero())
        else {
            return Ok(None);
        };
        wire.set_timeout(left)?;
        match wire.read(buf) {
            Ok(n) => return Ok(Some(n)),
            Err(e) if e.kind() == io::ErrorKind::Interrupted => continue,
            Err(e) if matches!(e.kind(), io::ErrorKind::WouldBlock | io::ErrorKind::TimedOut) => {
                return Ok(None)
            }
            Err(e) => return Err(e),
        }
    }
}

fn broken() -> Reply {
    Reply::error(400, "the connection failed while reading")
}

/// A request head, parsed; the body (if any) is still on the wire.
#[derive(Debug)]
pub struct Head {
    pub method: String,
    /// The request target as sent (`/api/frame?after=3`).
    pub url: String,
    /// Header names and values, in order.
    pub headers: Vec<(String, String)>,
    /// Bytes read past the head (the start of the body).
    pub rest: Vec<u8>,
}

impl Head {
    /// The value of header `name` (case-insensitive), if present.
    pub fn header(&self, name: &str) -> Option<&str> {
        self.headers.iter().find(|(k, _)| k.eq_ignore_ascii_case(name)).map(|(_, v)| v.as_str())
    }

    /// The body's announced length: 0 without Content-Length; chunked bodies are refused.
    /// (Content-Length itself was checked with the head: see [`content_length`].)
    pub fn body_len(&self) -> Result<u64, Reply> {
        if self.header("Transfer-Encoding").is_some() {
            return Err(Reply::error(411, "send the body with a Content-Length (not chunked)"));
        }
        content_length(&self.headers).map(|n| n.unwrap_or(0))
    }
}

/// The length the Content-Length headers give, None without one. Every line must be a whole
/// number and all must agree: two different lengths frame the body two ways (how requests
/// are smuggled past a proxy), so they are refused whatever the route; the same length
/// repeated is one framing and is accepted (RFC 9110, 8.6).
fn content_length(headers: &[(String, String)]) -> Result<Option<u64>, Reply> {
    let mut length = None;
    for (_, v) in headers.iter().filter(|(k, _)| k.eq_ignore_ascii_case("Content-Length")) {
        // Digits only (RFC 9110: 1*DIGIT): Rust's parse would also take "+2".
        let v = v.trim();
        let n = Some(v)
            .filter(|v| !v.is_empty() && v.bytes().all(|b| b.is_ascii_digit()))
            .and_then(|v| v.parse::<u64>().ok())
            .ok_or_else(|| Reply::error(400, "Content-Length: not a whole number of bytes"))?;
        match length {
            Some(m) if m != n => {
                return Err(Reply::error(
                    400,
                    format!("Content-Length: {m} and {n} disagree; send one length"),
                ))
            }
            _ => length = Some(n),
        }
    }
    Ok(length)
}

/// What a turn of [`HeadReader::read`] gave.
#[derive(Debug)]
pub enum HeadProgress {
    /// The whole head.
    Done(Head),
    /// Not yet: the turn ended first (read on in another turn).
    Pending,
    /// The client closed the connection before sending anything.
    Closed,
}

/// A request head being read, in one or more turns, at most [`MAX_HEAD`] bytes, within
/// [`HEAD_TIMEOUT`] of the connection's accept.
pub struct HeadReader {
    buf: Vec<u8>,
    len: usize,
    deadline: Instant,
}

impl HeadReader {
    /// For a connection accepted at `accepted`.
    pub fn new(accepted: Instant) -> Self {
        HeadReader { buf: Vec::new(), len: 0, deadline: accepted + HEAD_TIMEOUT }
    }

    /// Reads for at most `turn` (not past the deadline, unless it passed before this turn):
    /// the head, `Pending` when the turn ended first, or the reply for a head that is too
    /// long, malformed or late.
    pub fn read(&mut self, wire: &mut impl Wire, turn: Duration) -> Result<HeadProgress, Reply> {
        let now = Instant::now();
        // A deadline that passed while the connection waited in the queue (every worker
        // busy) was the server's delay, not the client's: one last turn reads what has
        // arrived, so a whole head is served; only a turn that ends past the deadline without
        // one gives 408. A client that sends nothing gains at most that one turn.
        let until = if now >= self.deadline { now + turn } else { self.deadline.min(now + turn) };
        if self.buf.is_empty() {
            self.buf = vec![0u8; MAX_HEAD];
        }
        loop {
            if self.len == self.buf.len() {
                // Full without an end of head: say which part is too long.
                return Err(if self.buf.contains(&b'\n') {
                    Reply::error(431, format!("the request head is over {MAX_HEAD} bytes"))
                } else {
                    Reply::error(414, format!("the request line is over {MAX_HEAD} bytes"))
                });
            }
            let n = match read_until(wire, &mut self.buf[self.len..], until) {
                Ok(Some(n)) => n,
                Ok(None) if until < self.deadline => return Ok(HeadProgress::Pending),
                Ok(None) => {
                    return Err(Reply::error(408, "the request head did not arrive in time"))
                }
                Err(_) => return Err(broken()),
            };
            if n == 0 {
                return match self.len {
                    0 => Ok(HeadProgress::Closed),
                    _ => Err(Reply::error(400, "the request ended inside its head")),
                };
            }
            self.len += n;
            if let Some(head) = parse_head(&self.buf[..self.len])? {
                return Ok(HeadProgress::Done(head));
            }
        }
    }
}

/// The head at the start of `bytes`, None while it is incomplete.
fn parse_head(bytes: &[u8]) -> Result<Option<Head>, Reply> {
    let mut headers = [httparse::EMPTY_HEADER; MAX_HEADERS];
    let mut request = httparse::Request::new(&mut headers);
    match request.parse(bytes) {
        Ok(httparse::Status::Partial) => Ok(None),
        Ok(httparse::Status::Complete(end)) => {
            let headers: Vec<(String, String)> = request
                .headers
                .iter()
                .map(|h| (h.name.to_string(), String::from_utf8_lossy(h.value).into()))
                .collect();
            // The body's framing is checked before any route sees the request.
            content_length(&headers)?;
            // One Host (RFC 9112, 3.2): the check of the Host header reads the first, so a
            // second must not pass unseen.
            if headers.iter().filter(|(k, _)| k.eq_ignore_ascii_case("Host")).count() > 1 {
                return Err(Reply::error(400, "Host: sent more than once; send one"));
            }
            Ok(Some(Head {
                method: request.method.unwrap_or("").to_string(),
                url: request.path.unwrap_or("").to_string(),
                headers,
                rest: bytes[end..].to_vec(),
            }))
        }
        Err(httparse::Error::TooManyHeaders) => {
            Err(Reply::error(431, format!("more than {MAX_HEADERS} header lines")))
        }
        Err(e) => Err(Reply::error(400, format!("not an HTTP request ({e})"))),
    }
}

/// Reads and parses one request head within [`HEAD_TIMEOUT`] from now, in one turn.
/// `Ok(None)`: the client closed the connection before sending anything.
pub fn read_head(wire: &mut impl Wire) -> Result<Option<Head>, Reply> {
    match HeadReader::new(Instant::now()).read(wire, HEAD_TIMEOUT)? {
        HeadProgress::Done(head) => Ok(Some(head)),
        HeadProgress::Closed => Ok(None),
        // A turn as long as the timeout ends at the deadline: not reached.
        HeadProgress::Pending => Err(Reply::error(408, "the request head did not arrive in time")),
    }
}

/// Reads the body `head` announces (at most [`MAX_BODY`] bytes) within [`BODY_TIMEOUT`].
pub fn read_body(wire: &mut impl Wire, head: &Head) -> Result<Vec<u8>, Reply> {
    let len = head.body_len()?;
    if len > MAX_BODY {
        return Err(Reply::error(413, format!("the request body is over {MAX_BODY} bytes")));
    }
    let len = len as usize;
    let deadline = Instant::now() + BODY_TIMEOUT;
    let mut body = head.rest.clone();
    body.truncate(len);
    let start = body.len();
    body.resize(len, 0);
    let mut at = start;
    while at < len {
        let n = read_until(wire, &mut body[at..], deadline)
            .map_err(|_| broken())?
            .ok_or_else(|| Reply::error(408, "the request body did not arrive in time"))?;
        if n == 0 {
            return Err(Reply::error(400, "the request body is shorter than its Content-Length"));
        }
        at += n;
    }
    Ok(body)
}

/// A request's body, read from the wire only if a route asks for it (after the token check).
pub struct Body<'a, W: Wire> {
    wire: &'a mut W,
    head: &'a Head,
    read: bool,
}

impl<'a, W: Wire> Body<'a, W> {
    pub fn new(wire: &'a mut W, head: &'a Head) -> Self {
        Body { wire, head, read: false }
    }

    /// The body (see [`read_body`]).
    pub fn read(&mut self) -> Result<Vec<u8>, Reply> {
        self.read = true;
        read_body(self.wire, self.head)
    }

    /// Announced body bytes still on the wire (none once read).
    pub fn unread(&self) -> u64 {
        match self.read {
            true => 0,
            false => {
                let len = self.head.body_len().unwrap_or(0);
                len.saturating_sub(self.head.rest.len() as u64)
            }
        }
    }
}

/// A request's path and decoded query parameters, in order.
pub struct Target {
    pub path: String,
    pub query: Vec<(String, String)>,
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

    /// The value of parameter `key`, the last where it is given more than once.
    pub fn get(&self, key: &str) -> Option<&str> {
        self.query.iter().rev().find(|(k, _)| k == key).map(|(_, v)| v.as_str())
    }

    /// How many times parameter `key` is given.
    pub fn count(&self, key: &str) -> usize {
        self.query.iter().filter(|(k, _)| k == key).count()
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

#[cfg(test)]
mod tests {
    use super::*;

    /// Bytes handed out in the given pieces; then the end (or, with `hang`, a timeout).
    struct Pieces {
        pieces: std::collections::VecDeque<Vec<u8>>,
        hang: bool,
    }

    impl Pieces {
        fn new(pieces: &[&[u8]], hang: bool) -> Self {
            Pieces { pieces: pieces.iter().map(|p| p.to_vec()).collect(), hang }
        }
    }

    impl Read for Pieces {
        fn read(&mut self, buf: &mut [u8]) -> io::Result<usize> {
            let Some(mut p) = self.pieces.pop_front() else {
                return match self.hang {
                    true => Err(io::ErrorKind::WouldBlock.into()),
                    false => Ok(0),
                };
            };
            let n = p.len().min(buf.len());
            buf[..n].copy_from_slice(&p[..n]);
            if n < p.len() {
                self.pieces.push_front(p.split_off(n));
            }
            Ok(n)
        }
    }

    impl Wire for Pieces {
        fn set_timeout(&mut self, _: Duration) -> io::Result<()> {
            Ok(())
        }
    }

    fn status(r: Result<Option<Head>, Reply>) -> u16 {
        match r {
            Ok(_) => 200,
            Err(r) => r.status,
        }
    }

    #[test]
    fn heads_parse_in_pieces_and_bodies_follow() {
        let mut w = Pieces::new(
            &[
                b"POST /api/state?token=a HTTP/1.1\r\nHo",
                b"st: x\r\nContent-Length: 5\r\n\r\nab",
                b"cde",
            ],
            false,
        );
        let head = read_head(&mut w).unwrap().unwrap();
        assert_eq!((head.method.as_str(), head.url.as_str()), ("POST", "/api/state?token=a"));
        assert_eq!(head.header("host"), Some("x"));
        assert_eq!(read_body(&mut w, &head).unwrap(), b"abcde");
        assert!(read_head(&mut Pieces::new(&[], false)).unwrap().is_none());
    }

    #[test]
    fn oversized_malformed_or_late_heads_get_their_status() {
        let long_line = format!("GET /{} HTTP/1.1\r\n\r\n", "a".repeat(MAX_HEAD));
        assert_eq!(status(read_head(&mut Pieces::new(&[long_line.as_bytes()], true))), 414);
        let big_header = format!("GET / HTTP/1.1\r\nX: {}\r\n\r\n", "a".repeat(MAX_HEAD));
        assert_eq!(status(read_head(&mut Pieces::new(&[big_header.as_bytes()], true))), 431);
        let many = format!("GET / HTTP/1.1\r\n{}\r\n", "X: 1\r\n".repeat(MAX_HEADERS + 1));
        assert_eq!(status(read_head(&mut Pieces::new(&[many.as_bytes()], true))), 431);
        assert_eq!(status(read_head(&mut Pieces::new(&[b"\x00\x01 nonsense\r\n\r\n"], true))), 400);
        assert_eq!(status(read_head(&mut Pieces::new(&[b"GET / HTTP/1.1\r\n"], true))), 408);
        assert_eq!(status(read_head(&mut Pieces::new(&[b"GET / HTTP/1.1\r\n"], false))), 400);
        let head = |h: &str| read_head(&mut Pieces::new(&[h.as_bytes()], true)).unwrap().unwrap();
        let over = head(&format!("POST / HTTP/1.1\r\nContent-Length: {}\r\n\r\n", MAX_BODY + 1));
        assert_eq!(read_body(&mut Pieces::new(&[], true), &over).unwrap_err().status, 413);
        let chunked = head("POST / HTTP/1.1\r\nTransfer-Encoding: chunked\r\n\r\n");
        assert_eq!(read_body(&mut Pieces::new(&[], true), &chunked).unwrap_err().status, 411);
        let twice = "POST / HTTP/1.1\r\nContent-Length: 2\r\nContent-Length: 3\r\n\r\nabc";
        assert_eq!(status(read_head(&mut Pieces::new(&[twice.as_bytes()], true))), 400);
        let same = head("POST / HTTP/1.1\r\nContent-Length: 3\r\ncontent-length: 3\r\n\r\nabc");
        assert_eq!(read_body(&mut Pieces::new(&[], true), &same).unwrap(), b"abc");
        for bad in ["+2", "-2", "0x2", "", "2 2"] {
            let r = format!("POST / HTTP/1.1\r\nContent-Length: {bad}\r\n\r\nab");
            assert_eq!(status(read_head(&mut Pieces::new(&[r.as_bytes()], true))), 400, "{bad}");
        }
        let hosts = "GET / HTTP/1.1\r\nHost: localhost\r\nhost: evil.example\r\n\r\n";
        assert_eq!(status(read_head(&mut Pieces::new(&[hosts.as_bytes()], true))), 400);
        let short = head("POST / HTTP/1.1\r\nContent-Length: 9\r\n\r\nab");
        assert_eq!(read_body(&mut Pieces::new(&[], false), &short).unwrap_err().status, 400);
    }

    /// Requests cut, spliced and flipped at random (a fixed seed): every one gets a head or one
    /// of the statuses above, never a panic, and no read goes past the limits.
    #[test]
    fn mangled_requests_get_a_status_and_never_a_panic() {
        let valid = b"POST /api/state?token=abc HTTP/1.1\r\nHost: 127.0.0.1:8000\r\n\
                      Content-Length: 11\r\nX-Isoview-Token: abc\r\n\r\n{\"set\": []}";
        let mut seed = 0x9e37_79b9_7f4a_7c15u64;
        let mut next = move |n: usize| {
            seed ^= seed << 13;
            seed ^= seed >> 7;
            seed ^= seed << 17;
            (seed % n.max(1) as u64) as usize
        };
        for _ in 0..3000 {
            let mut bytes = valid.to_vec();
            for _ in 0..1 + next(4) {
                let at = next(bytes.len());
                match next(5) {
                    0 => bytes.truncate(at),
                    1 => bytes[at] = next(256) as u8,
                    2 => bytes.splice(at..at, vec![b'a'; next(3) * MAX_HEAD]).for_each(drop),
                    3 => bytes.splice(at..at, b"\r\n".iter().copied()).for_each(drop),
                    _ => bytes
                        .splice(at..at, b"Content-Length: 99999999\r\n".iter().copied())
                        .for_each(drop),
                }
                if bytes.is_empty() {
                    bytes.push(b'G');
                }
            }
            let pieces: Vec<&[u8]> = bytes.chunks(1 + next(64)).collect();
            let mut wire = Pieces::new(&pieces, next(2) == 0);
            match read_head(&mut wire) {
                Ok(None) => {}
                Ok(Some(head)) => {
                    if let Err(r) = read_body(&mut wire, &head) {
                        assert!([400, 408, 411, 413].contains(&r.status), "{}", r.status);
                    }
                }
                Err(r) => assert!([400, 408, 414, 431].contains(&r.status), "{}", r.status),
            }
        }
    }

    #[test]
    fn replies_are_http_with_a_length_and_close() {
        let text = String::from_utf8(Reply::error(403, "no").header("X-A", "1").encode()).unwrap();
        assert!(text.starts_with("HTTP/1.1 403 Forbidden\r\n"), "{text}");
        for h in ["Connection: close\r\n", "Content-Length: 14\r\n", "X-A: 1\r\n"] {
            assert!(text.contains(h), "{h}: {text}");
        }
        assert!(text.ends_with("\r\n\r\n{\"error\":\"no\"}"), "{text}");
    }

    #[test]
    fn query_strings_decode() {
        let t = Target::parse("/api/probe?x=3&y=4&token=ab%2Fc&s=a+b&flag");
        assert_eq!(t.path, "/api/probe");
        assert_eq!(t.get("x"), Some("3"));
        assert_eq!(t.get("token"), Some("ab/c"));
        assert_eq!(t.get("s"), Some("a b"));
        assert_eq!(t.get("flag"), Some(""));
        let t = Target::parse("/api/state?token=a&x=1&token=b");
        assert_eq!((t.count("token"), t.count("x"), t.count("y")), (2, 1, 0));
        assert_eq!(percent_decode("100%"), "100%");
        assert_eq!(percent_decode("%zz%41"), "%zzA");
    }
}
