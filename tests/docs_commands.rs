//! The docs cannot drift from the program (issue 55): every `pvrsim ...`
//! command line written in README.md and docs/**/*.md, in a code block or
//! an inline code span, parses with the current options (clap's
//! `try_parse_from` on the command-line type; nothing runs). A second test
//! runs the README's quick commands on the built-in data.

mod cli_support;

use std::path::{Path, PathBuf};

use clap::Parser;
use cli_support::*;

/// Splits a command line into words as a POSIX shell would for the
/// simple lines the docs hold: white space separates, single and double
/// quotes group, a backslash escapes the next character. `None` when a
/// quote is not closed.
fn shell_words(line: &str) -> Option<Vec<String>> {
    let mut words = Vec::new();
    let mut cur = String::new();
    let mut in_word = false;
    let mut chars = line.chars();
    while let Some(c) = chars.next() {
        match c {
            '\'' => {
                in_word = true;
                loop {
                    match chars.next()? {
                        '\'' => break,
                        c => cur.push(c),
                    }
                }
            }
            '"' => {
                in_word = true;
                loop {
                    match chars.next()? {
                        '"' => break,
                        '\\' => cur.push(chars.next()?),
                        c => cur.push(c),
                    }
                }
            }
            '\\' => {
                in_word = true;
                if let Some(n) = chars.next() {
                    cur.push(n);
                }
            }
            c if c.is_whitespace() => {
                if in_word {
                    words.push(std::mem::take(&mut cur));
                    in_word = false;
                }
            }
            c => {
                in_word = true;
                cur.push(c);
            }
        }
    }
    if in_word {
        words.push(cur);
    }
    Some(words)
}

/// The words of one shell command that starts with `pvrsim` (after an
/// optional `$ `, `sudo `, `time ` or environment assignments), cut at a
/// comment, a pipe, a redirection or a `;`/`&&`.
fn pvrsim_words(line: &str) -> Option<Vec<String>> {
    let line = line.trim().trim_start_matches("$ ");
    let line = match line.find(" #") {
        Some(i) => &line[..i],
        None => line,
    };
    let words = shell_words(line)?;
    let mut it = words.into_iter().peekable();
    while let Some(w) = it.peek() {
        if w == "sudo" || w == "time" || (w.contains('=') && !w.starts_with('-')) {
            it.next();
        } else {
            break;
        }
    }
    let first = it.next()?;
    let exe = first.rsplit('/').next().unwrap_or(&first);
    if exe != "pvrsim" {
        return None;
    }
    let mut out = vec!["pvrsim".to_string()];
    for w in it {
        if matches!(
            w.as_str(),
            "|" | ";" | "&&" | "||" | ">" | "2>" | ">>" | "&"
        ) || w.starts_with('>')
            || w.starts_with("2>")
        {
            break;
        }
        out.push(w);
    }
    Some(out)
}

/// Whether an inline span is a placeholder synopsis rather than a command
/// (`pvrsim scene MESH --field F [--view +x|-x]`, `pvrsim ... | head`).
fn is_synopsis(span: &str) -> bool {
    span.contains('[') || span.contains('|') || span.contains("...") || span.contains('…')
}

/// The markdown files: README.md and every .md under docs/.
fn doc_files() -> Vec<PathBuf> {
    let root = Path::new(env!("CARGO_MANIFEST_DIR"));
    let mut files = vec![root.join("README.md")];
    let mut dirs = vec![root.join("docs")];
    while let Some(d) = dirs.pop() {
        let mut entries: Vec<PathBuf> = std::fs::read_dir(&d)
            .unwrap()
            .map(|e| e.unwrap().path())
            .collect();
        entries.sort();
        for p in entries {
            if p.is_dir() {
                dirs.push(p);
            } else if p.extension().is_some_and(|e| e == "md") {
                files.push(p);
            }
        }
    }
    files
}

/// Every `pvrsim` command line of `text`: `(line number, words)`. Code
/// blocks: each line (a trailing `\` joins the next); prose: each inline
/// code span that starts with `pvrsim ` and is not a synopsis.
fn commands(text: &str) -> Vec<(usize, Vec<String>)> {
    let mut out = Vec::new();
    let mut in_block = false;
    let mut pending: Option<(usize, String)> = None;
    for (i, line) in text.lines().enumerate() {
        let n = i + 1;
        if line.trim_start().starts_with("```") {
            in_block = !in_block;
            pending = None;
            continue;
        }
        if in_block {
            let (start, mut joined) = pending.take().unwrap_or((n, String::new()));
            joined.push_str(line.trim_end());
            if let Some(stripped) = joined.strip_suffix('\\') {
                pending = Some((start, format!("{stripped} ")));
                continue;
            }
            if let Some(w) = pvrsim_words(&joined) {
                out.push((start, w));
            }
            continue;
        }
        for (k, span) in line.split('`').enumerate() {
            if k % 2 == 1 && span.starts_with("pvrsim ") && !is_synopsis(span) {
                if let Some(w) = pvrsim_words(span) {
                    out.push((n, w));
                }
            }
        }
    }
    out
}

