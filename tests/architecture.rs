//! The layers of `docs/architecture.md`, checked on the source.
//!
//! Every module path a file of `src/` names (`crate::…`, `super::…`,
//! `self::…`, nested `super::super::…`, `use` groups, inline modules,
//! `#[path]` test files as part of their declaring file, re-exports followed
//! through `pub use`; comments and string literals left out) becomes an arrow
//! between two *children of one folder*: between rooms (the top-level
//! modules of `src/`) when the path leaves the file's room, between the files
//! and sub-folders of a folder when it stays inside one. Then:
//!
//! - every arrow between rooms is in [`ARROWS`], the layer table (and the
//!   table itself runs downward only, with a reason beside each frontend
//!   arrow that goes around the job layer);
//! - inside every folder of `src/`, the children form no circle (no two
//!   files import each other, nor three in a ring);
//! - the checker fails when a forbidden import is inserted (its own tests
//!   below feed it such sources).
//!
//! `cargo test --release --test architecture -- --nocapture` prints the
//! arrows found, room by room.

use std::collections::{BTreeMap, BTreeSet};
use std::path::{Path, PathBuf};

mod import_graph;
use import_graph::{arrows, code, crate_sources, find_circle, path_modules, Arrows, Source};

/// The rooms, top to bottom: a room may only import rooms of a lower
/// level (a larger number). Rooms on one level import nothing of each other.
const LEVELS: &[(&str, u8)] = &[
    ("cli", 0),
    ("experiment", 1),
    ("bench", 1),
    ("view", 1),
    ("job", 2),
    ("cluster", 3),
    ("manager", 4),
    ("node", 5),
    ("compositor", 6),
    ("render", 7),
    ("data", 8),
    ("scene", 9),
    ("image", 10),
    ("net", 10),
    ("budget", 10),
    ("base", 11),
    ("error", 12),
    ("text", 12),
];

/// The frontends: an arrow from one of these past the job layer into the
/// engine must carry its reason (the third field of [`ARROWS`]).
const FRONTENDS: &[&str] = &["cli", "experiment", "bench", "view"];

/// The rooms a frontend may name without a reason: the job layer, the
/// frontends below it, and the base types every layer shares.
const FRONTEND_PLAIN: &[&str] = &[
    "job",
    "experiment",
    "bench",
    "view",
    "error",
    "text",
    "base",
];

