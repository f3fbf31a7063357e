//! Who may talk to the server: a request must carry the session's random token (`?token=` in
//! the URL or an `X-Isoview-Token` header), and its `Host` header must name this machine by
//! `localhost` or an IP address. The Host rule defeats DNS rebinding: a page on
//! `evil.example` that re-points its name at 127.0.0.1 still sends `Host: evil.example`.
//! (The port is not checked: behind `ssh -L 8000:127.0.0.1:PORT` browsers send `localhost:8000`.)

/// A random token of 32 hex digits (128 bits from the operating system's generator).
pub fn new_token() -> Result<String, String> {
    let mut bytes = [0u8; 16];
    getrandom::fill(&mut bytes)
        .map_err(|e| format!("cannot get random bytes for the token: {e}"))?;
    Ok(bytes.iter().map(|b| format!("{b:02x}")).collect())
}

/// Whether `given` equals `token`, in time independent of where they differ.
pub fn token_matches(token: &str, given: &str) -> bool {
    let (a, b) = (token.as_bytes(), given.as_bytes());
    a.len() == b.len() && a.iter().zip(b).fold(0u8, |acc, (x, y)| acc | (x ^ y)) == 0
}

/// Whether a `Host` header names this machine: `localhost` or an IP literal (v4, or v6 in
/// brackets), with or without a port.
pub fn host_allowed(host: &str) -> bool {
    let host = host.trim();
    let name = if let Some(rest) = host.strip_prefix('[') {
        match rest.split_once(']') {
            Some((v6, port)) if port.is_empty() || is_port(port) => {
                return v6.parse::<std::net::Ipv6Addr>().is_ok()
            }
            _ => return false,
        }
    } else {
        match host.rsplit_once(':') {
            Some((name, port)) if is_port(port) => name,
            Some(_) => return false,
            None => host,
        }
    };
    name.eq_ignore_ascii_case("localhost") || name.parse::<std::net::Ipv4Addr>().is_ok()
}

fn is_port(s: &str) -> bool {
    s.strip_prefix(':').is_some_and(|p| p.parse::<u16>().is_ok())
        || (!s.starts_with(':') && s.parse::<u16>().is_ok())
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn hosts_naming_this_machine_pass_and_names_do_not() {
        for ok in
            ["127.0.0.1:8000", "localhost:8000", "LOCALHOST", "[::1]:8000", "[::1]", "10.0.0.5"]
        {
            assert!(host_allowed(ok), "{ok}");
        }
        for bad in [
            "evil.example",
            "evil.example:8000",
            "127.0.0.1.nip.io:80",
            "[::1]x",
            "localhost:x",
            "",
        ] {
            assert!(!host_allowed(bad), "{bad}");
        }
    }

    #[test]
    fn tokens_are_random_hex_and_compared_whole() {
        let (a, b) = (new_token().unwrap(), new_token().unwrap());
        assert_eq!(a.len(), 32);
        assert!(a.chars().all(|c| c.is_ascii_hexdigit()));
        assert_ne!(a, b);
        assert!(token_matches(&a, &a));
        assert!(!token_matches(&a, &b));
        assert!(!token_matches(&a, &a[..31]));
        assert!(!token_matches(&a, ""));
    }
}
