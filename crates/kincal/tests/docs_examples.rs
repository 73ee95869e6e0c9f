//! Examples that cannot drift: every ```console block of README.md and docs/*.md whose
//! first line is `$ kincal …` is run, and its output must be the block's text.
//!
//! A block is one command (a line starting with `$ `, continued by lines ending in `\`)
//! followed by what it prints (stdout, then stderr). The blocks of one file run in order in
//! one scratch directory holding links to the repository's `scenarios/`, `data/` and
//! `results/`, so a block can use files an earlier block wrote (`--out ur10-cal`, then
//! `--robot ur10-cal/identified.json`) and the repository stays untouched. Wall-clock
//! figures (`12.3 ms`, `0.25 s`) are compared as `<time>`; everything else to the
//! character, trailing spaces aside, but for elisions in the doc's text: a line that is only
//! `…` stands for any number of lines, and a `…` ending a line for the rest of that line
//! (`flagged: …`), so a long listing can be shown in part.
//!
//! `KINCAL_BLESS_DOCS=1 cargo test -p kincal --test integration docs_examples` rewrites the blocks with
//! what the commands print now (after a change that moves them on purpose).

use std::path::{Path, PathBuf};
use std::process::Command;

use crate::common::root;
use regex::Regex;

/// One example: the file and line it starts at, the command's arguments, the expected text.
struct Example {
    file: String,
    line: usize,
    /// 0-based line range of the expected output in the file.
    output_lines: std::ops::Range<usize>,
    args: Vec<String>,
    expected: String,
}

/// The ```console blocks of `text` that run `kincal`.
fn examples(file: &str, text: &str) -> Vec<Example> {
    let mut out = Vec::new();
    let mut lines = text.lines().enumerate();
    while let Some((i, l)) = lines.next() {
        if l.trim() != "```console" {
            continue;
        }
        let block: Vec<&str> = lines
            .by_ref()
            .map(|(_, l)| l)
            .take_while(|l| l.trim() != "```")
            .collect();
        let Some(first) = block.first() else { continue };
        if !first.starts_with("$ kincal ") {
            continue;
        }
        let mut cmd = String::new();
        let mut rest = 0;
        for (k, l) in block.iter().enumerate() {
            let l = if k == 0 { &l[2..] } else { l.trim() };
            match l.strip_suffix('\\') {
                Some(head) => cmd.push_str(head),
                None => {
                    cmd.push_str(l);
                    rest = k + 1;
                    break;
                }
            }
        }
        let args = cmd.split_whitespace().skip(1).map(str::to_string).collect();
        out.push(Example {
            file: file.to_string(),
            line: i + 1,
            output_lines: i + 1 + rest..i + 1 + block.len(),
            args,
            expected: block[rest..].join("\n"),
        });
    }
    out
}

/// Wall-clock figures as `<time>`, trailing spaces and blank edges dropped.
fn normalise(text: &str) -> String {
    let time = Regex::new(r"\b\d+(\.\d+)? (ms|s)\b").unwrap();
    let text = time.replace_all(text, "<time>");
    text.lines()
        .map(str::trim_end)
        .collect::<Vec<_>>()
        .join("\n")
        .trim()
        .to_string()
}

/// Whether `got` is what the doc's `expected` shows (both normalised): equal, or equal but
/// for the elisions (a line `…`: any lines; a line ending in `…`: any rest of that line).
fn shows(expected: &str, got: &str) -> bool {
    if !expected.contains('…') {
        return expected == got;
    }
    let mut pattern = String::from("^");
    for (k, line) in expected.lines().enumerate() {
        if line == "…" {
            pattern.push_str(r"(?:[^\n]*\n)*?");
            continue;
        }
        match line.strip_suffix('…') {
            Some(head) => {
                pattern.push_str(&regex::escape(head));
                pattern.push_str(r"[^\n]*");
            }
            None => pattern.push_str(&regex::escape(line)),
        }
        let last = k + 1 == expected.lines().count();
        if !last {
            pattern.push_str(r"\n");
        }
    }
    pattern.push('$');
    Regex::new(&pattern).is_ok_and(|re| re.is_match(got))
}

