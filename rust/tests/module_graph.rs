//! No import cycle between the crate's modules: the graph of which module uses which, read
//! from the sources (rust/src/**/*.rs), has no cycle.
//!
//! A module is a file (`lib.rs` the crate, `x/mod.rs` and `x.rs` module `x`, `x/y.rs`
//! module `x::y`) or an inline `mod name { ... }` in one. A module uses another when its
//! code names a path `crate::...`, `super::...` or `self::...`, or a `use` line starts
//! with the name of one of its child modules (`use scan::Scan;`); the path's longest
//! prefix that is a module is the one used. Declaring a child (`mod x;`) is no use of it.

use std::collections::{BTreeMap, BTreeSet};
use std::fs;
use std::path::{Path, PathBuf};

type Graph = BTreeMap<String, BTreeSet<String>>;

/// Every `.rs` file under `dir`, sorted.
fn sources(dir: &Path) -> Vec<PathBuf> {
    let mut out = Vec::new();
    let mut todo = vec![dir.to_path_buf()];
    while let Some(d) = todo.pop() {
        for entry in fs::read_dir(&d).expect("readable source directory") {
            let p = entry.expect("directory entry").path();
            if p.is_dir() {
                todo.push(p);
            } else if p.extension().is_some_and(|e| e == "rs") {
                out.push(p);
            }
        }
    }
    out.sort();
    out
}

/// The module path of a source file (`crate`, `crate::compare`, `crate::compare::scan`).
fn module_of(root: &Path, file: &Path) -> String {
    let rel = file.strip_prefix(root).expect("file under the root");
    let mut parts: Vec<String> = rel
        .iter()
        .map(|s| s.to_string_lossy().into_owned())
        .collect();
    let last = parts.pop().expect("a file name");
    match last.as_str() {
        "lib.rs" | "mod.rs" => {}
        name => parts.push(name.trim_end_matches(".rs").to_string()),
    }
    std::iter::once("crate".to_string())
        .chain(parts)
        .collect::<Vec<_>>()
        .join("::")
}

/// A line of code without its comment, string and character literals.
fn code(line: &str) -> String {
    let mut out = String::new();
    let mut chars = line.chars().peekable();
    while let Some(c) = chars.next() {
        match c {
            '/' if chars.peek() == Some(&'/') => break,
            '"' => {
                // a string literal (escapes skipped)
                while let Some(d) = chars.next() {
                    match d {
                        '\\' => {
                            chars.next();
                        }
                        '"' => break,
                        _ => {}
                    }
                }
                out.push_str("\"\"");
            }
            '\'' => {
                // a character literal ('x', '\n', '{'), else a lifetime
                let rest: String = chars.clone().take(3).collect();
                let mut r = rest.chars();
                match (r.next(), r.next(), r.next()) {
                    (Some('\\'), Some(_), Some('\'')) => {
                        chars.nth(2);
                        out.push_str("' '");
                    }
                    (Some(_), Some('\''), _) => {
                        chars.nth(1);
                        out.push_str("' '");
                    }
                    _ => out.push(c),
                }
            }
            _ => out.push(c),
        }
    }
    out
}

/// The identifier at the start of `s`, if any.
fn ident(s: &str) -> Option<&str> {
    let end = s
        .find(|c: char| !(c.is_ascii_alphanumeric() || c == '_'))
        .unwrap_or(s.len());
    (end > 0 && !s.as_bytes()[0].is_ascii_digit()).then(|| &s[..end])
}

/// The segments of the path starting at `s` (`crate::a::b::{x, y}` gives `crate, a, b`).
fn path_at(s: &str) -> Vec<&str> {
    let mut out = Vec::new();
    let mut rest = s;
    while let Some(id) = ident(rest) {
        out.push(id);
        match rest[id.len()..].strip_prefix("::") {
            Some(r) => rest = r,
            None => break,
        }
    }
    out
}