/// The layer table: every arrow `FROM -> TO` (room `FROM` names a path in
/// room `TO`) that the code may hold. An arrow found in the code and not
/// here fails `every_arrow_is_in_the_table`; an arrow here that the code no
/// longer holds fails `every_table_arrow_is_used` (so the table stays true).
/// The third field is the reason, required for a frontend reaching the
/// engine directly; `docs/architecture.md` repeats these reasons.
const ARROWS: &[(&str, &str, &str)] = &[
    // ---- frontends
    ("cli", "experiment", ""),
    ("cli", "base", ""),
    ("cli", "bench", ""),
    ("cli", "view", ""),
    ("cli", "job", ""),
    ("cli", "text", ""),
    ("cli", "budget", "`generate` and `splat` size their output before writing (no job of their own)"),
    ("cli", "cluster", "`worker` runs a remote worker; `cluster` prints the report's summary and timeline"),
    ("cli", "data", "`info`, `scene`, `generate`, `demo`, `splat` read and write datasets (no job of their own)"),
    ("cli", "image", "`cluster` and `splat` write the image a job returns"),
    ("cli", "net", "`worker` takes the TCP options and token; `cluster` writes the network trace"),
    ("cli", "render", "`demo` and `splat` call a renderer directly (no job of their own)"),
    ("cli", "scene", "`scene`, `generate`, `demo`, `cluster` read or write scene files"),
    ("experiment", "job", ""),
    ("experiment", "text", ""),
    ("experiment", "base", ""),
    ("experiment", "data", "the fidelity sweep generates built-in datasets; the estimate reads a mesh's size"),
    ("experiment", "scene", "the estimate reads a scene's image size"),
    ("view", "job", ""),
    ("view", "image", "the viewer encodes the frames a job returns (JPEG while moving, the one PNG writer when still)"),
    ("view", "scene", "the viewer turns the camera and edits the transfer function of the loaded scene, and writes it as a scene TOML"),
    ("bench", "job", ""),
    ("bench", "text", ""),
    ("bench", "cluster", "calibration times phase 2 alone (node lists) and local TCP workers"),
    ("bench", "compositor", "calibration times one compositing schedule and codec alone"),
    ("bench", "data", "benchmarks load or generate their volumes once, outside the timed region"),
    ("bench", "image", "benchmarks compare the images of the paths they time"),
    ("bench", "net", "calibration reads thread CPU clocks and times TCP frames"),
    ("bench", "node", "calibration fits the node cost model (least squares, cost profiles)"),
    ("bench", "render", "benchmarks time one renderer phase alone (the job would add load and checks)"),
    ("bench", "scene", "benchmarks build cameras and transfer functions for generated volumes"),
    // ---- job layer
    ("job", "cluster", ""),
    ("job", "node", ""),
    ("job", "compositor", ""),
    ("job", "render", ""),
    ("job", "data", ""),
    ("job", "scene", ""),
    ("job", "image", ""),
    ("job", "net", ""),
    ("job", "budget", ""),
    ("job", "text", ""),
    ("job", "base", ""),
    // ---- engine
    ("cluster", "manager", ""),
    ("cluster", "node", ""),
    ("cluster", "compositor", ""),
    ("cluster", "render", ""),
    ("cluster", "data", ""),
    ("cluster", "scene", ""),
    ("cluster", "image", ""),
    ("cluster", "net", ""),
    ("cluster", "base", ""),
    ("cluster", "text", ""),
    ("manager", "node", ""),
    ("manager", "net", ""),
    ("node", "compositor", ""),
    ("node", "render", ""),
    ("node", "data", ""),
    ("node", "scene", ""),
    ("node", "image", ""),
    ("node", "net", ""),
    ("node", "base", ""),
    ("node", "error", ""),
    ("compositor", "image", ""),
    ("compositor", "base", ""),
    ("render", "data", ""),
    ("render", "scene", ""),
    ("render", "image", ""),
    ("render", "base", ""),
    ("render", "error", ""),
    // ---- data, scene, image and base types
    ("data", "scene", ""),
    ("data", "error", ""),
    ("scene", "error", ""),
    ("image", "error", ""),
];

/// The Python module (`python/src`, its own crate over `pvrsim`): a
/// frontend beside `cli`. Every room of `pvrsim` it names, with the reason
/// where it reaches past the job layer; `python_arrows_are_in_the_table`
/// holds it to the code both ways, and `docs/architecture.md` shows each
/// as `python -> ROOM`.
const PYTHON_ARROWS: &[(&str, &str)] = &[
    ("job", ""),
    ("error", ""),
    ("base", ""),
    ("cli", "`pvrsim.main()` runs the command line in this process; `Scene.fit` parses the `scene` command's options"),
    ("experiment", "`pvrsim.sweep` runs a sweep config as `pvrsim sweep` does"),
    ("view", "`pvrsim.view` starts the viewer's server, as `pvrsim view` does"),
    ("cluster", "a cluster result draws its timeline; worker processes are started as `python -m pvrsim worker`"),
    ("data", "`Mesh.read` and `Volume.read` hand datasets to Python"),
    ("scene", "`Scene` wraps the scene contract's type"),
    ("image", "results hand their images to numpy"),
];

/// Circles inside rooms the code still holds, each a pair of children of
/// one folder (`folder`, `a`, `b`) that name each other, with who breaks it.
/// The circle check ignores these two arrows and nothing else; a pair that
/// no longer names each other fails `every_circle_left_is_still_there`, so
/// the list only shrinks.
const CIRCLES_LEFT: &[(&str, &str, &str, &str)] = &[];