fn doc_files(root: &Path) -> Vec<PathBuf> {
    let mut files = vec![root.join("README.md")];
    if let Ok(dir) = std::fs::read_dir(root.join("docs")) {
        let mut docs: Vec<PathBuf> = dir
            .filter_map(|e| e.ok().map(|e| e.path()))
            .filter(|p| p.extension().is_some_and(|e| e == "md"))
            .collect();
        docs.sort();
        files.extend(docs);
    }
    files
}

#[test]
fn the_parser_finds_commands_continuations_and_output() {
    let text = "x\n```console\n$ kincal predict --robot r.json \\\n    --joints j.csv\n\
                12 rows\n```\n```console\n$ ls\n```\n";
    let ex = examples("t.md", text);
    assert_eq!(ex.len(), 1);
    assert_eq!(ex[0].line, 2);
    assert_eq!(
        ex[0].args,
        ["predict", "--robot", "r.json", "--joints", "j.csv"]
    );
    assert_eq!(ex[0].expected, "12 rows");
    assert_eq!(
        normalise("fit: 5 iterations; 12.3 ms  \nin 0.25 s → x\n"),
        "fit: 5 iterations; <time>\nin <time> → x"
    );
}

#[test]
fn elisions_stand_for_lines_and_line_ends_only() {
    let got = "a 1\nflagged: x\nflagged: y\nflagged: z\ndone";
    assert!(shows("a 1\nflagged: …\n…\ndone", got));
    assert!(shows("a …\n…\ndone", got));
    assert!(shows(got, got));
    assert!(!shows("a 1\n…\nnot done", got));
    assert!(!shows("a 2…\n…\ndone", got));
    assert!(!shows("a 1\nflagged: …\ndone", got));
    assert!(!shows("a 1", got));
}

#[test]
fn console_examples_in_the_docs_print_what_they_show() {
    let root = root();
    let mut failures = Vec::new();
    let mut ran = 0;
    for path in doc_files(&root) {
        let text = std::fs::read_to_string(&path).unwrap();
        let name = path.strip_prefix(&root).unwrap().display().to_string();
        let list = examples(&name, &text);
        if list.is_empty() {
            continue;
        }
        let mut lines: Vec<String> = text.lines().map(str::to_string).collect();
        let mut blessed = Vec::new();
        let scratch = tempfile::tempdir().unwrap();
        for dir in ["scenarios", "data", "results"] {
            std::os::unix::fs::symlink(root.join(dir), scratch.path().join(dir)).unwrap();
        }
        for ex in list {
            let out = Command::new(env!("CARGO_BIN_EXE_kincal"))
                .args(&ex.args)
                .current_dir(scratch.path())
                .env("CI", "1")
                .env("RUST_BACKTRACE", "0")
                .output()
                .unwrap();
            ran += 1;
            let got = format!(
                "{}{}",
                String::from_utf8_lossy(&out.stdout),
                String::from_utf8_lossy(&out.stderr)
            );
            if !shows(&normalise(&ex.expected), &normalise(&got)) {
                blessed.push((ex.output_lines.clone(), got.trim_end().to_string()));
                failures.push(format!(
                    "{}:{}: `kincal {}` printed\n{}\n--- but the doc shows ---\n{}",
                    ex.file,
                    ex.line,
                    ex.args.join(" "),
                    got.trim_end(),
                    ex.expected
                ));
            }
        }
        if std::env::var_os("KINCAL_BLESS_DOCS").is_some() && !blessed.is_empty() {
            for (range, got) in blessed.into_iter().rev() {
                lines.splice(range, got.lines().map(str::to_string));
            }
            std::fs::write(&path, lines.join("\n") + "\n").unwrap();
            failures.push(format!("{name}: blessed"));
        }
    }
    assert!(
        ran > 0,
        "no ```console example runs kincal in README.md or docs/"
    );
    assert!(
        failures.is_empty(),
        "{} example(s) drifted from what the commands print (update the docs):\n\n{}",
        failures.len(),
        failures.join("\n\n")
    );
}

