//! The layers of `docs/architecture.md`, checked on the source: the rooms
//! (top-level modules of `src/`) and the rooms each one names through
//! `crate::ROOM` paths (comments left out) form a graph with no circle, and
//! no room below the frontends names a frontend (`cli`, `experiment`,
//! `bench`).

use std::collections::{BTreeMap, BTreeSet};
use std::path::{Path, PathBuf};

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

/// The code of a file without its `//` comments (doc links name rooms
/// without importing them).
fn code(text: &str) -> String {
    text.lines()
        .map(|l| l.find("//").map_or(l, |i| &l[..i]))
        .collect::<Vec<_>>()
        .join("\n")
}

/// Identifiers that follow `crate::`, including those inside one level of
/// `crate::{a, b::c}`.
fn named_after_crate(code: &str) -> BTreeSet<String> {
    let mut out = BTreeSet::new();
    let ident = |s: &str| -> String {
        s.chars()
            .take_while(|c| c.is_alphanumeric() || *c == '_')
            .collect()
    };
    for (i, _) in code.match_indices("crate::") {
        let rest = &code[i + "crate::".len()..];
        if let Some(group) = rest.strip_prefix('{') {
            let inner = &group[..group.find('}').unwrap_or(group.len())];
            for part in inner.split(',') {
                out.insert(ident(part.trim()));
            }
        } else {
            out.insert(ident(rest));
        }
    }
    out
}

/// Room -> the rooms it names.
fn room_graph() -> BTreeMap<String, BTreeSet<String>> {
    let src = Path::new(env!("CARGO_MANIFEST_DIR")).join("src");
    let rooms: BTreeSet<String> = std::fs::read_dir(&src)
        .unwrap()
        .map(|e| {
            let n = e.unwrap().file_name().into_string().unwrap();
            n.strip_suffix(".rs").map(str::to_string).unwrap_or(n)
        })
        .filter(|n| n != "lib" && n != "main")
        .collect();
    let mut files = Vec::new();
    rust_files(&src, &mut files);
    let mut g: BTreeMap<String, BTreeSet<String>> =
        rooms.iter().map(|r| (r.clone(), BTreeSet::new())).collect();
    for f in files {
        let rel = f.strip_prefix(&src).unwrap();
        let first = rel.components().next().unwrap().as_os_str();
        let first = first.to_str().unwrap();
        let room = first.strip_suffix(".rs").unwrap_or(first).to_string();
        if !rooms.contains(&room) {
            continue;
        }
        let text = std::fs::read_to_string(&f).unwrap();
        for t in named_after_crate(&code(&text)) {
            if t != room && rooms.contains(&t) {
                g.get_mut(&room).unwrap().insert(t);
            }
        }
    }
    g
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
        for v in &g[u] {
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

#[test]
fn the_rooms_form_no_circle() {
    let g = room_graph();
    assert!(g.len() > 10, "found only {} rooms under src/", g.len());
    if let Some(c) = find_circle(&g) {
        panic!("rooms import each other in a circle: {}", c.join(" -> "));
    }
}

#[test]
fn no_room_below_the_frontends_names_one() {
    let frontends = ["cli", "experiment", "bench"];
    let g = room_graph();
    for (room, named) in &g {
        if room == "cli" {
            continue;
        }
        for f in frontends {
            // experiment and bench are frontends that call the job layer;
            // only cli may call them.
            assert!(
                !named.contains(f),
                "src/{room} names the frontend `{f}` (crate::{f}); frontends sit on top of the job layer"
            );
        }
    }
}

/// The files of one folder (modules beside `mod.rs`) -> the siblings each
/// names through `super::NAME` (the folder's own `mod.rs` helpers left out).
fn sibling_graph(dir: &Path) -> BTreeMap<String, BTreeSet<String>> {
    let names: BTreeSet<String> = std::fs::read_dir(dir)
        .unwrap()
        .filter_map(|e| {
            let p = e.unwrap().path();
            let n = p.file_stem()?.to_str()?.to_string();
            (p.extension().is_some_and(|x| x == "rs") && n != "mod").then_some(n)
        })
        .collect();
    let mut g = BTreeMap::new();
    for n in &names {
        let text = std::fs::read_to_string(dir.join(format!("{n}.rs"))).unwrap();
        let code = code(&text);
        let named = code
            .match_indices("super::")
            .map(|(i, _)| {
                code[i + "super::".len()..]
                    .chars()
                    .take_while(|c| c.is_alphanumeric() || *c == '_')
                    .collect::<String>()
            })
            .filter(|t| t != n && names.contains(t))
            .collect();
        g.insert(n.clone(), named);
    }
    g
}

#[test]
fn no_two_files_of_the_job_layer_import_each_other() {
    let dir = Path::new(env!("CARGO_MANIFEST_DIR")).join("src/job");
    let g = sibling_graph(&dir);
    assert!(g.len() > 10, "found only {} files in src/job", g.len());
    if let Some(c) = find_circle(&g) {
        panic!(
            "src/job files import each other in a circle: {}",
            c.join(" -> ")
        );
    }
}

#[test]
fn the_checker_sees_a_circle_and_a_name() {
    let mut g: BTreeMap<String, BTreeSet<String>> = BTreeMap::new();
    g.insert("a".into(), ["b".to_string()].into());
    g.insert("b".into(), ["a".to_string()].into());
    assert!(find_circle(&g).is_some());
    g.get_mut("b").unwrap().clear();
    assert!(find_circle(&g).is_none());
    let n = named_after_crate(&code(
        "use crate::{job::x, net};\nlet y = crate::text::plural(1); // crate::cli",
    ));
    assert_eq!(n, ["job", "net", "text"].map(String::from).into());
}
