//! Self-contained HTML reports: headings, text, key–value tables and figures (SVG inlined), so a
//! design or simulation result can be read in a browser without any other file.

use std::fmt::Write as _;
use std::path::Path;

use crate::error::{PlotError, Result};
use crate::figure::Figure;

/// One block of a report section.
#[derive(Debug, Clone, PartialEq)]
pub enum Block {
    /// A paragraph of plain text (escaped).
    Text(String),
    /// A table: header cells, then rows of cells (escaped).
    Table {
        /// Column headings.
        header: Vec<String>,
        /// Rows of cells, each as long as the header.
        rows: Vec<Vec<String>>,
    },
    /// SVG text drawn elsewhere (a file a workflow already wrote), inlined as it is, with a caption.
    Svg {
        /// The `<svg>` document.
        svg: String,
        /// Text under the plot.
        caption: String,
    },
    /// Preformatted text (a console account), escaped.
    Pre(String),
    /// A figure rendered to SVG and inlined, with a caption.
    Figure {
        /// The plot.
        figure: Box<Figure>,
        /// Text under the plot.
        caption: String,
    },
    /// A figure as an interactive canvas (zoom, pan, hover values) drawn by an inline script from
    /// the figure's data as JSON, no network needed; its static SVG is inlined too and hidden once
    /// the canvas is drawn, so a page read without scripts still shows it (and no page shows it twice).
    Interactive {
        /// The plot.
        figure: Box<Figure>,
        /// Text under the plot.
        caption: String,
    },
}

/// A titled section of a report.
#[derive(Debug, Clone, PartialEq)]
pub struct Section {
    /// Section heading.
    pub heading: String,
    /// Content in order.
    pub blocks: Vec<Block>,
}

/// A whole report.
#[derive(Debug, Clone, PartialEq, Default)]
pub struct Report {
    /// Document title.
    pub title: String,
    /// Sections in order.
    pub sections: Vec<Section>,
}

impl Report {
    /// An empty report with a title.
    pub fn new(title: impl Into<String>) -> Self {
        Report {
            title: title.into(),
            sections: Vec::new(),
        }
    }

    /// Appends a section and returns it for filling.
    pub fn section(&mut self, heading: impl Into<String>) -> &mut Section {
        self.sections.push(Section {
            heading: heading.into(),
            blocks: Vec::new(),
        });
        let last = self.sections.len() - 1;
        &mut self.sections[last]
    }

    /// Renders the report as one HTML document.
    pub fn to_html(&self) -> Result<String> {
        let mut h = String::new();
        let _ = write!(
            h,
            "<!DOCTYPE html>\n<html><head><meta charset=\"utf-8\"><title>{}</title>\n<style>{}</style></head><body>\n<h1>{}</h1>\n",
            esc(&self.title),
            STYLE,
            esc(&self.title)
        );
        let mut interactive = 0usize;
        for s in &self.sections {
            let _ = writeln!(h, "<h2>{}</h2>", esc(&s.heading));
            for b in &s.blocks {
                match b {
                    Block::Text(t) => {
                        let _ = writeln!(h, "<p>{}</p>", esc(t));
                    }
                    Block::Table { header, rows } => {
                        if rows.iter().any(|r| r.len() != header.len()) {
                            return Err(PlotError::Data(format!(
                                "table in section '{}' has rows of the wrong length",
                                s.heading
                            )));
                        }
                        h.push_str("<table><tr>");
                        for c in header {
                            let _ = write!(h, "<th>{}</th>", esc(c));
                        }
                        h.push_str("</tr>\n");
                        for r in rows {
                            h.push_str("<tr>");
                            for c in r {
                                let _ = write!(h, "<td>{}</td>", esc(c));
                            }
                            h.push_str("</tr>\n");
                        }
                        h.push_str("</table>\n");
                    }
                    Block::Figure { figure, caption } => {
                        let svg = figure.to_svg_string()?;
                        let _ = writeln!(h, "<figure>{svg}<figcaption>{}</figcaption></figure>", esc(caption));
                    }
                    Block::Interactive { figure, caption } => {
                        let svg = figure.to_svg_string()?;
                        let json = figure.to_json()?;
                        interactive += 1;
                        let id = format!("skl-fig-{interactive}");
                        let _ = writeln!(
                            h,
                            "<figure><div class=\"skl-static\">{svg}</div><details open><summary>interactive: wheel zooms (shift: x only, alt: y only), drag pans, double-click resets, hover shows values</summary><div class=\"skl-int\" data-src=\"{id}\"></div></details><script type=\"application/json\" id=\"{id}\">{json}</script><figcaption>{}</figcaption></figure>",
                            esc(caption)
                        );
                    }
                    Block::Svg { svg, caption } => {
                        // An XML prolog is not allowed inside HTML.
                        let body = svg.find("<svg").map_or(svg.as_str(), |i| &svg[i..]);
                        let _ = writeln!(h, "<figure>{body}<figcaption>{}</figcaption></figure>", esc(caption));
                    }
                    Block::Pre(t) => {
                        let _ = writeln!(h, "<pre>{}</pre>", esc(t));
                    }
                }
            }
        }
        if interactive > 0 {
            // One copy of the script, after the data it reads.
            let _ = writeln!(h, "<script>{}</script>", crate::interactive::INTERACTIVE_JS);
        }
        h.push_str("</body></html>\n");
        Ok(h)
    }

