//! The module graph has no cycle (issue 26, item 1; docs/ARCHITECTURE.md's layers).
//!
//! Each folder under `src/` and each top-level file is a node, except an engine's folder
//! (`src/udec/`), whose folders and files are the nodes (`udec::model`, `udec::gpu`, …); an edge
//! A → B is a `crate::B…` path (or a `super::…` path that resolves into B, or `blockdem::B…` in
//! `main.rs`) written in A's code. Comments, doc comments, string and character literals and `#[cfg(test)]` items
//! are left out: a unit test may reach across layers, the library may not. The test reads the
//! source text, not the compiler's view, so it needs no extra dependency and names the file and
//! line of each edge that closes a cycle.

use std::collections::{BTreeMap, BTreeSet};
use std::fs;
use std::path::{Path, PathBuf};

/// One use of another module: where it is written.
#[derive(Clone, Debug)]
struct Site {
    file: PathBuf,
    line: usize,
}

/// The node → (node → first site) graph of `src/`.
type Graph = BTreeMap<String, BTreeMap<String, Site>>;

fn rust_files(dir: &Path, out: &mut Vec<PathBuf>) {
    let mut entries: Vec<_> = fs::read_dir(dir).expect("src/ readable").map(|e| e.expect("entry").path()).collect();
    entries.sort();
    for p in entries {
        if p.is_dir() {
            rust_files(&p, out);
        } else if p.extension().is_some_and(|e| e == "rs") {
            out.push(p);
        }
    }
}

