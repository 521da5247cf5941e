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

/// Whether a word is a placeholder of a synopsis (`SCENE.toml`, `N`,
/// `exact|midpoint`, `[--table1]`, `CACHE/c<N>/demo.toml`, `paper-*`).
fn is_placeholder(word: &str) -> bool {
    let stem = word.split('.').next().unwrap_or(word);
    word.contains(['[', ']', '|', '<', '>', '*', '…'])
        || word == "..."
        || (stem.chars().any(|c| c.is_ascii_uppercase())
            && !stem.chars().any(|c| c.is_ascii_lowercase())
            && !stem.starts_with('-'))
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

/// How a documented command line is checked.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
enum Check {
    /// A whole command in a code block: it must parse.
    Parse,
    /// A synopsis with placeholders, or a fragment in prose: its
    /// subcommand and every `--option` it names must exist.
    Options,
}

/// Every `pvrsim` command line of `text`: `(line number, words, check)`.
/// Code blocks: each line (a trailing `\` joins the next), parsed whole
/// unless a word is a placeholder; prose: each inline code span that
/// starts with `pvrsim ` (a span may run over lines), its options checked.
fn commands(text: &str) -> Vec<(usize, Vec<String>, Check)> {
    let mut out = Vec::new();
    let mut in_block = false;
    let mut pending: Option<(usize, String)> = None;
    let mut prose = String::new();
    let mut prose_lines: Vec<usize> = Vec::new();
    for (i, line) in text.lines().enumerate() {
        let n = i + 1;
        if line.trim_start().starts_with("```") {
            in_block = !in_block;
            pending = None;
            prose.push('\n');
            prose_lines.push(n);
            continue;
        }
        if !in_block {
            prose.push_str(line);
            prose.push('\n');
            prose_lines.push(n);
            continue;
        }
        let (start, mut joined) = pending.take().unwrap_or((n, String::new()));
        joined.push_str(line.trim_end());
        if let Some(stripped) = joined.strip_suffix('\\') {
            pending = Some((start, format!("{stripped} ")));
            continue;
        }
        if let Some(w) = pvrsim_words(&joined) {
            let check = if w.iter().any(|w| is_placeholder(w)) {
                Check::Options
            } else {
                Check::Parse
            };
            out.push((start, w, check));
        }
    }
    let mut at = 0;
    for (k, span) in prose.split('`').enumerate() {
        let line = prose_lines
            .get(prose[..at].matches('\n').count())
            .copied()
            .unwrap_or(0);
        at += span.len() + 1;
        let span = span.replace('\n', " ");
        if k % 2 == 1 && span.starts_with("pvrsim ") {
            if let Some(w) = pvrsim_words(&span) {
                out.push((line, w, Check::Options));
            }
        }
    }
    out.sort_by_key(|(l, _, _)| *l);
    out
}

/// Checks the subcommand and the `--options` of `words` against the
/// command-line definition: `Err` names what does not exist.
fn options_exist(words: &[String]) -> Result<(), String> {
    use clap::CommandFactory;
    let cli = pvrsim::cli::Cli::command();
    let Some(name) = words
        .get(1)
        .filter(|w| !w.starts_with('-') && !is_placeholder(w))
    else {
        return Ok(());
    };
    let Some(sub) = cli.find_subcommand(name) else {
        return Err(format!("no subcommand `{name}`"));
    };
    for w in &words[2..] {
        let Some(long) = w.strip_prefix("--") else {
            continue;
        };
        let long = long.split('=').next().unwrap_or(long);
        if long.is_empty() || is_placeholder(long) {
            continue;
        }
        let known = sub.get_arguments().chain(cli.get_arguments()).any(|a| {
            a.get_long() == Some(long) || a.get_all_aliases().is_some_and(|v| v.contains(&long))
        }) || matches!(long, "help" | "version");
        if !known {
            return Err(format!("`pvrsim {name}` has no option --{long}"));
        }
    }
    Ok(())
}

#[test]
fn every_documented_command_line_parses() {
    let mut checked = [0, 0];
    let mut bad = Vec::new();
    for file in doc_files() {
        let text = std::fs::read_to_string(&file).unwrap();
        let shown = file
            .strip_prefix(env!("CARGO_MANIFEST_DIR"))
            .unwrap_or(&file)
            .display()
            .to_string();
        for (line, words, check) in commands(&text) {
            let result = match check {
                Check::Parse => {
                    checked[0] += 1;
                    match pvrsim::cli::Cli::try_parse_from(&words) {
                        Ok(_) => Ok(()),
                        Err(e) => {
                            use clap::error::ErrorKind;
                            if matches!(
                                e.kind(),
                                ErrorKind::DisplayHelp | ErrorKind::DisplayVersion
                            ) {
                                Ok(())
                            } else {
                                Err(e.to_string().lines().next().unwrap_or("").to_string())
                            }
                        }
                    }
                }
                Check::Options => {
                    checked[1] += 1;
                    options_exist(&words)
                }
            };
            if let Err(e) = result {
                bad.push(format!("{shown}:{line}: {}\n    {e}", words.join(" ")));
            }
        }
    }
    assert!(
        checked[0] > 80 && checked[1] > 150,
        "only {checked:?} command lines found in the docs"
    );
    assert!(
        bad.is_empty(),
        "{} documented command lines do not fit the program:\n{}",
        bad.len(),
        bad.join("\n")
    );
}

#[test]
fn the_extractor_finds_commands_and_checks_them() {
    let text = "Run `pvrsim render s.toml -o a.png` or `pvrsim scene M\n--view +x`.\n\
                ```sh\n\
                pvrsim cluster s.toml --nodes 4 \\\n  --ert 0.9   # comment\n\
                echo pvrsim\n\
                PVRSIM_X=1 pvrsim info m.vtk | head\n\
                pvrsim render SCENE.toml --ert T\n\
                ```\n";
    let c = commands(text);
    let got: Vec<(usize, String, Check)> =
        c.iter().map(|(l, w, k)| (*l, w.join(" "), *k)).collect();
    assert_eq!(
        got,
        [
            (
                1,
                "pvrsim render s.toml -o a.png".to_string(),
                Check::Options
            ),
            (1, "pvrsim scene M --view +x".to_string(), Check::Options),
            (
                4,
                "pvrsim cluster s.toml --nodes 4 --ert 0.9".to_string(),
                Check::Parse
            ),
            (7, "pvrsim info m.vtk".to_string(), Check::Parse),
            (
                8,
                "pvrsim render SCENE.toml --ert T".to_string(),
                Check::Options
            ),
        ]
    );
    // A misspelt option is caught both ways, a renamed command too.
    let w = pvrsim_words("pvrsim render s.toml --ert-tabel 20").unwrap();
    assert!(pvrsim::cli::Cli::try_parse_from(&w).is_err());
    assert!(options_exist(&w).unwrap_err().contains("--ert-tabel"));
    assert!(options_exist(&pvrsim_words("pvrsim rendr x").unwrap()).is_err());
    assert!(options_exist(&pvrsim_words("pvrsim render SCENE --ert T --compare").unwrap()).is_ok());
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
    let hints = out.lines().filter(|l| {
        let t = l.trim_start();
        t.starts_with("next: pvrsim ") || t.starts_with("pvrsim ")
    });
    for line in hints {
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
