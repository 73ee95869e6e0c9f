//! Self-contained HTML reports: the Markdown report's text and tables with the plots in place.
//!
//! A page is one file: the CSS is embedded, every plot is inline SVG, there is no script and
//! nothing is fetched from the network. It reads on a laptop screen (a centred column of at
//! most 64 rem, plots scaled to the column) and prints (figures and table rows are not split
//! across pages, links show no decoration). The Markdown is rendered by `pulldown-cmark`
//! (CommonMark with GitHub tables), so the page says exactly what `report.md` / `summary.md`
//! say; the Markdown files stay for review diffs.

use std::fmt::Write as _;

use pulldown_cmark::{Options, Parser, html};

/// A plot to place in a page.
#[derive(Clone, Debug, PartialEq)]
pub struct Picture {
    /// Text of the Markdown heading (any level, without the `#`s) this plot goes under, at
    /// the end of that section; the first heading that starts with this text is taken. `None`
    /// or no such heading: the plot goes in a "Figures" section at the end.
    pub after_heading: Option<String>,
    /// One sentence saying what the plot shows.
    pub caption: String,
    /// The file the same SVG is written to beside the page (named in the caption).
    pub file: String,
    /// The SVG document.
    pub svg: String,
}

/// The page's style sheet.
pub const CSS: &str = "\
:root { color-scheme: light; }
body { font-family: system-ui, -apple-system, 'Segoe UI', 'DejaVu Sans', Roboto, Helvetica, Arial, sans-serif;
  max-width: 64rem; margin: 2rem auto; padding: 0 1.5rem; line-height: 1.45; color: #1b1b1b; background: #fff; }
h1 { font-size: 1.6rem; border-bottom: 2px solid #ddd; padding-bottom: .3rem; }
h2 { font-size: 1.25rem; margin-top: 2.2rem; border-bottom: 1px solid #eee; padding-bottom: .2rem; }
h3 { font-size: 1.05rem; }
table { border-collapse: collapse; margin: 1rem 0; font-size: .9rem; font-variant-numeric: tabular-nums; }
th, td { border: 1px solid #d0d0d0; padding: .25rem .6rem; vertical-align: top; }
th { background: #f3f3f3; }
tr:nth-child(even) td { background: #fafafa; }
code { font-family: 'DejaVu Sans Mono', Menlo, Consolas, monospace; font-size: .88em; background: #f4f4f4; padding: 0 .2em; border-radius: 3px; }
pre { background: #f4f4f4; padding: .6rem; overflow-x: auto; }
pre code { background: none; padding: 0; }
figure { margin: 1.5rem 0; text-align: center; }
figure svg { max-width: 100%; height: auto; border: 1px solid #eee; }
figcaption { font-size: .9rem; color: #444; margin-top: .3rem; }
footer { margin-top: 3rem; font-size: .8rem; color: #666; }
@media print {
  body { max-width: none; margin: 0; padding: 0; font-size: 10pt; }
  h1, h2, h3 { break-after: avoid; }
  figure, tr { break-inside: avoid; }
  figure svg { border: none; max-height: 9cm; width: auto; }
  table { font-size: 8.5pt; }
  a { color: inherit; text-decoration: none; }
}
";

/// Escapes `&`, `<`, `>` and `"` for HTML text and attributes.
pub fn escape(s: &str) -> String {
    let mut o = String::with_capacity(s.len());
    for c in s.chars() {
        match c {
            '&' => o.push_str("&amp;"),
            '<' => o.push_str("&lt;"),
            '>' => o.push_str("&gt;"),
            '"' => o.push_str("&quot;"),
            _ => o.push(c),
        }
    }
    o
}

/// Markdown (CommonMark with tables and strikethrough) to an HTML fragment.
pub fn markdown_to_html(md: &str) -> String {
    let mut opts = Options::empty();
    opts.insert(Options::ENABLE_TABLES);
    opts.insert(Options::ENABLE_STRIKETHROUGH);
    let mut out = String::new();
    html::push_html(&mut out, Parser::new_ext(md, opts));
    out
}

/// The heading text of a Markdown line (`## Table 4: …` → `Table 4: …`), if it is one.
fn heading(line: &str) -> Option<&str> {
    let t = line.trim_start_matches('#');
    (line.starts_with('#') && t.starts_with(' ') && line.len() - t.len() <= 6).then(|| t.trim())
}

fn picture_html(p: &Picture) -> String {
    // The XML prolog, if any, is not valid inside HTML.
    let svg = p.svg.trim();
    let svg = svg
        .strip_prefix("<?xml")
        .and_then(|s| s.find("?>").map(|i| s[i + 2..].trim_start()))
        .unwrap_or(svg);
    let svg = svg.replacen(
        "<svg ",
        &format!("<svg role=\"img\" aria-label=\"{}\" ", escape(&p.caption)),
        1,
    );
    format!(
        "<figure>\n{svg}\n<figcaption>{} <span class=\"file\">(<code>{}</code>)</span></figcaption>\n</figure>\n",
        escape(&p.caption),
        escape(&p.file)
    )
}

/// A complete page: `markdown` rendered section by section, each picture after the section
/// whose heading starts with its [`Picture::after_heading`], the others at the end.
///
/// Deterministic: the same input gives the same bytes.
pub fn page(title: &str, markdown: &str, pictures: &[Picture]) -> String {
    // Split the Markdown at headings (outside fenced code blocks).
    let mut sections: Vec<(Option<String>, String)> = vec![(None, String::new())];
    let mut in_fence = false;
    for line in markdown.lines() {
        if line.trim_start().starts_with("```") {
            in_fence = !in_fence;
        }
        if !in_fence && let Some(h) = heading(line) {
            sections.push((Some(h.to_string()), String::new()));
        }
        let body = &mut sections.last_mut().expect("never empty").1;
        body.push_str(line);
        body.push('\n');
    }
    let mut placed = vec![false; pictures.len()];
    let mut body = String::new();
    for (h, md) in &sections {
        body.push_str(&markdown_to_html(md));
        if let Some(h) = h {
            for (k, p) in pictures.iter().enumerate() {
                if !placed[k] && p.after_heading.as_deref().is_some_and(|a| h.starts_with(a)) {
                    placed[k] = true;
                    body.push_str(&picture_html(p));
                }
            }
        }
    }
    if placed.iter().any(|p| !p) {
        body.push_str("<h2>Figures</h2>\n");
        for (k, p) in pictures.iter().enumerate() {
            if !placed[k] {
                body.push_str(&picture_html(p));
            }
        }
    }
    let mut o = String::new();
    let _ = write!(
        o,
        "<!DOCTYPE html>\n<html lang=\"en\">\n<head>\n<meta charset=\"utf-8\">\n\
         <meta name=\"viewport\" content=\"width=device-width, initial-scale=1\">\n\
         <title>{}</title>\n<style>\n{CSS}</style>\n</head>\n<body>\n<main>\n{body}</main>\n\
         <footer>Written by kincal. Self-contained: no script, no network; the SVG plots are \
         also written beside this file.</footer>\n</body>\n</html>\n",
        escape(title)
    );
    o
}

#[cfg(test)]
mod tests {
    use super::*;

    fn pic(after: Option<&str>, caption: &str) -> Picture {
        Picture {
            after_heading: after.map(String::from),
            caption: caption.into(),
            file: "x.svg".into(),
            svg: "<svg width=\"10\" height=\"10\" xmlns=\"http://www.w3.org/2000/svg\"></svg>"
                .into(),
        }
    }

    #[test]
    fn tables_render_and_pictures_go_under_their_heading() {
        let md = "# Title\n\nIntro.\n\n## Table 4: errors\n\n| a | b |\n|---|---:|\n| x \\| y | 1.0 |\n\n## Recovery\n\nText.\n";
        let html = page(
            "T <1>",
            md,
            &[
                pic(Some("Recovery"), "R"),
                pic(Some("Table 4"), "E"),
                pic(None, "Z"),
            ],
        );
        assert!(html.starts_with("<!DOCTYPE html>"));
        assert!(html.contains("<title>T &lt;1&gt;</title>"));
        assert!(html.contains("<table>"));
        assert!(html.contains("<td>x | y</td>"), "{html}");
        assert!(html.contains("text-align: right"));
        let (e, r, z) = (
            html.find("aria-label=\"E\"").unwrap(),
            html.find("aria-label=\"R\"").unwrap(),
            html.find("aria-label=\"Z\"").unwrap(),
        );
        let (t4, rec, figs) = (
            html.find("<h2>Table 4").unwrap(),
            html.find("<h2>Recovery").unwrap(),
            html.find("<h2>Figures").unwrap(),
        );
        assert!(t4 < e && e < rec && rec < r && r < figs && figs < z);
        assert!(!html.contains("<script"));
        assert!(!html.contains("http://") || html.matches("http://").count() == 3);
        assert!(!html.contains("https://"));
    }

    #[test]
    fn headings_inside_code_fences_do_not_split() {
        let md = "## A\n\n```\n# not a heading\n```\n";
        let html = page("t", md, &[pic(Some("not"), "P")]);
        assert!(html.contains("# not a heading"));
        // The picture found no heading and went to the end.
        assert!(html.contains("<h2>Figures</h2>"));
    }

    #[test]
    fn escapes() {
        assert_eq!(escape("a<b & \"c\">"), "a&lt;b &amp; &quot;c&quot;&gt;");
    }
}
