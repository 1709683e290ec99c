//! The self-contained HTML report: figures inlined as SVG (so the file opens from disk
//! with no server or network), PNG copies linked beside it.

/// A piece of a section.
#[derive(Debug, Clone)]
pub enum Block {
    Paragraph(String),
    /// Inline SVG markup, a caption, and the PNG file name (relative to the report).
    Figure {
        id: String,
        caption: String,
        svg: String,
        png: String,
    },
    Table {
        header: Vec<String>,
        rows: Vec<Vec<String>>,
    },
    /// Preformatted text (parameters, JSON).
    Pre(String),
}

#[derive(Debug, Clone)]
pub struct Section {
    pub id: String,
    pub title: String,
    pub blocks: Vec<Block>,
}

#[derive(Debug, Clone)]
pub struct Report {
    pub title: String,
    pub subtitle: String,
    pub sections: Vec<Section>,
}

pub fn escape(s: &str) -> String {
    s.replace('&', "&amp;")
        .replace('<', "&lt;")
        .replace('>', "&gt;")
        .replace('"', "&quot;")
}

/// Strip an XML declaration so the SVG can sit inside HTML.
fn inline_svg(svg: &str) -> &str {
    match svg.find("<svg") {
        Some(i) => &svg[i..],
        None => svg,
    }
}

pub fn render(r: &Report) -> String {
    let mut h = String::new();
    h += "<!DOCTYPE html>\n<html lang=\"en\"><head><meta charset=\"utf-8\">\n";
    h += &format!("<title>{}</title>\n", escape(&r.title));
    h += "<style>body{font-family:sans-serif;max-width:1200px;margin:2em auto;padding:0 1em;color:#222}\
          table{border-collapse:collapse;margin:1em 0}td,th{border:1px solid #bbb;padding:4px 8px;text-align:left}\
          th{background:#eee}figure{margin:1.5em 0}figcaption{font-size:90%;color:#444}\
          pre{background:#f6f6f6;padding:8px;overflow-x:auto;font-size:85%}nav a{margin-right:1em}</style>\n";
    h += "</head><body>\n";
    h += &format!(
        "<h1>{}</h1>\n<p>{}</p>\n<nav>",
        escape(&r.title),
        escape(&r.subtitle)
    );
    for s in &r.sections {
        h += &format!("<a href=\"#{}\">{}</a>", escape(&s.id), escape(&s.title));
    }
    h += "</nav>\n";
    for s in &r.sections {
        h += &format!(
            "<section id=\"{}\"><h2>{}</h2>\n",
            escape(&s.id),
            escape(&s.title)
        );
        for b in &s.blocks {
            match b {
                Block::Paragraph(t) => h += &format!("<p>{}</p>\n", escape(t)),
                Block::Pre(t) => h += &format!("<pre>{}</pre>\n", escape(t)),
                Block::Figure {
                    id,
                    caption,
                    svg,
                    png,
                } => {
                    h += &format!(
                        "<figure id=\"{}\" class=\"figure\">{}<figcaption>{} (<a href=\"{}\">PNG</a>)</figcaption></figure>\n",
                        escape(id),
                        inline_svg(svg),
                        escape(caption),
                        escape(png)
                    );
                }
                Block::Table { header, rows } => {
                    h += "<table><tr>";
                    for c in header {
                        h += &format!("<th>{}</th>", escape(c));
                    }
                    h += "</tr>\n";
                    for row in rows {
                        h += "<tr>";
                        for c in row {
                            h += &format!("<td>{}</td>", escape(c));
                        }
                        h += "</tr>\n";
                    }
                    h += "</table>\n";
                }
            }
        }
        h += "</section>\n";
    }
    h += "</body></html>\n";
    h
}