/// What is wrong with a crate's arrows against the table: arrows between
/// rooms not in `table`, and circles inside folders. Empty when it holds.
fn violations(a: &Arrows, table: &[(&str, &str, &str)]) -> Vec<String> {
    let allowed: BTreeSet<(&str, &str)> = table.iter().map(|(f, t, _)| (*f, *t)).collect();
    let mut out = Vec::new();
    if let Some(rooms) = a.get(&Vec::new()) {
        for (from, tos) in rooms {
            for to in tos {
                if !allowed.contains(&(from.as_str(), to.as_str())) {
                    out.push(format!(
                        "src/{from} names crate::{to}, an arrow {from} -> {to} not in the layer table (tests/architecture.rs ARROWS)"
                    ));
                }
            }
        }
    }
    for (folder, g) in a {
        let mut g = g.clone();
        let name = folder.join("/");
        for (f, x, y, _) in CIRCLES_LEFT {
            if *f == name {
                for (p, q) in [(x, y), (y, x)] {
                    if let Some(s) = g.get_mut(*p) {
                        s.remove(*q);
                    }
                }
            }
        }
        if let Some(c) = find_circle(&g) {
            let at = if folder.is_empty() {
                "src".to_string()
            } else {
                format!("src/{}", folder.join("/"))
            };
            out.push(format!(
                "{at}: children import each other in a circle: {}",
                c.join(" -> ")
            ));
        }
    }
    out
}

/// Prints the arrows between rooms and the count inside folders.
fn print_arrows(a: &Arrows) {
    println!("arrows between rooms (FROM -> rooms it names):");
    for (from, tos) in a.get(&Vec::new()).into_iter().flatten() {
        let list: Vec<&str> = tos.iter().map(String::as_str).collect();
        println!("  {from:<10} -> {}", list.join(", "));
    }
    let inner: usize = a
        .iter()
        .filter(|(f, _)| !f.is_empty())
        .map(|(_, g)| g.values().map(BTreeSet::len).sum::<usize>())
        .sum();
    println!(
        "arrows inside rooms: {inner} in {} folders; circles left: {}",
        a.len().saturating_sub(1),
        CIRCLES_LEFT.len()
    );
}

// ---------------------------------------------------------------- tests

#[test]
fn every_arrow_is_in_the_table() {
    let sources = crate_sources();
    let a = arrows(&sources);
    print_arrows(&a);
    let rooms = a.get(&Vec::new()).map_or(0, BTreeMap::len);
    assert!(
        rooms > 10,
        "found only {rooms} rooms with arrows under src/"
    );
    let v = violations(&a, ARROWS);
    assert!(v.is_empty(), "the layers do not hold:\n{}", v.join("\n"));
}

#[test]
fn every_table_arrow_is_used() {
    let a = arrows(&crate_sources());
    let found = a.get(&Vec::new()).cloned().unwrap_or_default();
    let unused: Vec<String> = ARROWS
        .iter()
        .filter(|(f, t, _)| !found.get(*f).is_some_and(|s| s.contains(*t)))
        .map(|(f, t, _)| format!("{f} -> {t}"))
        .collect();
    assert!(
        unused.is_empty(),
        "arrows in the table that the code no longer holds (remove them): {}",
        unused.join(", ")
    );
}

#[test]
fn every_circle_left_is_still_there() {
    let a = arrows(&crate_sources());
    for (folder, x, y, _) in CIRCLES_LEFT {
        let key: Vec<String> = folder.split('/').map(String::from).collect();
        let names = |p: &str, q: &str| {
            a.get(&key)
                .and_then(|g| g.get(p))
                .is_some_and(|s| s.contains(q))
        };
        assert!(
            names(x, y) && names(y, x),
            "src/{folder}: {x} and {y} no longer name each other; remove them from CIRCLES_LEFT"
        );
    }
}

#[test]
fn the_table_runs_downward_and_names_its_detours() {
    let level: BTreeMap<&str, u8> = LEVELS.iter().copied().collect();
    let src = Path::new(env!("CARGO_MANIFEST_DIR")).join("src");
    let rooms: BTreeSet<String> = std::fs::read_dir(&src)
        .unwrap()
        .filter_map(|e| {
            let n = e.unwrap().file_name().into_string().unwrap();
            let n = n.strip_suffix(".rs").map(str::to_string).unwrap_or(n);
            (n != "lib" && n != "main").then_some(n)
        })
        .collect();
    for r in &rooms {
        assert!(
            level.contains_key(r.as_str()),
            "room {r} has no level in LEVELS"
        );
    }
    let mut seen = BTreeSet::new();
    for (f, t, why) in ARROWS {
        assert!(seen.insert((f, t)), "{f} -> {t} is twice in ARROWS");
        let (lf, lt) = (level[f], level[t]);
        assert!(
            lf < lt,
            "{f} -> {t} runs upward or sideways (levels {lf} -> {lt})"
        );
        let detour = FRONTENDS.contains(f) && !FRONTEND_PLAIN.contains(t);
        assert_eq!(
            detour,
            !why.is_empty(),
            "{f} -> {t}: a frontend reaching past the job layer needs a reason, any other arrow none"
        );
    }
}

