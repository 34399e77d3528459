//! The docs cannot lie: every command block in README.md and `docs/*.md` marked runnable is run
//! against the built binary, and every figure the docs show is regenerated and compared with the
//! committed file.
//!
//! A runnable block is a fenced `sh` block whose preceding line is an HTML comment (invisible on
//! GitHub and in mdBook):
//!
//! ```text
//! <!-- run -->
//! <!-- run figure=bode.png:docs/img/engineer-bode.png -->
//! ```
//!
//! The blocks of one file run in order with `bash -eo pipefail` in one temporary directory (so a
//! later block may read what an earlier one wrote), with `examples/` and `testdata/` of the
//! repository linked into it and the built `skyloop` first on PATH. Each must exit 0, and every
//! file it names after `--out`, `--c` or `-o` must exist afterwards. `figure=A:B` compares the file
//! A the block wrote with the committed B byte for byte (skyloop's plots are drawn in pure Rust with
//! an embedded font, so they are reproducible); `SKYLOOP_BLESS=1` writes A over B instead, which is
//! how `tools/docs_figures.sh` regenerates the figures. A fenced block after a runnable one whose
//! preceding line is `<!-- output -->` quotes its output: each of its lines (but those starting
//! with `…`) must be a line the block printed today, so every number the docs quote is checked.
//!
//! The CLI reference `docs/reference/cli.md` is generated from clap's own definitions by
//! `skyloop --markdown-help` and checked here against the binary, so it cannot drift from `--help`.
#![allow(clippy::unwrap_used)] // a panic is how a test reports failure

mod common;

use std::path::{Path, PathBuf};
use std::process::Command;

/// The repository root (two levels above this crate).
fn root() -> PathBuf {
    Path::new(env!("CARGO_MANIFEST_DIR"))
        .join("../..")
        .canonicalize()
        .unwrap()
}

/// A runnable block: its commands, the figure comparisons, the output lines the docs quote from it
/// and the line it starts on.
struct Block {
    line: usize,
    script: String,
    figures: Vec<(String, String)>,
    quoted: Vec<String>,
}

/// The runnable `sh` blocks of a Markdown text, in order.
fn runnable_blocks(text: &str) -> Vec<Block> {
    let lines: Vec<&str> = text.lines().collect();
    let mut out = Vec::new();
    let mut i = 0;
    while i + 1 < lines.len() {
        let marker = lines[i].trim();
        let fence = lines[i + 1].trim();
        if marker == "<!-- output -->" && fence.starts_with("```") {
            let start = i + 2;
            let end = (start..lines.len())
                .find(|&j| lines[j].trim() == "```")
                .unwrap_or(lines.len());
            let last: &mut Block = out.last_mut().expect("an output block follows a runnable block");
            last.quoted.extend(
                lines[start..end]
                    .iter()
                    .map(|l| l.trim().to_string())
                    .filter(|l| !l.is_empty() && !l.starts_with('…') && !l.starts_with("...")),
            );
            i = end + 1;
            continue;
        }
        let is_marker = marker.starts_with("<!-- run") && marker.ends_with("-->");
        if !(is_marker && (fence == "```sh" || fence == "```bash")) {
            i += 1;
            continue;
        }
        let figures = marker
            .trim_start_matches("<!-- run")
            .trim_end_matches("-->")
            .split_whitespace()
            .filter_map(|w| w.strip_prefix("figure="))
            .map(|f| {
                let (a, b) = f.split_once(':').expect("figure=PRODUCED:COMMITTED");
                (a.to_string(), b.to_string())
            })
            .collect();
        let start = i + 2;
        let end = (start..lines.len())
            .find(|&j| lines[j].trim() == "```")
            .unwrap_or_else(|| panic!("unclosed block at line {}", start));
        out.push(Block {
            line: i + 1,
            script: lines[start..end].join("\n"),
            figures,
            quoted: Vec::new(),
        });
        i = end + 1;
    }
    out
}

/// The files a script names as outputs: the word after `--out`, `--c` or `-o`.
fn named_outputs(script: &str) -> Vec<String> {
    let mut out = Vec::new();
    for line in script.lines() {
        let code = line.split(" #").next().unwrap_or("");
        let words: Vec<&str> = code.split_whitespace().collect();
        for w in words.windows(2) {
            if matches!(w[0], "--out" | "--c" | "-o") {
                out.push(w[1].trim_matches(|c| c == '"' || c == '\'').to_string());
            }
        }
    }
    out
}

/// The fraction of pixels of two PNG images that differ visibly (by more than 48 of 255 in a
/// channel); 1 when either does not decode or their sizes differ. A tolerance, not byte equality:
/// the numerical kernels pick SIMD paths by CPU, so a last-digit difference may move an
/// antialiased edge by a pixel on another machine, while a stale figure differs in whole curves.
fn pixels_differ(a: &[u8], b: &[u8]) -> f64 {
    let decode = |bytes: &[u8]| -> Option<(u32, u32, Vec<u8>)> {
        let mut dec = png::Decoder::new(std::io::Cursor::new(bytes));
        dec.set_transformations(png::Transformations::EXPAND | png::Transformations::STRIP_16);
        let mut reader = dec.read_info().ok()?;
        let mut buf = vec![0; reader.output_buffer_size()];
        let info = reader.next_frame(&mut buf).ok()?;
        buf.truncate(info.buffer_size());
        let channels = info.color_type.samples();
        // Colour images compare R, G, B; grey ones their one value (alpha is ignored).
        let k = if channels >= 3 { 3 } else { 1 };
        let rgb = buf
            .chunks(channels)
            .flat_map(|p| [p[0], p[1.min(k - 1)], p[2.min(k - 1)]])
            .collect();
        Some((info.width, info.height, rgb))
    };
    match (decode(a), decode(b)) {
        (Some((wa, ha, pa)), Some((wb, hb, pb))) if (wa, ha) == (wb, hb) => {
            let n = pa.len() / 3;
            let bad = pa
                .chunks(3)
                .zip(pb.chunks(3))
                .filter(|(x, y)| x.iter().zip(y.iter()).any(|(u, v)| u.abs_diff(*v) > 48))
                .count();
            bad as f64 / n.max(1) as f64
        }
        _ => 1.0,
    }
}