/// The first column after the metric of a row of a summary.md table: `1.168 ± 0.166 […]` →
/// `1.168`, and the paper's column.
fn summary_row(summary: &str, metric: &str) -> (String, String) {
    let row = summary
        .lines()
        .find(|l| l.starts_with(&format!("| {metric} |")))
        .unwrap_or_else(|| panic!("summary.md has no row `{metric}`"));
    let cells: Vec<&str> = row.split('|').map(str::trim).collect();
    let ours = cells[2].split_whitespace().next().unwrap().to_string();
    (ours, cells[3].to_string())
}

/// The README's paper table, as the committed `results/paper-kr1000/summary.md` gives it.
fn paper_table(summary: &str) -> String {
    let r = |m| summary_row(summary, m);
    let (mb, pmb) = r("mean 3-D before (mm)");
    let (ma, pma) = r("mean 3-D after (mm)");
    let (xb, pxb) = r("max 3-D before (mm)");
    let (xa, pxa) = r("max 3-D after (mm)");
    let (imp, pimp) = r("improvement of mean (%)");
    format!(
        "| mean before → after (mm) | {mb} → {ma} | {pmb} → {pma} |\n\
         | max before → after (mm) | {xb} → {xa} | {pxb} → {pxa} |\n\
         | improvement of the mean (%) | {imp} | {pimp} |"
    )
}

#[test]
fn the_readme_paper_table_is_the_committed_result() {
    let root = root();
    let summary = std::fs::read_to_string(root.join("results/paper-kr1000/summary.md")).unwrap();
    let readme = std::fs::read_to_string(root.join("README.md")).unwrap();
    let table = paper_table(&summary);
    assert!(
        readme.contains(&table),
        "README.md's paper table differs from results/paper-kr1000/summary.md; it should \
         read:\n{table}"
    );
}

/// The figures the docs quote from the paper scenario's residual budget are the committed
/// `results/paper-kr1000/summary.md`'s: every decimal number of each quoting passage must
/// appear in the summary's budget section.
#[test]
fn the_residual_budget_quoted_in_the_docs_is_the_committed_result() {
    let root = root();
    let summary = std::fs::read_to_string(root.join("results/paper-kr1000/summary.md")).unwrap();
    let section = summary
        .split("## Residual budget")
        .nth(1)
        .and_then(|s| s.split("\n## ").next())
        .expect("results/paper-kr1000/summary.md has a residual budget");
    let numbers = Regex::new(r"\d+\.\d+(e-\d+)?").unwrap();
    // (file, passage start, passage end, lines kept, numbers expected at least)
    let passages: [(&str, &str, &str, bool, usize); 3] = [
        (
            "scenarios/README.md",
            "Its residual budget",
            "issue 19",
            false,
            8,
        ),
        (
            "docs/extended-model.md",
            "## What the paper scenario's residual is made of",
            "\n## ",
            true,
            10,
        ),
        ("README.md", "What the ", "docs/extended-model.md", false, 2),
    ];
    for (file, from, to, table_only, at_least) in passages {
        let text = std::fs::read_to_string(root.join(file)).unwrap();
        let start = text
            .find(from)
            .unwrap_or_else(|| panic!("{file} has no passage `{from}`"));
        let rest = &text[start + from.len()..];
        let passage = &rest[..rest.find(to).unwrap_or(rest.len())];
        let mut n = 0;
        for line in passage
            .lines()
            .filter(|l| !table_only || l.starts_with("| "))
        {
            for m in numbers.find_iter(line) {
                n += 1;
                assert!(
                    section.contains(m.as_str()),
                    "{file} quotes {} in `{line}`, which the residual budget of \
                     results/paper-kr1000/summary.md does not have:\n{section}",
                    m.as_str()
                );
            }
        }
        assert!(n >= at_least, "{file}: {n} numbers in\n{passage}");
    }
}