#[test]
fn every_documented_command_line_parses() {
    let mut checked = 0;
    let mut bad = Vec::new();
    for file in doc_files() {
        let text = std::fs::read_to_string(&file).unwrap();
        for (line, words) in commands(&text) {
            checked += 1;
            if let Err(e) = pvrsim::cli::Cli::try_parse_from(&words) {
                use clap::error::ErrorKind;
                if matches!(e.kind(), ErrorKind::DisplayHelp | ErrorKind::DisplayVersion)
                    || matches!(
                        e.kind(),
                        ErrorKind::DisplayHelpOnMissingArgumentOrSubcommand
                    ) && words.len() == 1
                {
                    continue;
                }
                let first = e.to_string().lines().next().unwrap_or("").to_string();
                bad.push(format!(
                    "{}:{line}: {}\n    {first}",
                    file.strip_prefix(env!("CARGO_MANIFEST_DIR"))
                        .unwrap_or(&file)
                        .display(),
                    words.join(" ")
                ));
            }
        }
    }
    assert!(
        checked > 100,
        "only {checked} command lines found in the docs"
    );
    assert!(
        bad.is_empty(),
        "{} of {checked} documented command lines do not parse:\n{}",
        bad.len(),
        bad.join("\n")
    );
}

#[test]
fn the_extractor_finds_commands_and_skips_prose() {
    let text = "Run `pvrsim render s.toml -o a.png` or `pvrsim scene M [--view V]`.\n\
                ```sh\n\
                pvrsim cluster s.toml --nodes 4 \\\n  --ert 0.9   # comment\n\
                echo pvrsim\n\
                PVRSIM_X=1 pvrsim info m.vtk | head\n\
                ```\n";
    let c = commands(text);
    let words: Vec<String> = c.iter().map(|(_, w)| w.join(" ")).collect();
    assert_eq!(
        words,
        [
            "pvrsim render s.toml -o a.png",
            "pvrsim cluster s.toml --nodes 4 --ert 0.9",
            "pvrsim info m.vtk"
        ]
    );
    assert_eq!(c[1].0, 3);
    // A misspelt option is caught.
    let w = pvrsim_words("pvrsim render s.toml --ert-tabel 20").unwrap();
    assert!(pvrsim::cli::Cli::try_parse_from(&w).is_err());
}

/// Runs `pvrsim ARGS` in `dir`; fails the test with its output unless it
/// succeeds.
fn ok(dir: &Path, args: &[&str]) -> (String, String) {
    let o = run_in(dir, args);
    let (out, err) = text(&o);
    assert!(
        o.status.success(),
        "pvrsim {}: {:?}\nstdout: {out}\nstderr: {err}",
        args.join(" "),
        o.status
    );
    assert!(!err.contains("panicked"), "{err}");
    (out, err)
}

#[test]
fn the_readme_quick_commands_run_on_built_in_data() {
    let d = tempfile::tempdir().unwrap();
    let p = d.path();
    // Quick start (README: `cargo run --release -- demo`).
    let (out, _) = ok(p, &["demo"]);
    for f in [
        "demo.vtk",
        "demo.toml",
        "demo.png",
        "demo-ert.toml",
        "hydrogen.toml",
    ] {
        assert!(p.join("demo").join(f).exists(), "demo/{f} missing");
    }
    // Every file the demo's "next:" lines name exists.
    for line in out.lines().filter(|l| l.contains("pvrsim ")) {
        let words = pvrsim_words(&line[line.find("pvrsim").unwrap()..]).unwrap();
        assert!(pvrsim::cli::Cli::try_parse_from(&words).is_ok(), "{line}");
        for w in words.iter().filter(|w| w.ends_with(".toml")) {
            assert!(p.join(w).exists(), "{line}: {w} was not written");
        }
    }
    // Rendering (README "Rendering"), on the demo's data.
    ok(
        p,
        &[
            "render",
            "demo/demo.toml",
            "-o",
            "out.png",
            "--threads",
            "2",
        ],
    );
    assert!(p.join("out.png").exists());
    ok(p, &["info", "demo/demo.vtk"]);
    ok(
        p,
        &["scene", "demo/demo.vtk", "--field", "speed", "-o", "s.toml"],
    );
    ok(p, &["render", "s.toml", "-o", "s.png", "--ert", "1.0"]);
    ok(p, &["render", "demo/hydrogen.toml", "-o", "h.png"]);
    // The simulated cluster, small.
    ok(
        p,
        &[
            "cluster",
            "demo/demo-ert.toml",
            "--nodes",
            "4",
            "--ert",
            "0.9",
            "--share",
            "--dlb",
            "-o",
            "c.png",
            "--report",
            "r.json",
        ],
    );
    assert!(json(&p.join("r.json"))["n_nodes"] == 4);
}
