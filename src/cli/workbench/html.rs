//! The page shell, HTML escaping and small table helpers. Every asset is inside the
//! binary (`assets/`): a page loads nothing from another host.

use std::fmt::Write;

pub(crate) const STYLE: &str = include_str!("assets/style.css");
pub(crate) const SCRIPT: &str = include_str!("assets/app.js");
pub(crate) const FAVICON: &str = include_str!("assets/favicon.svg");

/// `text` safe inside HTML text and attribute values.
pub(crate) fn esc(text: &str) -> String {
    let mut out = String::with_capacity(text.len());
    for c in text.chars() {
        match c {
            '&' => out.push_str("&amp;"),
            '<' => out.push_str("&lt;"),
            '>' => out.push_str("&gt;"),
            '"' => out.push_str("&quot;"),
            '\'' => out.push_str("&#39;"),
            c => out.push(c),
        }
    }
    out
}

/// `id` in a URL path: each `/`-separated part percent-encoded apart from unreserved
/// characters.
pub(crate) fn url_path(id: &str) -> String {
    id.split('/')
        .map(|part| {
            let mut s = String::new();
            for b in part.bytes() {
                if b.is_ascii_alphanumeric() || b"-._~".contains(&b) {
                    s.push(b as char);
                } else {
                    let _ = write!(s, "%{b:02X}");
                }
            }
            s
        })
        .collect::<Vec<_>>()
        .join("/")
}

/// A whole page: the title, the navigation, `body` (already HTML), and the per-run form
/// token in a `<meta>` for the page's script.
pub(crate) fn page(title: &str, form_token: &str, body: &str) -> String {
    format!(
        "<!doctype html>\n<html lang=\"en\"><head><meta charset=\"utf-8\">\
         <meta name=\"viewport\" content=\"width=device-width, initial-scale=1\">\
         <meta name=\"errmap-form-token\" content=\"{token}\">\
         <title>{title} — errmap workbench</title>\
         <link rel=\"icon\" href=\"/favicon.svg\" type=\"image/svg+xml\">\
         <link rel=\"stylesheet\" href=\"/assets/style.css\"></head>\
         <body><header><a class=\"brand\" href=\"/\">errmap workbench</a>\
         <nav><a href=\"/\">Workspace</a><a href=\"/live\">Live capture</a>\
         <a href=\"/history\">Fleet history</a></nav></header>\
         <main><h1>{title}</h1>\n{body}\n</main>\
         <div id=\"tip\" role=\"tooltip\" hidden></div>\
         <script src=\"/assets/app.js\"></script></body></html>\n",
        token = esc(form_token),
        title = esc(title),
    )
}

/// A table: `head` cells, then rows of cells (already HTML).
pub(crate) fn table(head: &[&str], rows: &[Vec<String>]) -> String {
    let mut s = String::from("<table><thead><tr>");
    for h in head {
        let _ = write!(s, "<th>{}</th>", esc(h));
    }
    s.push_str("</tr></thead><tbody>");
    for r in rows {
        s.push_str("<tr>");
        for c in r {
            let _ = write!(s, "<td>{c}</td>");
        }
        s.push_str("</tr>");
    }
    s.push_str("</tbody></table>");
    s
}

/// A number with `d` decimals and its unit, as text (an angle's °, ′ and ″ follow the
/// number without a space, as the SI brochure writes them).
pub(crate) fn num(v: f64, d: usize, unit: &str) -> String {
    if v.is_finite() && matches!(unit, "°" | "′" | "″") {
        format!("{v:.d$}{unit}")
    } else if v.is_finite() {
        format!("{v:.d$} {unit}")
    } else {
        "—".into()
    }
}

/// An error message box.
pub(crate) fn error_box(message: &str) -> String {
    format!("<p class=\"error\">{}</p>", esc(message))
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn markup_and_separators_are_escaped() {
        assert_eq!(
            esc("<a href=\"x\">&'"),
            "&lt;a href=&quot;x&quot;&gt;&amp;&#39;"
        );
        assert_eq!(url_path("a b/c%d/é"), "a%20b/c%25d/%C3%A9");
    }
}
