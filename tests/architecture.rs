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

/// The rooms, top to bottom: a room may only import rooms of a lower
/// level (a larger number). Rooms on one level import nothing of each other.
const LEVELS: &[(&str, u8)] = &[
    ("cli", 0),
    ("experiment", 1),
    ("bench", 1),
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
const FRONTENDS: &[&str] = &["cli", "experiment", "bench"];

/// The rooms a frontend may name without a reason: the job layer, the
/// frontends below it, and the base types every layer shares.
const FRONTEND_PLAIN: &[&str] = &["job", "experiment", "bench", "error", "text", "base"];

/// The layer table: every arrow `FROM -> TO` (room `FROM` names a path in
/// room `TO`) that the code may hold. An arrow found in the code and not
/// here fails `every_arrow_is_in_the_table`; an arrow here that the code no
/// longer holds fails `every_table_arrow_is_used` (so the table stays true).
/// The third field is the reason, required for a frontend reaching the
/// engine directly; `docs/architecture.md` repeats these reasons.
const ARROWS: &[(&str, &str, &str)] = &[
    // ---- frontends
    ("cli", "experiment", ""),
    ("cli", "bench", ""),
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
    ("experiment", "data", "the fidelity sweep generates built-in datasets; the estimate reads a mesh's size"),
    ("experiment", "scene", "the estimate reads a scene's image size"),
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

/// Circles inside rooms the code still holds, each a pair of children of
/// one folder (`folder`, `a`, `b`) that name each other, with who breaks it.
/// The circle check ignores these two arrows and nothing else; a pair that
/// no longer names each other fails `every_circle_left_is_still_there`, so
/// the list only shrinks.
const CIRCLES_LEFT: &[(&str, &str, &str, &str)] = &[
    ("cluster/remote", "coordinator", "drive", "issue 39 part A"),
    (
        "cluster/remote",
        "coordinator",
        "reassign",
        "issue 39 part A",
    ),
    ("cluster/remote", "grid", "session", "issue 39 part A"),
    ("cluster/remote", "grid", "worker", "issue 39 part A"),
    ("cluster/remote", "mesh", "worker", "issue 39 part A"),
    (
        "cluster",
        "grid",
        "remote",
        "issue 39 part A (cluster/grid.rs split)",
    ),
    ("cluster", "remote", "report", "issue 39 part A"),
    (
        "compositor",
        "codec",
        "layer",
        "codec/layers names layer::Layer, layer/exec the layer codec",
    ),
    (
        "data",
        "dataset",
        "io",
        "io re-exports dataset::read_dataset, dataset calls io's readers",
    ),
    (
        "node",
        "pixel_share",
        "shard_map",
        "shard_map names pixel_share::TILE, pixel_share the shard map",
    ),
    (
        "render",
        "slice2d",
        "slice3d",
        "only their tests: each compares with the other",
    ),
];

// ---------------------------------------------------------------- source

/// One source file: its module path (`src/render/cell/scan.rs` ->
/// `render::cell::scan`, `mod.rs` -> its folder) and its code.
struct Source {
    module: Vec<String>,
    code: String,
}

/// Files under `dir`, recursively.
fn rust_files(dir: &Path, out: &mut Vec<PathBuf>) {
    for e in std::fs::read_dir(dir).unwrap() {
        let p = e.unwrap().path();
        if p.is_dir() {
            rust_files(&p, out);
        } else if p.extension().is_some_and(|x| x == "rs") {
            out.push(p);
        }
    }
}

/// The module path of a file relative to `src/` (`None` for the crate
/// roots `lib.rs` and `main.rs`).
fn module_of(rel: &Path) -> Option<Vec<String>> {
    let mut parts: Vec<String> = rel
        .components()
        .map(|c| c.as_os_str().to_str().unwrap().to_string())
        .collect();
    let last = parts.pop()?;
    let stem = last.strip_suffix(".rs")?.to_string();
    if parts.is_empty() && (stem == "lib" || stem == "main") {
        return None;
    }
    if stem != "mod" {
        parts.push(stem);
    }
    Some(parts)
}

/// The files that `#[path = "FILE"] mod NAME;` declarations of `text` (the
/// file at `rel`, module `module`) bring in, with the module each becomes:
/// `exec.rs`'s `#[path = "exec_tests.rs"] mod tests;` makes
/// `exec_tests.rs` the module `…::exec::tests`, part of `exec`.
fn path_modules(rel: &Path, module: &[String], text: &str) -> Vec<(PathBuf, Vec<String>)> {
    let mut out = Vec::new();
    let mut rest = text;
    while let Some(i) = rest.find("#[path = \"") {
        rest = &rest[i + "#[path = \"".len()..];
        let Some(end) = rest.find('"') else { break };
        let file = &rest[..end];
        let after = rest[end..].trim_start_matches(['"', ']']).trim_start();
        let after = after.strip_prefix("pub ").unwrap_or(after);
        if let Some(decl) = after.strip_prefix("mod ") {
            let name: String = decl.chars().take_while(|c| ident_char(*c)).collect();
            let mut m = module.to_vec();
            m.push(name);
            out.push((rel.parent().unwrap().join(file), m));
        }
    }
    out
}

/// The sources of `src/`.
fn crate_sources() -> Vec<Source> {
    let src = Path::new(env!("CARGO_MANIFEST_DIR")).join("src");
    let mut files = Vec::new();
    rust_files(&src, &mut files);
    files.sort();
    let texts: Vec<(PathBuf, String)> = files
        .iter()
        .map(|f| {
            let rel = f.strip_prefix(&src).unwrap().to_path_buf();
            (rel, std::fs::read_to_string(f).unwrap())
        })
        .collect();
    let mut moved = BTreeMap::new();
    for (rel, text) in &texts {
        if let Some(m) = module_of(rel) {
            moved.extend(path_modules(rel, &m, text));
        }
    }
    texts
        .iter()
        .filter_map(|(rel, text)| {
            let module = moved.get(rel).cloned().or_else(|| module_of(rel))?;
            Some(Source {
                module,
                code: code(text),
            })
        })
        .collect()
}

/// The code of a file with comments, string literals and character
/// literals blanked out (doc links and messages name modules without
/// importing them). Lifetimes (`'a`) stay.
fn code(text: &str) -> String {
    let b: Vec<char> = text.chars().collect();
    let mut out = String::with_capacity(b.len());
    let mut i = 0;
    let at = |i: usize| b.get(i).copied().unwrap_or('\0');
    while i < b.len() {
        let c = b[i];
        if c == '/' && at(i + 1) == '/' {
            while i < b.len() && b[i] != '\n' {
                i += 1;
            }
        } else if c == '/' && at(i + 1) == '*' {
            let mut depth = 0;
            while i < b.len() {
                if b[i] == '/' && at(i + 1) == '*' {
                    depth += 1;
                    i += 2;
                } else if b[i] == '*' && at(i + 1) == '/' {
                    depth -= 1;
                    i += 2;
                    if depth == 0 {
                        break;
                    }
                } else {
                    i += 1;
                }
            }
            out.push(' ');
        } else if c == 'r'
            && (at(i + 1) == '"' || (at(i + 1) == '#' && !ident_char(at(i + 2))))
            && (i == 0
                || !ident_char(b[i - 1])
                || (b[i - 1] == 'b' && (i < 2 || !ident_char(b[i - 2]))))
        {
            // raw string r"…", r#"…"#
            let mut j = i + 1;
            let mut hashes = 0;
            while at(j) == '#' {
                hashes += 1;
                j += 1;
            }
            j += 1; // the opening quote
            loop {
                if j >= b.len() {
                    break;
                }
                if b[j] == '"' && (0..hashes).all(|k| at(j + 1 + k) == '#') {
                    j += 1 + hashes;
                    break;
                }
                j += 1;
            }
            out.push_str("\"\"");
            i = j;
        } else if c == '"' {
            let mut j = i + 1;
            while j < b.len() && b[j] != '"' {
                if b[j] == '\\' {
                    j += 1;
                }
                j += 1;
            }
            out.push_str("\"\"");
            i = j + 1;
        } else if c == '\'' {
            // a character literal ('x', '\n', '\u{..}') or a lifetime
            if at(i + 1) == '\\' {
                let mut j = i + 2;
                while j < b.len() && b[j] != '\'' {
                    j += 1;
                }
                out.push_str("' '");
                i = j + 1;
            } else if at(i + 2) == '\'' {
                out.push_str("' '");
                i += 3;
            } else {
                out.push(c);
                i += 1;
            }
        } else {
            out.push(c);
            i += 1;
        }
    }
    out
}

fn ident_char(c: char) -> bool {
    c.is_alphanumeric() || c == '_'
}

// ---------------------------------------------------------------- paths

/// A module path from the crate root (`["render", "cell", "scan"]`).
type ModPath = Vec<String>;

/// A tiny lexer over code: identifiers, `::` and single punctuation.
fn tokens(code: &str) -> Vec<String> {
    let b: Vec<char> = code.chars().collect();
    let mut out = Vec::new();
    let mut i = 0;
    while i < b.len() {
        let c = b[i];
        if c.is_whitespace() {
            i += 1;
        } else if ident_char(c) {
            let s = i;
            while i < b.len() && ident_char(b[i]) {
                i += 1;
            }
            out.push(b[s..i].iter().collect());
        } else if c == ':' && b.get(i + 1) == Some(&':') {
            out.push("::".into());
            i += 2;
        } else {
            out.push(c.to_string());
            i += 1;
        }
    }
    out
}

/// A path as written, before it is resolved: its segments, and the alias
/// it is bound to in a `use` (`as NAME`, else its last segment).
#[derive(Debug, Clone)]
struct Written {
    segments: Vec<String>,
    alias: String,
}

/// Parses a use tree (or a plain path) at `t[i]`, pushing every leaf path
/// (with `prefix` in front) onto `out`; returns the index after it.
fn use_tree(t: &[String], mut i: usize, prefix: &[String], out: &mut Vec<Written>) -> usize {
    let mut segs = prefix.to_vec();
    loop {
        match t.get(i).map(String::as_str) {
            Some("{") => {
                i += 1;
                while i < t.len() && t[i] != "}" {
                    i = use_tree(t, i, &segs, out);
                    if t.get(i).map(String::as_str) == Some(",") {
                        i += 1;
                    } else if t.get(i).map(String::as_str) != Some("}") {
                        // something a use tree does not hold: stop here
                        return i;
                    }
                }
                return i + 1;
            }
            Some("*") => {
                if !segs.is_empty() {
                    out.push(Written {
                        segments: segs,
                        alias: "*".into(),
                    });
                }
                return i + 1;
            }
            Some(s) if s.chars().next().is_some_and(ident_char) => {
                if s == "self" && !segs.is_empty() && i > 0 && t[i - 1] != "::" {
                    // `{self, …}` inside a group: the prefix itself
                    let alias = segs.last().unwrap().clone();
                    out.push(Written {
                        segments: segs,
                        alias,
                    });
                    return i + 1;
                }
                segs.push(s.to_string());
                i += 1;
                if t.get(i).map(String::as_str) == Some("::") {
                    i += 1;
                    continue;
                }
                let mut alias = segs.last().unwrap().clone();
                if t.get(i).map(String::as_str) == Some("as") {
                    alias = t.get(i + 1).cloned().unwrap_or_default();
                    i += 2;
                }
                out.push(Written {
                    segments: segs,
                    alias,
                });
                return i;
            }
            _ => {
                if segs.len() > prefix.len() {
                    let alias = segs.last().unwrap().clone();
                    out.push(Written {
                        segments: segs,
                        alias,
                    });
                }
                return i;
            }
        }
    }
}

/// Resolves a written path against `here` (the module, inline modules
/// included, where it is written) to a path from the crate root; `None` for
/// a path that starts elsewhere (an extern crate, a local name).
fn resolve(written: &[String], here: &[String]) -> Option<Vec<String>> {
    let mut base: Vec<String>;
    let mut k = 0;
    match written.first().map(String::as_str) {
        Some("crate") => {
            base = Vec::new();
            k = 1;
        }
        Some("self") => {
            base = here.to_vec();
            k = 1;
        }
        Some("super") => {
            base = here.to_vec();
            while written.get(k).map(String::as_str) == Some("super") {
                base.pop()?;
                k += 1;
            }
        }
        _ => return None,
    }
    base.extend(written[k..].iter().cloned());
    Some(base)
}

/// Every path a source names, resolved from the crate root, with the
/// `pub use` re-exports it declares (alias -> path, for the file's own
/// module). Inline `mod NAME { … }` blocks shift `self`/`super`; a bare
/// `pub use child::x` (a child of the file's own module) counts as
/// re-export only.
fn paths_of(src: &Source) -> (Vec<ModPath>, Vec<(String, ModPath)>) {
    let t = tokens(&src.code);
    let mut named = Vec::new();
    let mut reexports = Vec::new();
    // inline modules: (name, brace depth at which they close)
    let mut inline: Vec<(String, usize)> = Vec::new();
    let mut depth = 0usize;
    let mut i = 0;
    let here = |inline: &Vec<(String, usize)>| -> Vec<String> {
        let mut h = src.module.clone();
        h.extend(inline.iter().map(|(n, _)| n.clone()));
        h
    };
    while i < t.len() {
        let s = t[i].as_str();
        match s {
            "{" => {
                depth += 1;
                i += 1;
            }
            "}" => {
                if inline.last().is_some_and(|(_, d)| *d == depth) {
                    inline.pop();
                }
                depth = depth.saturating_sub(1);
                i += 1;
            }
            "mod" if t.get(i + 2).map(String::as_str) == Some("{") => {
                depth += 1;
                inline.push((t[i + 1].clone(), depth));
                i += 3;
            }
            "use" => {
                let public = i > 0 && (t[i - 1] == "pub" || t[i - 1] == ")");
                let mut leaves = Vec::new();
                let j = use_tree(&t, i + 1, &[], &mut leaves);
                let h = here(&inline);
                for w in leaves {
                    let first = w.segments[0].as_str();
                    let full = resolve(&w.segments, &h).or_else(|| {
                        // a bare path: a child of this module (or an extern crate)
                        (public && !matches!(first, "crate" | "self" | "super")).then(|| {
                            let mut p = h.clone();
                            p.extend(w.segments.iter().cloned());
                            p
                        })
                    });
                    if let Some(full) = full {
                        if public && inline.is_empty() {
                            reexports.push((w.alias.clone(), full.clone()));
                        }
                        if resolve(&w.segments, &h).is_some() {
                            named.push(full);
                        }
                    }
                }
                i = j.max(i + 1);
            }
            "crate" | "super" | "self"
                if t.get(i + 1).map(String::as_str) == Some("::")
                    && (i == 0 || t[i - 1] != "::") =>
            {
                let mut leaves = Vec::new();
                let j = use_tree(&t, i, &[], &mut leaves);
                let h = here(&inline);
                for w in leaves {
                    if let Some(full) = resolve(&w.segments, &h) {
                        named.push(full);
                    }
                }
                i = j.max(i + 1);
            }
            _ => i += 1,
        }
    }
    (named, reexports)
}

// ---------------------------------------------------------------- graph

/// The arrows of a crate: for each folder (a module path; the crate root
/// is the empty path), child -> the children it names.
type Arrows = BTreeMap<Vec<String>, BTreeMap<String, BTreeSet<String>>>;

/// The arrows between the children of every folder of `sources`.
fn arrows(sources: &[Source]) -> Arrows {
    let modules: BTreeSet<Vec<String>> = sources.iter().map(|s| s.module.clone()).collect();
    let mut reexports: BTreeMap<Vec<String>, BTreeMap<String, Vec<String>>> = BTreeMap::new();
    let mut named = Vec::new();
    for s in sources {
        let (n, r) = paths_of(s);
        for (alias, path) in r {
            reexports
                .entry(s.module.clone())
                .or_default()
                .insert(alias, path);
        }
        named.push((s.module.clone(), n));
    }
    // follows re-exports until the path names the module that defines it
    let canonical = |mut p: Vec<String>| -> Vec<String> {
        'again: for _ in 0..32 {
            for k in 0..p.len() {
                let prefix = &p[..k];
                let longer = &p[..=k];
                if modules.contains(prefix) && !modules.contains(longer) {
                    if let Some(to) = reexports.get(prefix).and_then(|m| m.get(&p[k])) {
                        if to.as_slice() != longer {
                            let mut q = to.clone();
                            q.extend(p[k + 1..].iter().cloned());
                            p = q;
                            continue 'again;
                        }
                    }
                    break 'again;
                }
            }
            break;
        }
        p
    };
    let mut out: Arrows = BTreeMap::new();
    for (from, paths) in named {
        for p in paths {
            let to = canonical(p);
            let k = from.iter().zip(&to).take_while(|(a, b)| a == b).count();
            if k >= from.len() || k >= to.len() {
                continue; // a path into the file itself or one of its folders' items
            }
            let mut child = to[..=k].to_vec();
            if !modules.contains(&child) {
                continue; // an item of the folder's own mod.rs
            }
            let folder = to[..k].to_vec();
            let target = child.pop().unwrap();
            out.entry(folder)
                .or_default()
                .entry(from[k].clone())
                .or_default()
                .insert(target);
        }
    }
    out
}

/// A circle through `g`, if any.
fn find_circle(g: &BTreeMap<String, BTreeSet<String>>) -> Option<Vec<String>> {
    fn dfs(
        u: &str,
        g: &BTreeMap<String, BTreeSet<String>>,
        state: &mut BTreeMap<String, u8>,
        stack: &mut Vec<String>,
    ) -> Option<Vec<String>> {
        state.insert(u.to_string(), 1);
        stack.push(u.to_string());
        for v in g.get(u).into_iter().flatten() {
            match state.get(v.as_str()) {
                Some(1) => {
                    let at = stack.iter().position(|s| s == v).unwrap();
                    let mut c = stack[at..].to_vec();
                    c.push(v.clone());
                    return Some(c);
                }
                None => {
                    if let Some(c) = dfs(v, g, state, stack) {
                        return Some(c);
                    }
                }
                _ => {}
            }
        }
        stack.pop();
        state.insert(u.to_string(), 2);
        None
    }
    let mut state = BTreeMap::new();
    for r in g.keys() {
        if !state.contains_key(r) {
            if let Some(c) = dfs(r, g, &mut state, &mut Vec::new()) {
                return Some(c);
            }
        }
    }
    None
}

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
