//! Bytes → text, as the files were written: UTF-8 with or without a byte-order mark,
//! Windows-1252 when the bytes are not UTF-8, UTF-16LE after its mark (Fagor 8065).
//! The decoded text keeps its line ends, so that a table written back ([`Text::encode`])
//! is byte for byte the original wherever nothing was changed.

/// How a file's bytes were decoded.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum Encoding {
    Utf8,
    /// Windows-1252 (what a Western-locale Excel writes for "CSV").
    Cp1252,
    Utf16Le,
}

/// A decoded file: its text (line ends kept), encoding and byte-order mark.
#[derive(Debug, Clone, PartialEq)]
pub struct Text {
    pub text: String,
    pub encoding: Encoding,
    pub bom: bool,
}

/// The characters Windows-1252 puts at 0x80…0x9F (the rest is Latin-1); the five unused
/// codes map to themselves, as Windows' own conversion does.
const CP1252_HIGH: [char; 32] = [
    '€', '\u{81}', '‚', 'ƒ', '„', '…', '†', '‡', 'ˆ', '‰', 'Š', '‹', 'Œ', '\u{8d}', 'Ž', '\u{8f}',
    '\u{90}', '‘', '’', '“', '”', '•', '–', '—', '˜', '™', 'š', '›', 'œ', '\u{9d}', 'ž', 'Ÿ',
];

impl Text {
    /// Decodes `bytes`: a UTF-16LE mark (FF FE) → UTF-16LE (an odd byte count or an unpaired
    /// surrogate is `Err` with the 1-based line of the fault); a UTF-8 mark or valid UTF-8 →
    /// UTF-8; anything else → Windows-1252.
    pub fn decode(bytes: &[u8]) -> Result<Text, (usize, String)> {
        if let Some(rest) = bytes.strip_prefix(&[0xFF, 0xFE]) {
            if rest.len() % 2 != 0 {
                let line = 1 + rest
                    .chunks(2)
                    .filter(|c| c.len() == 2 && c[0] == b'\n' && c[1] == 0)
                    .count();
                return Err((line, "UTF-16LE text with an odd number of bytes".into()));
            }
            let units: Vec<u16> = rest
                .chunks_exact(2)
                .map(|c| u16::from_le_bytes([c[0], c[1]]))
                .collect();
            let mut text = String::with_capacity(units.len());
            let mut line = 1;
            for c in char::decode_utf16(units.iter().copied()) {
                match c {
                    Ok(ch) => {
                        if ch == '\n' {
                            line += 1;
                        }
                        text.push(ch);
                    }
                    Err(_) => return Err((line, "an unpaired UTF-16 surrogate".into())),
                }
            }
            return Ok(Text {
                text,
                encoding: Encoding::Utf16Le,
                bom: true,
            });
        }
        let (body, bom) = match bytes.strip_prefix(&[0xEF, 0xBB, 0xBF]) {
            Some(rest) => (rest, true),
            None => (bytes, false),
        };
        match std::str::from_utf8(body) {
            Ok(s) => Ok(Text {
                text: s.to_string(),
                encoding: Encoding::Utf8,
                bom,
            }),
            Err(_) => Ok(Text {
                text: body
                    .iter()
                    .map(|&b| match b {
                        0x80..=0x9F => CP1252_HIGH[usize::from(b - 0x80)],
                        _ => char::from(b),
                    })
                    .collect(),
                encoding: Encoding::Cp1252,
                bom,
            }),
        }
    }

    /// The bytes of `text` in this file's encoding and mark (the inverse of
    /// [`Text::decode`] for every text it produced). A character Windows-1252 cannot
    /// hold is written as `?`.
    pub fn encode(&self, text: &str) -> Vec<u8> {
        let mut out = Vec::with_capacity(text.len() * 2 + 3);
        match self.encoding {
            Encoding::Utf16Le => {
                out.extend_from_slice(&[0xFF, 0xFE]);
                for u in text.encode_utf16() {
                    out.extend_from_slice(&u.to_le_bytes());
                }
            }
            Encoding::Utf8 => {
                if self.bom {
                    out.extend_from_slice(&[0xEF, 0xBB, 0xBF]);
                }
                out.extend_from_slice(text.as_bytes());
            }
            Encoding::Cp1252 => {
                if self.bom {
                    out.extend_from_slice(&[0xEF, 0xBB, 0xBF]);
                }
                for ch in text.chars() {
                    let code = u32::from(ch);
                    let byte = if code < 0x80 || (0xA0..=0xFF).contains(&code) {
                        code as u8
                    } else if let Some(i) = CP1252_HIGH.iter().position(|&c| c == ch) {
                        0x80 + i as u8
                    } else {
                        b'?'
                    };
                    out.push(byte);
                }
            }
        }
        out
    }

