//! The import graph of `src/`, for `tests/architecture.rs`: every file's
//! module path, its code without comments and string literals, every module
//! path it names (resolved from the crate root, re-exports followed to the
//! defining file), and the arrows between the children of each folder.

use std::collections::{BTreeMap, BTreeSet};
use std::path::{Path, PathBuf};

// ---------------------------------------------------------------- source

/// One source file: its module path (`src/render/cell/scan.rs` ->
/// `render::cell::scan`, `mod.rs` -> its folder) and its code.
pub struct Source {
    pub module: Vec<String>,
    pub code: String,
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
pub fn path_modules(rel: &Path, module: &[String], text: &str) -> Vec<(PathBuf, Vec<String>)> {
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
pub fn crate_sources() -> Vec<Source> {
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
pub fn code(text: &str) -> String {
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
pub type ModPath = Vec<String>;

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
pub type Arrows = BTreeMap<Vec<String>, BTreeMap<String, BTreeSet<String>>>;

/// The arrows between the children of every folder of `sources`.
pub fn arrows(sources: &[Source]) -> Arrows {
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
pub fn find_circle(g: &BTreeMap<String, BTreeSet<String>>) -> Option<Vec<String>> {
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