/// The rows of the markdown tables of `text` (cells trimmed), header and
/// separator rows left out.
fn table_rows(text: &str) -> Vec<Vec<String>> {
    text.lines()
        .filter(|l| l.starts_with('|') && !l.starts_with("|---"))
        .map(|l| {
            l.trim_matches('|')
                .split('|')
                .map(|c| c.trim().to_string())
                .collect()
        })
        .filter(|r: &Vec<String>| r[0] != "room" && r[0] != "arrow")
        .collect()
}

#[test]
fn the_document_shows_the_table() {
    let doc =
        std::fs::read_to_string(Path::new(env!("CARGO_MANIFEST_DIR")).join("docs/architecture.md"))
            .unwrap();
    let start = doc
        .find("## The layer table")
        .expect("docs/architecture.md: ## The layer table");
    let end = doc[start..]
        .find("### Circles left")
        .map_or(doc.len(), |e| start + e);
    let mut shown = BTreeSet::new();
    let mut reasons = BTreeMap::new();
    for r in table_rows(&doc[start..end]) {
        if let Some((f, t)) = r[0].split_once(" -> ") {
            reasons.insert((f.to_string(), t.to_string()), r[1].clone());
            continue;
        }
        for from in r[0].split(", ") {
            for to in r[1].replace("*named:*", "").split([',', ';']) {
                let to = to.trim();
                if !to.is_empty() && to != "—" {
                    shown.insert((from.to_string(), to.to_string()));
                }
            }
        }
    }
    let table: BTreeSet<(String, String)> = ARROWS
        .iter()
        .map(|(f, t, _)| (f.to_string(), t.to_string()))
        .collect();
    assert_eq!(
        shown, table,
        "docs/architecture.md's layer table differs from ARROWS"
    );
    let named: BTreeMap<(String, String), String> = ARROWS
        .iter()
        .filter(|(_, _, why)| !why.is_empty())
        .map(|(f, t, why)| ((f.to_string(), t.to_string()), why.replace('`', "")))
        .collect();
    let reasons: BTreeMap<_, _> = reasons
        .into_iter()
        .map(|(k, v)| (k, v.replace('`', "")))
        .collect();
    assert_eq!(
        reasons, named,
        "docs/architecture.md's named frontend arrows differ from ARROWS' reasons"
    );
}

/// A source from a module path (`a::b`) and its text.
fn fake(module: &str, text: &str) -> Source {
    Source {
        module: module.split("::").map(String::from).collect(),
        code: code(text),
    }
}

#[test]
fn the_checker_fails_on_an_inserted_forbidden_import() {
    let mut sources = crate_sources();
    assert!(violations(&arrows(&sources), ARROWS).is_empty());
    // a renderer naming a frontend
    let scan = sources
        .iter_mut()
        .find(|s| s.module == ["render", "cell", "scan"])
        .expect("src/render/cell/scan.rs");
    scan.code.push_str("\nuse crate::cli::x;\n");
    let v = violations(&arrows(&sources), ARROWS);
    assert!(
        v.iter().any(|m| m.contains("render -> cli")),
        "an inserted `use crate::cli::x;` in render was not caught: {v:?}"
    );
    // two files of one folder naming each other, by super:: and crate::
    let mut sources = crate_sources();
    for (m, add) in [
        (["net", "cpu"], "\nfn f() { super::trace::g(); }\n"),
        (["net", "trace"], "\nuse crate::net::cpu::h;\n"),
    ] {
        let s = sources.iter_mut().find(|s| s.module == m).unwrap();
        s.code.push_str(&code(add));
    }
    let v = violations(&arrows(&sources), ARROWS);
    assert!(
        v.iter().any(|m| m.starts_with("src/net:")),
        "net/cpu <-> net/trace was not caught: {v:?}"
    );
}