/// The source with comments and the contents of string and character literals replaced by
/// spaces (newlines kept, so that line numbers stay right).
fn code_only(src: &str) -> String {
    let b: Vec<char> = src.chars().collect();
    let mut out = String::with_capacity(src.len());
    let blank = |c: char| if c == '\n' { '\n' } else { ' ' };
    let mut i = 0;
    while i < b.len() {
        let c = b[i];
        let next = b.get(i + 1).copied();
        if c == '/' && next == Some('/') {
            while i < b.len() && b[i] != '\n' {
                out.push(' ');
                i += 1;
            }
        } else if c == '/' && next == Some('*') {
            // Block comments nest in Rust.
            let mut depth = 0;
            while i < b.len() {
                if b[i] == '/' && b.get(i + 1) == Some(&'*') {
                    depth += 1;
                    out.push_str("  ");
                    i += 2;
                } else if b[i] == '*' && b.get(i + 1) == Some(&'/') {
                    depth -= 1;
                    out.push_str("  ");
                    i += 2;
                    if depth == 0 {
                        break;
                    }
                } else {
                    out.push(blank(b[i]));
                    i += 1;
                }
            }
        } else if c == 'r' && (next == Some('"') || next == Some('#')) && (i == 0 || !is_ident(b[i - 1])) {
            // A raw string r"…" or r#"…"#: it ends at a quote followed by as many hashes.
            let mut j = i + 1;
            let mut hashes = 0;
            while b.get(j) == Some(&'#') {
                hashes += 1;
                j += 1;
            }
            if b.get(j) != Some(&'"') {
                out.push(c);
                i += 1;
                continue;
            }
            out.push(' ');
            i += 1;
            while i <= j {
                out.push(' ');
                i += 1;
            }
            while i < b.len() {
                if b[i] == '"' && (1..=hashes).all(|k| b.get(i + k) == Some(&'#')) {
                    for _ in 0..=hashes {
                        out.push(' ');
                    }
                    i += 1 + hashes;
                    break;
                }
                out.push(blank(b[i]));
                i += 1;
            }
        } else if c == '"' {
            out.push(' ');
            i += 1;
            while i < b.len() && b[i] != '"' {
                if b[i] == '\\' {
                    out.push(' ');
                    i += 1;
                }
                if i < b.len() {
                    out.push(blank(b[i]));
                    i += 1;
                }
            }
            out.push(' ');
            i += 1;
        } else if c == '\'' {
            // A character literal ('x', '\n', '\u{…}') or a lifetime ('a): only the first is blanked.
            if next == Some('\\') {
                let mut j = i + 2;
                while j < b.len() && b[j] != '\'' {
                    j += 1;
                }
                for _ in i..=j.min(b.len() - 1) {
                    out.push(' ');
                }
                i = j + 1;
            } else if b.get(i + 2) == Some(&'\'') {
                out.push_str("   ");
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

fn is_ident(c: char) -> bool {
    c.is_alphanumeric() || c == '_'
}

/// `code` with every `#[cfg(test)]` item blanked: from the attribute to the `;` or the brace
/// that closes the item's first `{`.
fn without_test_items(code: &str) -> String {
    let mut out: Vec<char> = code.chars().collect();
    let len = out.len();
    let text: String = out.iter().collect();
    let mut starts = Vec::new();
    let mut from = 0;
    while let Some(k) = text[from..].find("#[cfg(test)]") {
        starts.push(text[..from + k].chars().count());
        from += k + 1;
    }
    for s in starts {
        let mut i = s;
        let mut depth = 0usize;
        while i < out.len() {
            match out[i] {
                '{' => depth += 1,
                '}' => {
                    depth -= 1;
                    if depth == 0 {
                        break;
                    }
                }
                ';' if depth == 0 => break,
                _ => {}
            }
            i += 1;
        }
        for c in out.iter_mut().take((i + 1).min(len)).skip(s) {
            if *c != '\n' {
                *c = ' ';
            }
        }
    }
    out.into_iter().collect()
}

/// The module path of a file under `src/`: `cpu/mod.rs` → [cpu], `cpu/gather.rs` → [cpu, gather].
fn module_path(rel: &Path) -> Vec<String> {
    let mut parts: Vec<String> = rel.iter().map(|p| p.to_string_lossy().into_owned()).collect();
    let last = parts.pop().expect("a file");
    let stem = last.trim_end_matches(".rs");
    if stem != "mod" && stem != "lib" && stem != "main" {
        parts.push(stem.to_string());
    }
    parts
}

/// The folders under `src/` that hold an engine: their modules are nodes of their own.
const ENGINES: [&str; 2] = ["udec", "d3"];

/// The modules of the chassis, dimension-free (issue 26, item 7): none of them may name an
/// engine's module.
const CHASSIS: [&str; 5] = ["deck", "driver", "gpu", "output", "profile"];

/// The node a module path belongs to: its first part, or an engine's module.
fn node_of(path: &[String]) -> Option<String> {
    let first = path.first()?;
    if ENGINES.contains(&first.as_str()) {
        return Some(match path.get(1) {
            Some(m) => format!("{first}::{m}"),
            None => first.clone(),
        });
    }
    Some(first.clone())
}

/// The first identifier at `s[i..]` (after spaces), and where it ends.
fn ident_at(s: &[char], mut i: usize) -> Option<(String, usize)> {
    while i < s.len() && s[i].is_whitespace() {
        i += 1;
    }
    let start = i;
    while i < s.len() && is_ident(s[i]) {
        i += 1;
    }
    (i > start).then(|| (s[start..i].iter().collect(), i))
}

/// The first identifier of each top-level item of the `{…}` group that opens at `s[i]`.
fn group_heads(s: &[char], i: usize) -> Vec<String> {
    let mut heads = Vec::new();
    let mut depth = 0;
    let mut expect_head = true;
    let mut j = i;
    while j < s.len() {
        match s[j] {
            '{' => {
                depth += 1;
                if depth == 1 {
                    expect_head = true;
                }
            }
            '}' => {
                depth -= 1;
                if depth == 0 {
                    break;
                }
            }
            ',' if depth == 1 => expect_head = true,
            c if depth == 1 && expect_head && is_ident(c) => {
                if let Some((id, end)) = ident_at(s, j) {
                    heads.push(id);
                    j = end;
                    expect_head = false;
                    continue;
                }
            }
            _ => {}
        }
        j += 1;
    }
    heads
}

/// The module paths, one or two parts long, that a path starting at `base` names at `s[i..]`
/// (after `crate::` or `super::`): one part, or two where the first is an engine's folder.
fn roots_at(s: &[char], i: usize, base: &[String]) -> Vec<Vec<String>> {
    let mut j = i;
    while j < s.len() && s[j].is_whitespace() {
        j += 1;
    }
    let with = |id: String| {
        let mut p = base.to_vec();
        p.push(id);
        p
    };
    if s.get(j) == Some(&'{') {
        return group_heads(s, j).into_iter().map(with).collect();
    }
    let Some((id, end)) = ident_at(s, j) else { return Vec::new() };
    let path = with(id);
    if path.len() == 1 && ENGINES.contains(&path[0].as_str()) && s[end..].iter().take(2).copied().eq("::".chars()) {
        let deeper = roots_at(s, end + 2, &path);
        if !deeper.is_empty() {
            return deeper;
        }
    }
    vec![path]
}

fn graph(src: &Path) -> Graph {
    let mut files = Vec::new();
    rust_files(src, &mut files);
    let nodes: BTreeSet<String> = files.iter().filter_map(|f| node_of(&module_path(f.strip_prefix(src).expect("under src")))).collect();
    let mut g: Graph = nodes.iter().map(|n| (n.clone(), BTreeMap::new())).collect();
    for file in &files {
        let rel = file.strip_prefix(src).expect("under src");
        let here = module_path(rel);
        let Some(node) = node_of(&here) else { continue }; // lib.rs only declares the modules
        let code = without_test_items(&code_only(&fs::read_to_string(file).expect("readable")));
        let s: Vec<char> = code.chars().collect();
        let line_of = |i: usize| s[..i].iter().filter(|&&c| c == '\n').count() + 1;
        let mut add = |path: Vec<String>, i: usize| {
            let Some(target) = node_of(&path) else { return };
            if target != node && nodes.contains(&target) {
                g.get_mut(&node).expect("node").entry(target).or_insert(Site { file: file.clone(), line: line_of(i) });
            }
        };
        let mut i = 0;
        while i < s.len() {
            let preceded_by_ident = i > 0 && (is_ident(s[i - 1]) || s[i - 1] == ':');
            let at = |w: &str| s[i..].iter().take(w.chars().count()).copied().eq(w.chars());
            if !preceded_by_ident && (at("crate::") || (node == "main" && at("blockdem::"))) {
                let len = if at("crate::") { 7 } else { 10 };
                for t in roots_at(&s, i + len, &[]) {
                    add(t, i);
                }
                i += len;
            } else if !preceded_by_ident && at("super::") {
                // Each `super::` climbs one module from the file's own module path.
                let mut up = 0;
                let mut j = i;
                while s[j..].iter().take(7).copied().eq("super::".chars()) {
                    up += 1;
                    j += 7;
                }
                let base = here.len().saturating_sub(up);
                for t in roots_at(&s, j, &here[..base]) {
                    add(t, i);
                }
                i = j;
            } else {
                i += 1;
            }
        }
    }
    g
}

/// Tarjan's strongly connected components of `g`.
fn components(g: &Graph) -> Vec<Vec<String>> {
    struct T<'a> {
        g: &'a Graph,
        index: BTreeMap<&'a str, usize>,
        low: BTreeMap<&'a str, usize>,
        stack: Vec<&'a str>,
        on: BTreeSet<&'a str>,
        out: Vec<Vec<String>>,
    }
    fn visit<'a>(t: &mut T<'a>, v: &'a str) {
        let n = t.index.len();
        t.index.insert(v, n);
        t.low.insert(v, n);
        t.stack.push(v);
        t.on.insert(v);
        for w in t.g[v].keys() {
            let w = w.as_str();
            if !t.index.contains_key(w) {
                visit(t, w);
                let lw = t.low[w];
                let lv = t.low.get_mut(v).expect("visited");
                *lv = (*lv).min(lw);
            } else if t.on.contains(w) {
                let iw = t.index[w];
                let lv = t.low.get_mut(v).expect("visited");
                *lv = (*lv).min(iw);
            }
        }
        if t.low[v] == t.index[v] {
            let mut c = Vec::new();
            loop {
                let w = t.stack.pop().expect("on the stack");
                t.on.remove(w);
                c.push(w.to_string());
                if w == v {
                    break;
                }
            }
            c.sort();
            t.out.push(c);
        }
    }
    let mut t = T { g, index: BTreeMap::new(), low: BTreeMap::new(), stack: Vec::new(), on: BTreeSet::new(), out: Vec::new() };
    for v in g.keys() {
        if !t.index.contains_key(v.as_str()) {
            visit(&mut t, v);
        }
    }
    t.out
}

#[test]
fn modules_form_no_cycle() {
    let src = Path::new(env!("CARGO_MANIFEST_DIR")).join("src");
    let g = graph(&src);
    let mut report = String::new();
    for c in components(&g).into_iter().filter(|c| c.len() > 1) {
        report.push_str(&format!("cycle among {}:\n", c.join(", ")));
        for a in &c {
            for (b, site) in &g[a] {
                if c.contains(b) {
                    let file = site.file.strip_prefix(&src).unwrap_or(&site.file).display();
                    report.push_str(&format!("  {a} -> {b}  (src/{file}:{})\n", site.line));
                }
            }
        }
    }
    assert!(report.is_empty(), "the module graph must have no cycle (docs/ARCHITECTURE.md):\n{report}");
}

/// The chassis stands apart from the engines (docs/ARCHITECTURE.md): a sibling engine (D3)
/// can take the deck lexer, the run driver, the GPU device and precision and the output
/// machinery as they are.
#[test]
fn the_chassis_names_no_engine() {
    let src = Path::new(env!("CARGO_MANIFEST_DIR")).join("src");
    let g = graph(&src);
    let mut report = String::new();
    for chassis in CHASSIS {
        assert!(g.contains_key(chassis), "no module {chassis} under src/");
        for (b, site) in &g[chassis] {
            if ENGINES.iter().any(|e| b == e || b.starts_with(&format!("{e}::"))) {
                let file = site.file.strip_prefix(&src).unwrap_or(&site.file).display();
                report.push_str(&format!("  {chassis} -> {b}  (src/{file}:{})\n", site.line));
            }
        }
    }
    assert!(report.is_empty(), "the chassis must not use an engine's modules:\n{report}");
}

/// The engines stand apart from each other (docs/ARCHITECTURE.md, "how to add an engine"): no
/// module of one engine names a module of another; what both need goes into the chassis.
#[test]
fn no_engine_names_another() {
    let src = Path::new(env!("CARGO_MANIFEST_DIR")).join("src");
    let g = graph(&src);
    let engine_of = |node: &str| ENGINES.iter().copied().find(|e| node == *e || node.starts_with(&format!("{e}::")));
    let mut report = String::new();
    for (a, edges) in &g {
        let Some(from) = engine_of(a) else { continue };
        for (b, site) in edges {
            if engine_of(b).is_some_and(|to| to != from) {
                let file = site.file.strip_prefix(&src).unwrap_or(&site.file).display();
                report.push_str(&format!("  {a} -> {b}  (src/{file}:{})\n", site.line));
            }
        }
    }
    assert!(report.is_empty(), "an engine must not use another engine's modules:\n{report}");
}

/// The scanner itself: comments, strings, test items and `super::` are read as the compiler would.
#[test]
fn the_scanner_reads_paths_as_the_compiler_does() {
    let dir = std::env::temp_dir().join(format!("blockdem-architecture-{}", std::process::id()));
    let _ = fs::remove_dir_all(&dir);
    fs::create_dir_all(dir.join("a")).expect("temp dir");
    fs::write(
        dir.join("a/mod.rs"),
        "// crate::b in a comment\n/* crate::c /* nested */ crate::c */\nconst S: &str = \"crate::c\";\nconst R: &str = r#\"crate::c\"#;\n\
         const Q: char = '\"';\nuse super::{b::x, d};\n#[cfg(test)]\nmod tests { use crate::c; }\nfn f<'a>(_: &'a u8) { crate::e::g(); }\n",
    )
    .expect("write");
    fs::write(dir.join("a/inner.rs"), "use super::sibling;\nuse super::super::f;\n").expect("write");
    for n in ["b", "c", "d", "e", "f"] {
        fs::write(dir.join(format!("{n}.rs")), "").expect("write");
    }
    let g = graph(&dir);
    let edges: Vec<&str> = g["a"].keys().map(String::as_str).collect();
    assert_eq!(edges, ["b", "d", "e", "f"]);
    assert_eq!(g["a"]["e"].line, 9);
    let _ = fs::remove_dir_all(&dir);
}