/// The module a path names, from module `at`: its longest prefix that is a module of
/// `modules`.
fn resolve(at: &[String], path: &[&str], modules: &BTreeSet<String>) -> Option<String> {
    let mut base: Vec<String> = match path.first() {
        Some(&"crate") => vec!["crate".to_string()],
        Some(&"self") => at.to_vec(),
        Some(&"super") => {
            let mut b = at.to_vec();
            for seg in path.iter().take_while(|s| **s == "super") {
                let _ = seg;
                b.pop()?;
            }
            b
        }
        _ => at.to_vec(), // a child module's name (checked by the caller)
    };
    let skip = match path.first() {
        Some(&"super") => path.iter().take_while(|s| **s == "super").count(),
        Some(&"crate") | Some(&"self") => 1,
        _ => 0,
    };
    let mut found = modules.contains(&base.join("::")).then(|| base.join("::"));
    for seg in &path[skip..] {
        base.push(seg.to_string());
        let name = base.join("::");
        if modules.contains(&name) {
            found = Some(name);
        } else {
            break;
        }
    }
    found
}

/// The modules of the sources under `root`, and which each uses.
fn graph(root: &Path) -> Graph {
    let files: Vec<(String, String)> = sources(root)
        .iter()
        .map(|f| {
            (
                module_of(root, f),
                fs::read_to_string(f).expect("readable source"),
            )
        })
        .collect();
    graph_of(&files)
}

/// [`graph`] of `(module path, source text)` pairs.
fn graph_of(files: &[(String, String)]) -> Graph {
    // the inline modules first, so that paths into them resolve
    let mut modules: BTreeSet<String> = files.iter().map(|(m, _)| m.clone()).collect();
    let mut lines: Vec<(Vec<String>, String)> = Vec::new();
    for (module, text) in files {
        let file: Vec<String> = module.split("::").map(str::to_string).collect();
        // inline modules open: (name, brace depth inside them)
        let mut inline: Vec<(String, usize)> = Vec::new();
        let mut depth = 0usize;
        for raw in text.lines() {
            let line = code(raw);
            let at: Vec<String> = file
                .iter()
                .cloned()
                .chain(inline.iter().map(|(n, _)| n.clone()))
                .collect();
            let t = line.trim_start();
            let t = t
                .strip_prefix("pub(crate) ")
                .or_else(|| t.strip_prefix("pub(super) "))
                .or_else(|| t.strip_prefix("pub "))
                .unwrap_or(t);
            let opens_inline = t.strip_prefix("mod ").and_then(|r| {
                let name = ident(r)?;
                r[name.len()..]
                    .trim_start()
                    .starts_with('{')
                    .then_some(name)
            });
            for ch in line.chars() {
                match ch {
                    '{' => depth += 1,
                    '}' => {
                        depth = depth.saturating_sub(1);
                        if inline.last().is_some_and(|(_, d)| depth < *d) {
                            inline.pop();
                        }
                    }
                    _ => {}
                }
            }
            if let Some(name) = opens_inline {
                let mut m = at.clone();
                m.push(name.to_string());
                modules.insert(m.join("::"));
                inline.push((name.to_string(), depth));
            }
            lines.push((at, line));
        }
    }
    let mut g: Graph = modules
        .iter()
        .map(|m| (m.clone(), BTreeSet::new()))
        .collect();
    for (at, line) in &lines {
        let here = at.join("::");
        let mut used = Vec::new();
        for key in ["crate::", "super::", "self::"] {
            let mut from = 0;
            while let Some(k) = line[from..].find(key) {
                let i = from + k;
                from = i + key.len();
                let before = line[..i].chars().next_back();
                if before.is_some_and(|c| c.is_ascii_alphanumeric() || c == '_' || c == ':') {
                    continue; // part of another path (`super::super::x`, `foo_self::`)
                }
                used.extend(resolve(at, &path_at(&line[i..]), &modules));
            }
        }
        // `use child::...`: a child module named without `self::`
        let t = line.trim_start();
        let t = t
            .strip_prefix("pub(crate) ")
            .or_else(|| t.strip_prefix("pub(super) "))
            .or_else(|| t.strip_prefix("pub "))
            .unwrap_or(t);
        if let Some(rest) = t.strip_prefix("use ") {
            let path = path_at(rest.trim_start());
            if !path.is_empty() && !matches!(path[0], "crate" | "super" | "self") {
                let child = format!("{here}::{}", path[0]);
                if modules.contains(&child) {
                    used.extend(resolve(at, &path, &modules));
                }
            }
        }
        for u in used {
            if u != here {
                g.entry(here.clone()).or_default().insert(u);
            }
        }
    }
    g
}

