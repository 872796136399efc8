//! UTC instants as the ledger stores them: whole seconds since 1970-01-01T00:00:00Z,
//! written `YYYY-MM-DDTHH:MM:SSZ` (so that text order is time order). The civil-date
//! conversion is the proleptic Gregorian calendar's, by the day-count algorithm of
//! H. Hinnant, "chrono-Compatible Low-Level Date Algorithms" (2013).

/// Seconds in a day.
pub(crate) const DAY_S: i64 = 86_400;

/// The earliest test time a ledger takes: 1970-01-01T00:00:00Z (no result errmap reads
/// is older; a year 0001 is a typing slip, and would bend every trend through it).
pub const EARLIEST_S: i64 = 0;

/// How far a test time may lie after the ledger's clock: one day, more than the largest
/// UTC offset (14 h) so that a local time given as UTC, or a measuring computer whose
/// clock runs ahead of the ledger's host, is still taken.
pub const CLOCK_SKEW_S: i64 = DAY_S;

/// The latest test time a ledger takes when its clock reads `now_s`.
pub fn latest_at(now_s: i64) -> i64 {
    now_s.saturating_add(CLOCK_SKEW_S)
}

/// Why a time could not be read.
#[derive(Debug, Clone, PartialEq, thiserror::Error)]
#[error(
    "{text:?}: not a time (RFC 3339 with Z or an offset, e.g. 2026-03-01T08:00:00Z, or a date YYYY-MM-DD)"
)]
pub struct TimeError {
    /// The text given.
    pub text: String,
}

/// Days since 1970-01-01 of a proleptic Gregorian date.
pub(crate) fn days_from_civil(y: i64, m: i64, d: i64) -> i64 {
    let y = if m <= 2 { y - 1 } else { y };
    let era = y.div_euclid(400);
    let yoe = y - era * 400;
    let mp = (m + 9) % 12;
    let doy = (153 * mp + 2) / 5 + d - 1;
    let doe = yoe * 365 + yoe / 4 - yoe / 100 + doy;
    era * 146_097 + doe - 719_468
}

/// The date (year, month, day) of a day count since 1970-01-01.
pub(crate) fn civil_from_days(z: i64) -> (i64, i64, i64) {
    let z = z + 719_468;
    let era = z.div_euclid(146_097);
    let doe = z - era * 146_097;
    let yoe = (doe - doe / 1460 + doe / 36_524 - doe / 146_096) / 365;
    let doy = doe - (365 * yoe + yoe / 4 - yoe / 100);
    let mp = (5 * doy + 2) / 153;
    let d = doy - (153 * mp + 2) / 5 + 1;
    let m = if mp < 10 { mp + 3 } else { mp - 9 };
    (yoe + era * 400 + i64::from(m <= 2), m, d)
}

fn days_in_month(y: i64, m: i64) -> i64 {
    match m {
        2 if (y % 4 == 0 && y % 100 != 0) || y % 400 == 0 => 29,
        2 => 28,
        4 | 6 | 9 | 11 => 30,
        _ => 31,
    }
}

fn digits(s: &str) -> Option<i64> {
    (!s.is_empty() && s.bytes().all(|b| b.is_ascii_digit()))
        .then(|| s.parse().ok())
        .flatten()
}

/// Reads an RFC 3339 time (`Z` or `±HH:MM`; fractions of a second are truncated) or a
/// date `YYYY-MM-DD` (00:00Z) into seconds since the epoch, UTC.
pub fn parse_utc(text: &str) -> Result<i64, TimeError> {
    parse(text.trim()).ok_or_else(|| TimeError {
        text: text.to_string(),
    })
}

fn parse(s: &str) -> Option<i64> {
    let b = s.as_bytes();
    if b.len() < 10 || b[4] != b'-' || b[7] != b'-' {
        return None;
    }
    let (y, m, d) = (digits(&s[0..4])?, digits(&s[5..7])?, digits(&s[8..10])?);
    if !(1..=9999).contains(&y) || !(1..=12).contains(&m) || d < 1 || d > days_in_month(y, m) {
        return None;
    }
    let day = days_from_civil(y, m, d) * DAY_S;
    if b.len() == 10 {
        return Some(day);
    }
    if !matches!(b[10], b'T' | b't' | b' ') || b.len() < 20 || b[13] != b':' || b[16] != b':' {
        return None;
    }
    let (hh, mm, ss) = (
        digits(&s[11..13])?,
        digits(&s[14..16])?,
        digits(&s[17..19])?,
    );
    if hh > 23 || mm > 59 || ss > 60 {
        return None;
    }
    let mut rest = &s[19..];
    if let Some(frac) = rest.strip_prefix('.') {
        let n = frac.bytes().take_while(u8::is_ascii_digit).count();
        if n == 0 {
            return None;
        }
        rest = &frac[n..];
    }
    let offset = match rest {
        "Z" | "z" => 0,
        _ => {
            let rb = rest.as_bytes();
            if rb.len() != 6 || !matches!(rb[0], b'+' | b'-') || rb[3] != b':' {
                return None;
            }
            let (oh, om) = (digits(&rest[1..3])?, digits(&rest[4..6])?);
            if oh > 23 || om > 59 {
                return None;
            }
            let sign = if rb[0] == b'+' { 1 } else { -1 };
            sign * (oh * 3600 + om * 60)
        }
    };
    Some(day + hh * 3600 + mm * 60 + ss - offset)
}

/// `YYYY-MM-DDTHH:MM:SSZ`.
pub fn format_utc(t: i64) -> String {
    let (y, m, d) = civil_from_days(t.div_euclid(DAY_S));
    let s = t.rem_euclid(DAY_S);
    format!(
        "{y:04}-{m:02}-{d:02}T{:02}:{:02}:{:02}Z",
        s / 3600,
        s / 60 % 60,
        s % 60
    )
}

/// The UTC date `YYYY-MM-DD` of a time in seconds (fractional allowed), `None` when it is
/// not finite or falls outside years 1–9999.
pub(crate) fn format_date(t_s: f64) -> Option<String> {
    if !t_s.is_finite() || t_s.abs() > 4e11 {
        return None;
    }
    let (y, m, d) = civil_from_days((t_s / DAY_S as f64).floor() as i64);
    (1..=9999)
        .contains(&y)
        .then(|| format!("{y:04}-{m:02}-{d:02}"))
}

/// Now, whole seconds since the epoch.
pub fn now_utc() -> i64 {
    std::time::SystemTime::now()
        .duration_since(std::time::UNIX_EPOCH)
        .map(|d| d.as_secs() as i64)
        .unwrap_or(0)
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn known_instants_round_trip() {
        assert_eq!(parse_utc("1970-01-01").expect("a value"), 0);
        assert_eq!(
            parse_utc("2000-03-01T00:00:00Z").expect("a value"),
            951_868_800
        );
        assert_eq!(
            parse_utc("2026-03-01T10:30:15.9+02:00").expect("a value"),
            parse_utc("2026-03-01T08:30:15Z").expect("a value")
        );
        for t in [0, 951_868_800, 1_798_761_599, -62_135_596_800] {
            assert_eq!(parse_utc(&format_utc(t)).expect("a value"), t);
        }
        assert_eq!(format_utc(-62_135_596_800), "0001-01-01T00:00:00Z");
        assert_eq!(format_date(-62_135_596_801.0), None);
        for bad in [
            "2026-02-30",
            "2026-13-01",
            "26-01-01",
            "2026-01-01T08:00:00",
            "x",
        ] {
            assert!(parse_utc(bad).is_err(), "{bad}");
        }
    }
}