#[test]
fn the_checker_reads_every_form_of_path() {
    let sources = vec![
        fake(
            "r::a",
            "use super::b::X; // crate::z\nconst S: &str = \"crate::y\";",
        ),
        fake("r::b", "fn f() { crate::r::c::g(); }"),
        fake("r::c", "use super::{d, e::{self, F}};"),
        fake("r::d", "mod tests { use super::super::e::G; }"),
        fake("r::e", "use crate::{q::{self}, r::f::H as I};"),
        fake("r::f", "pub fn h() {}"),
        fake("r", "pub use f::J;"),
        fake("r::g::h", "use super::super::J;"),
        fake("q", ""),
    ];
    let a = arrows(&sources);
    let inside = &a[&vec!["r".to_string()]];
    let edges: Vec<(String, String)> = inside
        .iter()
        .flat_map(|(f, ts)| ts.iter().map(move |t| (f.clone(), t.clone())))
        .collect();
    let want = [
        ("a", "b"),
        ("b", "c"),
        ("c", "d"),
        ("c", "e"),
        ("d", "e"),
        ("e", "f"),
        ("g", "f"),
    ]
    .map(|(f, t)| (f.to_string(), t.to_string()));
    assert_eq!(edges, want.to_vec());
    assert_eq!(
        a[&Vec::new()],
        [("r".to_string(), ["q".to_string()].into())].into()
    );
    assert!(violations(&a, &[("r", "q", "")]).is_empty());
    assert_eq!(violations(&a, &[]).len(), 1);
    let moved = path_modules(
        Path::new("r/a.rs"),
        &["r".to_string(), "a".to_string()],
        "#[cfg(test)]\n#[path = \"a_tests.rs\"]\nmod tests;",
    );
    assert_eq!(
        moved,
        [(
            PathBuf::from("r/a_tests.rs"),
            ["r", "a", "tests"].map(String::from).to_vec()
        )]
    );
    let mut g: BTreeMap<String, BTreeSet<String>> = BTreeMap::new();
    g.insert("a".into(), ["b".to_string()].into());
    g.insert("b".into(), ["a".to_string()].into());
    assert!(find_circle(&g).is_some());
    g.get_mut("b").unwrap().clear();
    assert!(find_circle(&g).is_none());
}

/// The rooms of `pvrsim` that the Python module's sources name
/// (`pvrsim::ROOM`, comments and strings left out).
fn python_rooms() -> BTreeSet<String> {
    let dir = Path::new(env!("CARGO_MANIFEST_DIR")).join("python/src");
    let mut rooms = BTreeSet::new();
    let mut stack = vec![dir];
    while let Some(d) = stack.pop() {
        for e in std::fs::read_dir(&d).unwrap() {
            let p = e.unwrap().path();
            if p.is_dir() {
                stack.push(p);
            } else if p.extension().is_some_and(|x| x == "rs") {
                let text = code(&std::fs::read_to_string(&p).unwrap());
                let mut rest = text.as_str();
                while let Some(i) = rest.find("pvrsim::") {
                    rest = &rest[i + "pvrsim::".len()..];
                    let room: String = rest
                        .chars()
                        .take_while(|c| c.is_ascii_alphanumeric() || *c == '_')
                        .collect();
                    if !room.is_empty() {
                        rooms.insert(room);
                    }
                }
            }
        }
    }
    rooms
}

#[test]
fn python_arrows_are_in_the_table() {
    let found = python_rooms();
    assert!(
        found.contains("job"),
        "the Python module calls the job layer"
    );
    let table: BTreeSet<String> = PYTHON_ARROWS.iter().map(|(r, _)| r.to_string()).collect();
    let unlisted: Vec<_> = found.difference(&table).collect();
    let unused: Vec<_> = table.difference(&found).collect();
    assert!(
        unlisted.is_empty() && unused.is_empty(),
        "python/src names rooms not in PYTHON_ARROWS: {unlisted:?}; PYTHON_ARROWS rows the code \
         no longer holds: {unused:?}"
    );
    for (room, why) in PYTHON_ARROWS {
        assert!(
            LEVELS.iter().any(|(r, _)| r == room),
            "python -> {room}: not a room of the layer table"
        );
        assert!(
            FRONTEND_PLAIN.contains(room) || *room == "cli" || !why.is_empty(),
            "python -> {room} reaches past the job layer without a reason"
        );
    }
    let doc =
        std::fs::read_to_string(Path::new(env!("CARGO_MANIFEST_DIR")).join("docs/architecture.md"))
            .unwrap();
    for (room, _) in PYTHON_ARROWS {
        assert!(
            doc.contains(&format!("python -> {room}")),
            "docs/architecture.md does not show `python -> {room}`"
        );
    }
}