    /// The lines (without their `\n` or `\r\n`), each with its byte offset in
    /// [`Text::text`]; line `i` of the result is physical line `i + 1`.
    pub fn lines(&self) -> Vec<(usize, &str)> {
        lines_of(&self.text)
    }
}

/// The lines of `text` (without `\n`/`\r\n`) with their byte offsets.
pub(crate) fn lines_of(text: &str) -> Vec<(usize, &str)> {
    let mut out = Vec::new();
    let mut start = 0;
    for (i, b) in text.bytes().enumerate() {
        if b == b'\n' {
            let line = &text[start..i];
            out.push((start, line.strip_suffix('\r').unwrap_or(line)));
            start = i + 1;
        }
    }
    if start < text.len() {
        let line = &text[start..];
        out.push((start, line.strip_suffix('\r').unwrap_or(line)));
    }
    out
}

/// The number of decimals written in a number's text (`-0.00127` → 5, `12` → 0).
pub(crate) fn decimals(token: &str) -> usize {
    token
        .split_once('.')
        .map(|(_, f)| f.chars().take_while(char::is_ascii_digit).count())
        .unwrap_or(0)
}

/// A plain decimal number (`-12.5`, `+3`, `.5`, `1e-3`), finite. Refuses what `f64`'s
/// parser would also take but no instrument writes (`inf`, `NaN`).
pub(crate) fn number(token: &str) -> Option<f64> {
    let t = token.trim();
    if t.is_empty()
        || !t
            .bytes()
            .all(|b| b.is_ascii_digit() || matches!(b, b'.' | b'-' | b'+' | b'e' | b'E'))
    {
        return None;
    }
    t.parse::<f64>().ok().filter(|v| v.is_finite())
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn utf16_with_mark_round_trips_byte_for_byte() {
        let s = "X AXIS ;3100\r\n2;/A ;0.0127\r\n";
        let mut bytes = vec![0xFF, 0xFE];
        for u in s.encode_utf16() {
            bytes.extend_from_slice(&u.to_le_bytes());
        }
        let t = Text::decode(&bytes).expect("utf-16");
        assert_eq!(t.encoding, Encoding::Utf16Le);
        assert_eq!(t.text, s);
        assert_eq!(t.encode(&t.text), bytes);
        assert_eq!(t.lines()[1].1, "2;/A ;0.0127");
    }

    #[test]
    fn cp1252_is_decoded_and_written_back() {
        let bytes = b"Temp \xb0C;\x80\r\n".to_vec();
        let t = Text::decode(&bytes).expect("cp1252");
        assert_eq!(t.encoding, Encoding::Cp1252);
        assert_eq!(t.text, "Temp °C;€\r\n");
        assert_eq!(t.encode(&t.text), bytes);
    }

    #[test]
    fn bom_is_kept_and_lines_lose_their_ends() {
        let bytes = b"\xEF\xBB\xBFa;b\r\nc\n\nd".to_vec();
        let t = Text::decode(&bytes).expect("utf-8");
        assert!(t.bom);
        let lines: Vec<&str> = t.lines().iter().map(|l| l.1).collect();
        assert_eq!(lines, ["a;b", "c", "", "d"]);
        assert_eq!(t.encode(&t.text), bytes);
    }

    #[test]
    fn numbers_and_decimals() {
        assert_eq!(decimals("-0.00127"), 5);
        assert_eq!(decimals("130"), 0);
        assert_eq!(number(" -5.00000 "), Some(-5.0));
        assert_eq!(number("NaN"), None);
        assert_eq!(number("inf"), None);
        assert_eq!(number("12,5"), None);
    }
}
