//! Standard base64 (RFC 4648, `=` padding, whitespace ignored), for VTK XML's inline binary
//! data: 30 lines instead of a dependency.

/// Decodes `text`; None on a character outside the alphabet or a stray `=`. Padding may end
/// each 4-character group (VTK encodes a block's header and its data as separate strings).
pub fn decode(text: &[u8]) -> Option<Vec<u8>> {
    let mut out = Vec::with_capacity(text.len() / 4 * 3);
    let (mut acc, mut bits, mut group, mut pad) = (0u32, 0u32, 0usize, 0usize);
    for &c in text.iter().filter(|c| !c.is_ascii_whitespace()) {
        let v = match c {
            b'A'..=b'Z' => c - b'A',
            b'a'..=b'z' => c - b'a' + 26,
            b'0'..=b'9' => c - b'0' + 52,
            b'+' => 62,
            b'/' => 63,
            b'=' => {
                pad += 1;
                group += 1;
                if group == 4 {
                    // A padded group ends: drop the partial bits.
                    (acc, bits, group, pad) = (0, 0, 0, 0);
                }
                continue;
            }
            _ => return None,
        };
        if pad > 0 {
            return None;
        }
        acc = (acc << 6) | v as u32;
        bits += 6;
        group = (group + 1) % 4;
        if bits >= 8 {
            bits -= 8;
            out.push((acc >> bits) as u8);
            acc &= (1 << bits) - 1;
        }
    }
    (group == 0).then_some(out)
}

#[cfg(test)]
mod tests {
    #[test]
    fn decodes_padded_and_concatenated_strings() {
        assert_eq!(super::decode(b"aGVsbG8="), Some(b"hello".to_vec()));
        assert_eq!(super::decode(b"aGk=aGk="), Some(b"hihi".to_vec()));
        assert_eq!(super::decode(b"aGVs\nbG8h"), Some(b"hello!".to_vec()));
        assert_eq!(super::decode(b"aGVsbG8"), None);
        assert_eq!(super::decode(b"a*=="), None);
    }
}