/// Runs every runnable block of `doc` (relative to the repository root); returns how many ran.
fn run_doc(doc: &str) -> usize {
    let root = root();
    let text = std::fs::read_to_string(root.join(doc)).unwrap();
    let blocks = runnable_blocks(&text);
    if blocks.is_empty() {
        return 0;
    }
    let dir = std::env::temp_dir().join(format!("skyloop-docs-{}-{}", doc.replace('/', "_"), std::process::id()));
    let _ = std::fs::remove_dir_all(&dir);
    std::fs::create_dir_all(&dir).unwrap();
    for sub in ["examples", "testdata"] {
        std::os::unix::fs::symlink(root.join(sub), dir.join(sub)).unwrap();
    }
    let bin_dir = Path::new(env!("CARGO_BIN_EXE_skyloop")).parent().unwrap().to_path_buf();
    let path = format!("{}:{}", bin_dir.display(), std::env::var("PATH").unwrap_or_default());
    let bless = std::env::var("SKYLOOP_BLESS").is_ok_and(|v| v == "1");
    for b in &blocks {
        let out = Command::new("bash")
            .args(["-eo", "pipefail", "-c", &b.script])
            .current_dir(&dir)
            .env("PATH", &path)
            .output()
            .unwrap();
        assert!(
            out.status.success(),
            "{doc}:{}: the block failed ({:?})\n{}\nstdout:\n{}\nstderr:\n{}",
            b.line,
            out.status.code(),
            b.script,
            String::from_utf8_lossy(&out.stdout),
            String::from_utf8_lossy(&out.stderr)
        );
        let printed = format!(
            "{}{}",
            String::from_utf8_lossy(&out.stdout),
            String::from_utf8_lossy(&out.stderr)
        );
        for q in &b.quoted {
            assert!(
                printed.lines().any(|l| l.trim() == q),
                "{doc}:{}: the docs quote a line the command no longer prints:\n{q}\nit printed:\n{printed}",
                b.line
            );
        }
        for f in named_outputs(&b.script) {
            assert!(
                dir.join(&f).exists(),
                "{doc}:{}: the block names {f}, which it did not write",
                b.line
            );
        }
        for (produced, committed) in &b.figures {
            let new = std::fs::read(dir.join(produced)).unwrap_or_else(|e| panic!("{doc}:{}: {produced}: {e}", b.line));
            let path = root.join(committed);
            if bless {
                std::fs::create_dir_all(path.parent().unwrap()).unwrap();
                std::fs::write(&path, &new).unwrap();
                continue;
            }
            let old = std::fs::read(&path).unwrap_or_default();
            let differ = pixels_differ(&old, &new);
            assert!(
                differ < 0.005,
                "{doc}:{}: {committed} is not what the block draws today ({:.1} % of its pixels differ): run tools/docs_figures.sh",
                b.line,
                100.0 * differ
            );
        }
    }
    let _ = std::fs::remove_dir_all(&dir);
    blocks.len()
}

#[test]
fn the_parser_finds_marked_blocks_only() {
    let md = "text\n```sh\nnot run\n```\n<!-- run figure=a.png:docs/img/a.png -->\n```sh\nskyloop x --out a.png   # note --out b\n```\n<!-- output -->\n```text\nline one\n… cut\n\n```\n";
    let blocks = runnable_blocks(md);
    assert_eq!(blocks.len(), 1);
    assert_eq!(blocks[0].line, 5);
    assert_eq!(
        blocks[0].figures,
        vec![("a.png".to_string(), "docs/img/a.png".to_string())]
    );
    assert_eq!(named_outputs(&blocks[0].script), vec!["a.png".to_string()]);
    assert_eq!(blocks[0].quoted, vec!["line one".to_string()]);
}

#[test]
fn readme_commands_run() {
    assert!(
        run_doc("README.md") >= 2,
        "the README's start-here paths are runnable blocks"
    );
}

#[test]
fn guide_commands_run() {
    let root = root();
    let mut ran = 0;
    for e in std::fs::read_dir(root.join("docs")).unwrap() {
        let p = e.unwrap().path();
        if p.extension().is_some_and(|x| x == "md") {
            ran += run_doc(p.strip_prefix(&root).unwrap().to_str().unwrap());
        }
    }
    assert!(ran >= 4, "the guides hold runnable blocks ({ran} ran)");
}

#[test]
fn cli_reference_is_generated_from_the_definitions() {
    let (code, out, err) = common::skyloop(&["--markdown-help"]);
    assert_eq!(code, 0, "{err}");
    assert!(out.contains("## `skyloop tune`"), "every subcommand has a section");
    let path = root().join("docs/reference/cli.md");
    if std::env::var("SKYLOOP_BLESS").is_ok_and(|v| v == "1") {
        std::fs::create_dir_all(path.parent().unwrap()).unwrap();
        std::fs::write(&path, &out).unwrap();
    }
    let committed = std::fs::read_to_string(&path).unwrap_or_default();
    assert!(
        committed == out,
        "docs/reference/cli.md is stale: run tools/docs_figures.sh"
    );
}