/// The geometric-vs-extended table of `docs/extended-model.md` and the figures
/// `scenarios/README.md` quotes for `paper-kr1000-extended` are the committed summaries'.
#[test]
fn the_extended_model_figures_in_the_docs_are_the_committed_results() {
    let root = root();
    let read = |f: &str| std::fs::read_to_string(root.join(f)).unwrap();
    let geo = read("results/paper-kr1000/summary.md");
    let ext = read("results/paper-kr1000-extended/summary.md");
    let doc = read("docs/extended-model.md");
    let mean = |s: &str| summary_row(s, "mean 3-D after (mm)").0;
    let max = |s: &str| summary_row(s, "max 3-D after (mm)").0;
    for row in [
        format!("| mean after | {} | {} |", mean(&geo), mean(&ext)),
        format!("| max after | {} | {} |", max(&geo), max(&ext)),
    ] {
        assert!(
            doc.contains(&row),
            "docs/extended-model.md should have the row\n{row}"
        );
    }
    let scen = read("scenarios/README.md");
    for quoted in [
        format!(
            "from the geometric model's {} mm to\n  {} mm",
            mean(&geo),
            mean(&ext)
        ),
        format!("(max {} → {} mm)", max(&geo), max(&ext)),
    ] {
        assert!(
            scen.contains(&quoted),
            "scenarios/README.md should say {quoted:?}"
        );
    }
    // The recovery table: each row's last four cells are the committed summary's, and the
    // quoted z sd range spans the committed rows.
    let recovery = doc
        .split("### Recovery: honest standard errors")
        .nth(1)
        .expect("docs/extended-model.md has the recovery table");
    let mut rows = 0;
    for line in recovery.lines().take_while(|l| !l.starts_with("## ")) {
        let cells: Vec<&str> = line.split('|').map(str::trim).collect();
        let Some(name) = cells.get(1).and_then(|c| c.strip_prefix('`')) else {
            continue;
        };
        let name = name.split('`').next().unwrap();
        let committed = ext
            .lines()
            .find(|l| l.starts_with(&format!("| {name} |")))
            .unwrap_or_else(|| panic!("{name} is not in the committed recovery table"));
        let c: Vec<&str> = committed.split('|').map(str::trim).collect();
        // The doc prints a typographic minus.
        let doc_cells: Vec<String> = cells[3..7].iter().map(|v| v.replace('−', "-")).collect();
        assert_eq!(
            doc_cells,
            &c[4..8],
            "{name}: the doc row differs from {committed}"
        );
        rows += 1;
    }
    assert!(rows >= 5, "{rows} recovery rows checked");
    let z_sd: Vec<f64> = ext
        .split("## Parameter recovery")
        .nth(1)
        .unwrap()
        .lines()
        .filter_map(|l| {
            let c: Vec<&str> = l.split('|').map(str::trim).collect();
            (c.len() == 9).then(|| c[7].parse::<f64>().ok()).flatten()
        })
        .collect();
    assert_eq!(z_sd.len(), 43);
    let (lo, hi) = z_sd
        .iter()
        .fold((f64::MAX, f64::MIN), |(a, b), &z| (a.min(z), b.max(z)));
    let range = format!("{lo:.2}–{hi:.2}");
    for (file, text) in [
        ("docs/extended-model.md", &doc),
        ("scenarios/README.md", &scen),
    ] {
        assert!(
            text.contains(&range),
            "{file} should quote the z sd range {range}"
        );
    }
}

