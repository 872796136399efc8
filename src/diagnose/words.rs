//! Numbers and lists in words, for the `where` texts, ambiguities and refusals.

/// `v` with `d` decimals, without a minus sign on a value that rounds to zero.
pub(crate) fn fixed(v: f64, d: usize) -> String {
    let s = format!("{v:.d$}");
    if s.starts_with('-') && s[1..].chars().all(|c| c == '0' || c == '.') {
        s[1..].to_string()
    } else {
        s
    }
}

pub(super) fn fmt_sig(v: f64) -> String {
    if v == 0.0 || !v.is_finite() {
        return format!("{v}");
    }
    let digits = (3 - v.abs().log10().floor() as i32).clamp(0, 8) as usize;
    format!("{v:.digits$}")
}

pub(super) fn range(v: &[f64]) -> (f64, f64) {
    v.iter()
        .fold((f64::INFINITY, f64::NEG_INFINITY), |(l, h), &x| {
            (l.min(x), h.max(x))
        })
}

pub(super) fn list(v: &[f64], unit: &str) -> String {
    let mut s: Vec<f64> = v.to_vec();
    s.sort_by(f64::total_cmp);
    s.dedup_by(|a, b| (*a - *b).abs() < 1e-6);
    let items: Vec<String> = s.iter().take(6).map(|v| format!("{v}")).collect();
    let more = if s.len() > 6 { ", …" } else { "" };
    format!("{}{more} {unit}", items.join(", "))
}