/// A cycle of `g` (its modules in order, the first repeated at the end), if there is one.
fn cycle(g: &Graph) -> Option<Vec<String>> {
    // 0: not seen, 1: on the current path, 2: done
    let mut state: BTreeMap<&str, u8> = BTreeMap::new();
    let mut path: Vec<&str> = Vec::new();
    fn visit<'a>(
        n: &'a str,
        g: &'a Graph,
        state: &mut BTreeMap<&'a str, u8>,
        path: &mut Vec<&'a str>,
    ) -> Option<Vec<String>> {
        state.insert(n, 1);
        path.push(n);
        for m in g.get(n).into_iter().flatten() {
            match state.get(m.as_str()).copied().unwrap_or(0) {
                1 => {
                    let start = path.iter().position(|p| *p == m)?;
                    let mut c: Vec<String> = path[start..].iter().map(|s| s.to_string()).collect();
                    c.push(m.clone());
                    return Some(c);
                }
                0 => {
                    if let Some(c) = visit(m, g, state, path) {
                        return Some(c);
                    }
                }
                _ => {}
            }
        }
        path.pop();
        state.insert(n, 2);
        None
    }
    for n in g.keys() {
        if state.get(n.as_str()).copied().unwrap_or(0) == 0 {
            if let Some(c) = visit(n, g, &mut state, &mut path) {
                return Some(c);
            }
        }
    }
    None
}

fn crate_graph() -> Graph {
    graph(
        &Path::new(env!("CARGO_MANIFEST_DIR"))
            .join("rust")
            .join("src"),
    )
}

#[test]
fn no_module_uses_itself_through_others() {
    let g = crate_graph();
    if let Some(c) = cycle(&g) {
        panic!("import cycle between modules: {}", c.join(" -> "));
    }
}

#[test]
fn the_graph_sees_the_crate() {
    // the reading finds the modules and their uses (else the test above proves nothing)
    let g = crate_graph();
    for m in [
        "crate::compare",
        "crate::compare::scan",
        "crate::canonical::resample",
        "crate::edt::tests",
        "crate::register",
        "crate::se2",
    ] {
        assert!(g.contains_key(m), "{m} not found");
    }
    let uses = |a: &str, b: &str| g.get(a).is_some_and(|s| s.contains(b));
    assert!(uses("crate::compare", "crate::register"));
    assert!(uses("crate::compare", "crate::compare::scan"));
    assert!(uses("crate::compare::resample", "crate::compare::scan"));
    assert!(uses("crate::compare::tests", "crate::edt::tests"));
    assert!(uses("crate::register", "crate::se2"));
    assert!(!uses("crate::register", "crate::compare"));
}

#[test]
fn a_cycle_is_found() {
    let files = vec![
        (
            "crate".to_string(),
            "pub mod a;\npub mod b;\n// use crate::a; (a comment)\n".to_string(),
        ),
        (
            "crate::a".to_string(),
            "mod inner {\n    use super::super::b::X;\n}\nuse crate::b::X;\n".to_string(),
        ),
        (
            "crate::b".to_string(),
            "pub struct X;\nfn f() { let _ = \"crate::a\"; }\nmod c;\n".to_string(),
        ),
        (
            "crate::b::c".to_string(),
            "use super::super::a;\n".to_string(),
        ),
    ];
    let g = graph_of(&files);
    assert!(g["crate::a::inner"].contains("crate::b"));
    assert!(g["crate"].is_empty(), "{:?}", g["crate"]);
    assert!(!g["crate::b"].contains("crate::a"), "a string is no use");
    assert_eq!(cycle(&g), None);
    let mut files = files;
    files[2].1.push_str("use self::c::Y;\n");
    let g = graph_of(&files);
    let c = cycle(&g).expect("a -> b -> b::c -> a");
    assert_eq!(c.first(), c.last());
    assert!(c.contains(&"crate::b::c".to_string()), "{c:?}");
}