/// The sweep table of `docs/extended-model.md` is the committed `sweep.md`s': each row's
/// three model columns are the "after (mm)" cells of that sweep at that scale.
#[test]
fn the_extended_model_sweep_table_is_the_committed_result() {
    let root = root();
    let doc = std::fs::read_to_string(root.join("docs/extended-model.md")).unwrap();
    let table = doc
        .split("## How much a richer model removes")
        .nth(1)
        .expect("docs/extended-model.md has the sweep table");
    let models = ["[]", "[\"compliance\"]", "[\"compliance\",\"gears\"]"];
    let mut rows = 0;
    for line in table.lines().take_while(|l| !l.starts_with("## ")) {
        let cells: Vec<&str> = line.split('|').map(str::trim).collect();
        if cells.len() != 7 {
            continue;
        }
        let sweep = match cells[1] {
            "compliance" => "compliance",
            c if c.starts_with("gear errors") => "gears",
            c if c.contains("mismatch") => "mismatch",
            _ => continue,
        };
        let md =
            std::fs::read_to_string(root.join(format!("results/sweep-extended-{sweep}/sweep.md")))
                .unwrap();
        for (model, doc_value) in models.iter().zip(&cells[3..6]) {
            let row = md
                .lines()
                .find(|l| l.starts_with(&format!("| {model} | {} |", cells[2])))
                .unwrap_or_else(|| {
                    panic!("sweep-extended-{sweep}: no row {model} at {}", cells[2])
                });
            let after = row.split('|').map(str::trim).nth(6).unwrap();
            assert_eq!(
                after, *doc_value,
                "docs/extended-model.md: {sweep} {model} at {}× says {doc_value}, sweep.md {after}",
                cells[2]
            );
        }
        rows += 1;
    }
    assert_eq!(rows, 7);
}

/// The Markdown files of the repository's own docs (README, ARCHITECTURE, docs/, scenarios/,
/// results/, data/), not those of build output.
fn markdown_files(root: &Path) -> Vec<PathBuf> {
    let mut out = Vec::new();
    let mut stack = vec![root.to_path_buf()];
    while let Some(dir) = stack.pop() {
        for e in std::fs::read_dir(&dir).unwrap().flatten() {
            let p = e.path();
            let name = e.file_name().to_string_lossy().to_string();
            if p.is_dir() {
                if !name.starts_with('.') && name != "target" && !name.starts_with("target-") {
                    stack.push(p);
                }
            } else if name.ends_with(".md") {
                out.push(p);
            }
        }
    }
    out.sort();
    out
}

#[test]
fn doc_links_and_model_sections_resolve_inside_the_repository() {
    let root = root();
    let model = std::fs::read_to_string(root.join("docs/model.md")).unwrap();
    let sections = model.lines().filter(|l| l.starts_with("## ")).count();
    let link = Regex::new(r"\]\(([^)#\s]+)(#[^)]*)?\)").unwrap();
    let section = Regex::new(r"docs/model\.md` ?§(\d+)|docs/model\.md ?§(\d+)").unwrap();
    let mut bad = Vec::new();
    let mut files = markdown_files(&root);
    files.retain(|p| !p.starts_with(root.join("crates")) || p.ends_with("README.md"));
    for path in files {
        let text = std::fs::read_to_string(&path).unwrap();
        let name = path.strip_prefix(&root).unwrap().display().to_string();
        for (i, line) in text.lines().enumerate() {
            for c in link.captures_iter(line) {
                let target = &c[1];
                if target.contains("://") || target.starts_with("mailto:") {
                    continue;
                }
                let resolved = path.parent().unwrap().join(target);
                let inside = resolved
                    .canonicalize()
                    .map(|p| p.starts_with(&root))
                    .unwrap_or(false);
                if !inside {
                    bad.push(format!(
                        "{name}:{}: link to {target} does not resolve inside the repository",
                        i + 1
                    ));
                }
            }
            for c in section.captures_iter(line) {
                let n: usize = c.get(1).or(c.get(2)).unwrap().as_str().parse().unwrap();
                if n == 0 || n > sections {
                    bad.push(format!("{name}:{}: docs/model.md has no §{n}", i + 1));
                }
            }
        }
    }
    assert!(bad.is_empty(), "{}", bad.join("\n"));
}