    /// Writes the report to `path` (an `.html` file).
    pub fn save(&self, path: &Path) -> Result<()> {
        let html = self.to_html()?;
        std::fs::write(path, html).map_err(|e| PlotError::Draw {
            path: path.display().to_string(),
            message: e.to_string(),
        })
    }
}

impl Section {
    /// Appends a paragraph.
    pub fn text(&mut self, t: impl Into<String>) -> &mut Self {
        self.blocks.push(Block::Text(t.into()));
        self
    }

    /// Appends a two-column table of quantities and values.
    pub fn key_values(&mut self, rows: &[(&str, String)]) -> &mut Self {
        self.blocks.push(Block::Table {
            header: vec!["quantity".into(), "value".into()],
            rows: rows.iter().map(|(k, v)| vec![k.to_string(), v.clone()]).collect(),
        });
        self
    }

    /// Appends a table with the given header and rows.
    pub fn table(&mut self, header: &[&str], rows: Vec<Vec<String>>) -> &mut Self {
        self.blocks.push(Block::Table {
            header: header.iter().map(|h| h.to_string()).collect(),
            rows,
        });
        self
    }

    /// Appends a figure shown both as a static SVG and as an interactive canvas (zoom, pan, hover
    /// values; inline script and data, no network), with a caption.
    pub fn interactive_figure(&mut self, figure: Figure, caption: impl Into<String>) -> &mut Self {
        self.blocks.push(Block::Interactive {
            figure: Box::new(figure),
            caption: caption.into(),
        });
        self
    }

    /// Appends a figure with a caption.
    pub fn figure(&mut self, figure: Figure, caption: impl Into<String>) -> &mut Self {
        self.blocks.push(Block::Figure {
            figure: Box::new(figure),
            caption: caption.into(),
        });
        self
    }
}

const STYLE: &str = "body{font-family:sans-serif;max-width:1000px;margin:2em auto;color:#222}\
table{border-collapse:collapse;margin:1em 0}td,th{border:1px solid #bbb;padding:4px 10px;text-align:left}\
th{background:#f0f0f0}figure{margin:1em 0}figcaption{color:#555;font-size:90%}svg{max-width:100%;height:auto}pre{background:#f7f7f7;padding:8px;overflow-x:auto;font-size:85%}\
.ok{color:#1a7f37}.no{color:#b00020;font-weight:bold}";

/// Escapes text for HTML.
fn esc(s: &str) -> String {
    s.replace('&', "&amp;")
        .replace('<', "&lt;")
        .replace('>', "&gt;")
        .replace('"', "&quot;")
}
