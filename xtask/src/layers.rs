//! `cargo xtask layers [--json]`: the shape of the code, checked.
//!
//! - **Layers** (`../shared/docs/design.md`): the library's rooms, bottom up — 1: `units`,
//!   `fmath`, `angle`, `fmt`; 2: `wire`; 3: `design`, `gate`, `logodds`, `decay`, `grid`, `pyramid`,
//!   `geometry`, `classify`; 4: `pipeline`, `link`, `app`; 5: `drivers`. A module may use its
//!   own layer and those below; `wire` uses nothing but layer 1.
//! - **No import cycle** between the modules (files) of the library, of the `pyramid` tool
//!   (`host/src`) or of the lab (`lab/src`): a module that names another (`use crate::…`,
//!   `super::…`, or a path in code) depends on it; a module and its own parent or child are
//!   not counted (a parent re-exports its children, a child uses its parent's items).
//! - **One definition per public type name** in the library (`pub struct|enum|trait|type`).
//!
//! `--root DIR` checks another checkout (to measure a tree before a change).
//!
//! It reads the sources as text (every `crate::`/`super::` path, in `use` lists and in code,
//! resolved to the deepest module file that exists), prints what it found, and fails on any
//! violation.
use crate::install::root;
use std::collections::{BTreeMap, BTreeSet};
use std::path::{Path, PathBuf};

/// A module as a path of names from its crate's root (`[]` is `lib.rs`/`main.rs`).
type ModPath = Vec<String>;

/// Every `.rs` file under `src`, by module path.
fn modules(src: &Path) -> BTreeMap<ModPath, PathBuf> {
    let mut out = BTreeMap::new();
    let mut stack = vec![src.to_path_buf()];
    while let Some(dir) = stack.pop() {
        let Ok(entries) = std::fs::read_dir(&dir) else {
            continue;
        };
        for entry in entries.flatten() {
            let path = entry.path();
            if path.is_dir() {
                stack.push(path);
                continue;
            }
            if path.extension().is_none_or(|e| e != "rs") {
                continue;
            }
            let Ok(rel) = path.strip_prefix(src) else {
                continue;
            };
            let mut parts: Vec<String> = rel
                .components()
                .map(|c| c.as_os_str().to_string_lossy().into_owned())
                .collect();
            let Some(last) = parts.pop() else { continue };
            let stem = last.trim_end_matches(".rs").to_string();
            // Test files (`tests.rs`) belong to their parent's tests, not to its code.
            if stem == "tests" {
                continue;
            }
            if !matches!(stem.as_str(), "mod" | "lib" | "main") {
                parts.push(stem);
            }
            out.insert(parts, path);
        }
    }
    out
}

/// The source without comments, string literals and `#[cfg(test)]` modules (a crude lexer:
/// enough for paths). A test module is cut from its attribute to its closing brace, so the
/// code after it still counts.
fn code_of(text: &str) -> String {
    let mut out = String::with_capacity(text.len());
    let mut chars = text.chars().peekable();
    while let Some(c) = chars.next() {
        match c {
            '/' if chars.peek() == Some(&'/') => {
                for c in chars.by_ref() {
                    if c == '\n' {
                        out.push('\n');
                        break;
                    }
                }
            }
            '"' => {
                let mut escaped = false;
                for c in chars.by_ref() {
                    if escaped {
                        escaped = false;
                    } else if c == '\\' {
                        escaped = true;
                    } else if c == '"' {
                        break;
                    }
                }
                out.push_str("\"\"");
            }
            _ => out.push(c),
        }
    }
    without_test_modules(&out)
}

/// `code` (comments and strings already removed) without its `#[cfg(test)]` modules: from
/// each `#[cfg(test)]` followed by a `mod` item to the item's matching closing brace (or its
/// `;`, for a module in its own file).
fn without_test_modules(code: &str) -> String {
    const ATTRIBUTE: &str = "#[cfg(test)]";
    let mut out = String::with_capacity(code.len());
    let mut rest = code;
    while let Some(at) = rest.find(ATTRIBUTE) {
        let after = &rest[at + ATTRIBUTE.len()..];
        let item = after.trim_start();
        let item = item.strip_prefix("pub(crate)").unwrap_or(item).trim_start();
        if !item.starts_with("mod ") {
            out.push_str(&rest[..at + ATTRIBUTE.len()]);
            rest = after;
            continue;
        }
        out.push_str(&rest[..at]);
        let Some(open) = after.find(['{', ';']) else {
            return out;
        };
        if after[open..].starts_with(';') {
            rest = &after[open + 1..];
            continue;
        }
        let mut depth = 0_usize;
        let mut end = after.len();
        let body = &after[open..];
        for (i, c) in body.char_indices() {
            // A brace in a character literal ('{') is not a block's.
            let quoted = body[..i].ends_with('\'') && body[i + 1..].starts_with('\'');
            match c {
                '{' if !quoted => depth += 1,
                '}' if !quoted => {
                    depth = depth.saturating_sub(1);
                    if depth == 0 {
                        end = open + i + 1;
                        break;
                    }
                }
                _ => {}
            }
        }
        rest = &after[end..];
    }
    out.push_str(rest);
    out
}

/// Expands `use` trees into full paths: `use crate::a::{b, c::{d, e}};` gives `crate::a::b`,
/// `crate::a::c::d`, `crate::a::c::e`; plus every `crate::x::y` or `super::x` path in code.
fn paths_in(code: &str) -> Vec<String> {
    let mut out = Vec::new();
    // `use` statements, braces expanded.
    let mut rest = code;
    while let Some(at) = rest.find("use ") {
        let before = rest[..at].chars().last();
        rest = &rest[at + 4..];
        if before.is_some_and(|c| c.is_alphanumeric() || c == '_') {
            continue;
        }
        let Some(end) = rest.find(';') else { break };
        let tree: String = rest[..end].chars().filter(|c| !c.is_whitespace()).collect();
        expand("", &tree, &mut out);
        rest = &rest[end..];
    }
    // Paths in code.
    for prefix in ["crate::", "super::"] {
        let mut rest = code;
        while let Some(at) = rest.find(prefix) {
            let before = rest[..at].chars().last();
            let tail = &rest[at..];
            let len = tail
                .find(|c: char| !(c.is_alphanumeric() || c == '_' || c == ':'))
                .unwrap_or(tail.len());
            if !before.is_some_and(|c| c.is_alphanumeric() || c == '_') {
                out.push(tail[..len].trim_end_matches(':').to_string());
            }
            rest = &rest[at + prefix.len()..];
        }
    }
    out
}

/// One `use` tree (no whitespace) under `prefix`.
fn expand(prefix: &str, tree: &str, out: &mut Vec<String>) {
    let join = |a: &str, b: &str| {
        if a.is_empty() {
            b.to_string()
        } else {
            format!("{a}::{b}")
        }
    };
    match tree.find('{') {
        None => {
            let item = tree.split(" as ").next().unwrap_or(tree);
            let item = item.split("as").next().unwrap_or(item);
            out.push(join(prefix, item.trim_end_matches("::*")));
        }
        Some(open) => {
            let head = tree[..open].trim_end_matches("::");
            let inner = &tree[open + 1..tree.rfind('}').unwrap_or(tree.len())];
            let base = join(prefix, head);
            // Split at top-level commas.
            let (mut depth, mut start) = (0, 0);
            for (i, c) in inner.char_indices() {
                match c {
                    '{' => depth += 1,
                    '}' => depth -= 1,
                    ',' if depth == 0 => {
                        expand(&base, &inner[start..i], out);
                        start = i + 1;
                    }
                    _ => {}
                }
            }
            if start < inner.len() {
                expand(&base, &inner[start..], out);
            }
        }
    }
}

/// The module a path names, from module `from`: the deepest module file along it.
fn target(
    path: &str,
    from: &ModPath,
    files: &BTreeMap<ModPath, PathBuf>,
    own: &ModPath,
) -> Option<ModPath> {
    let parts: Vec<&str> = path.split("::").filter(|p| !p.is_empty()).collect();
    let mut base: ModPath = match parts.first() {
        Some(&"crate") => Vec::new(),
        Some(&"super") => {
            // `super` of a `mod.rs`/file module is its parent.
            let mut p = from.clone();
            p.pop();
            p
        }
        _ => return None,
    };
    let mut best = None;
    for part in parts.iter().skip(1) {
        if *part == "super" {
            base.pop();
            continue;
        }
        base.push((*part).to_string());
        if files.contains_key(&base) {
            best = Some(base.clone());
        }
    }
    let _ = own;
    best
}

/// Whether `a` is an ancestor of `b` (or equal).
fn is_ancestor(a: &ModPath, b: &ModPath) -> bool {
    a.len() <= b.len() && a.iter().zip(b).all(|(x, y)| x == y)
}

/// The module graph of one crate: edges between modules that are not parent and child.
fn graph(
    src: &Path,
) -> (
    BTreeMap<ModPath, PathBuf>,
    BTreeMap<ModPath, BTreeSet<ModPath>>,
) {
    let files = modules(src);
    let mut edges: BTreeMap<ModPath, BTreeSet<ModPath>> = BTreeMap::new();
    for (m, path) in &files {
        let Ok(text) = std::fs::read_to_string(path) else {
            continue;
        };
        let code = code_of(&text);
        let set = edges.entry(m.clone()).or_default();
        for p in paths_in(&code) {
            if let Some(t) = target(&p, m, &files, m) {
                if !is_ancestor(&t, m) && !is_ancestor(m, &t) {
                    set.insert(t);
                }
            }
        }
    }
    (files, edges)
}

/// Strongly connected components of more than one module (Tarjan's algorithm).
fn cycles(edges: &BTreeMap<ModPath, BTreeSet<ModPath>>) -> Vec<Vec<ModPath>> {
    struct State<'a> {
        edges: &'a BTreeMap<ModPath, BTreeSet<ModPath>>,
        index: BTreeMap<ModPath, usize>,
        low: BTreeMap<ModPath, usize>,
        stack: Vec<ModPath>,
        on: BTreeSet<ModPath>,
        next: usize,
        out: Vec<Vec<ModPath>>,
    }
    fn visit(v: &ModPath, s: &mut State<'_>) {
        s.index.insert(v.clone(), s.next);
        s.low.insert(v.clone(), s.next);
        s.next += 1;
        s.stack.push(v.clone());
        s.on.insert(v.clone());
        let succ: Vec<ModPath> = s
            .edges
            .get(v)
            .map(|e| e.iter().cloned().collect())
            .unwrap_or_default();
        for w in succ {
            if !s.index.contains_key(&w) {
                visit(&w, s);
                let lw = s.low[&w];
                let lv = s.low[v];
                s.low.insert(v.clone(), lv.min(lw));
            } else if s.on.contains(&w) {
                let iw = s.index[&w];
                let lv = s.low[v];
                s.low.insert(v.clone(), lv.min(iw));
            }
        }
        if s.low[v] == s.index[v] {
            let mut component = Vec::new();
            while let Some(w) = s.stack.pop() {
                s.on.remove(&w);
                let done = &w == v;
                component.push(w);
                if done {
                    break;
                }
            }
            if component.len() > 1 {
                s.out.push(component);
            }
        }
    }
    let mut s = State {
        edges,
        index: BTreeMap::new(),
        low: BTreeMap::new(),
        stack: Vec::new(),
        on: BTreeSet::new(),
        next: 0,
        out: Vec::new(),
    };
    for v in edges.keys() {
        if !s.index.contains_key(v) {
            visit(v, &mut s);
        }
    }
    s.out
}

/// The layer of a library module (by its top-level room).
fn layer(m: &ModPath) -> Option<u8> {
    Some(match m.first().map(String::as_str)? {
        "units" | "fmath" | "angle" | "fmt" => 1,
        "wire" => 2,
        "design" | "gate" | "logodds" | "decay" | "grid" | "pyramid" | "geometry" | "classify" => 3,
        "pipeline" | "link" | "app" => 4,
        "drivers" => 5,
        _ => return None,
    })
}

fn name(m: &ModPath) -> String {
    if m.is_empty() {
        "(root)".into()
    } else {
        m.join("::")
    }
}

/// Public type names defined more than once in the library, with where.
fn duplicate_types(files: &BTreeMap<ModPath, PathBuf>) -> BTreeMap<String, Vec<String>> {
    let mut defs: BTreeMap<String, Vec<String>> = BTreeMap::new();
    for (m, path) in files {
        let Ok(text) = std::fs::read_to_string(path) else {
            continue;
        };
        for line in code_of(&text).lines() {
            for kind in ["pub struct ", "pub enum ", "pub trait ", "pub type "] {
                if let Some(rest) = line.strip_prefix(kind) {
                    let ident: String = rest
                        .chars()
                        .take_while(|c| c.is_alphanumeric() || *c == '_')
                        .collect();
                    if !ident.is_empty() {
                        defs.entry(ident).or_default().push(name(m));
                    }
                }
            }
        }
    }
    defs.retain(|_, v| v.len() > 1);
    defs
}

/// `cargo xtask layers [--json] [--root DIR]` (`--root`: another checkout, to compare).
pub fn task(args: &[String]) -> Result<(), String> {
    let mut json = false;
    let mut root = root();
    let mut rest = args.iter();
    while let Some(a) = rest.next() {
        match a.as_str() {
            "--json" => json = true,
            "--root" => root = PathBuf::from(rest.next().ok_or("--root needs a directory")?),
            other => {
                return Err(format!(
                    "unknown option {other}; usage: cargo xtask layers [--json] [--root DIR]"
                ))
            }
        }
    }
    let mut failures = Vec::new();
    let (lib_files, lib_edges) = graph(&root.join("src"));
    // Layers.
    let mut upward = Vec::new();
    let mut wire_up = 0;
    for (m, targets) in &lib_edges {
        let Some(lm) = layer(m) else { continue };
        for t in targets {
            let Some(lt) = layer(t) else { continue };
            let bad = if lm == 2 { lt > 1 && lt != 2 } else { lt > lm };
            if bad {
                if lm == 2 {
                    wire_up += 1;
                }
                upward.push(format!(
                    "{} (layer {lm}) uses {} (layer {lt})",
                    name(m),
                    name(t)
                ));
            }
        }
    }
    for u in &upward {
        failures.push(format!("upward import: {u}"));
    }
    // Cycles.
    let mut all_cycles = Vec::new();
    for (krate, src) in [
        ("terrain-pyramid", "src"),
        ("pyramid", "host/src"),
        ("lab", "lab/src"),
    ] {
        let dir = root.join(src);
        if !dir.is_dir() {
            continue;
        }
        let edges = if src == "src" {
            lib_edges.clone()
        } else {
            graph(&dir).1
        };
        for c in cycles(&edges) {
            let names: Vec<String> = c.iter().map(name).collect();
            all_cycles.push(format!("{krate}: {}", names.join(" <-> ")));
        }
    }
    for c in &all_cycles {
        failures.push(format!("import cycle: {c}"));
    }
    // Duplicate type names.
    let dups = duplicate_types(&lib_files);
    for (n, wheres) in &dups {
        failures.push(format!(
            "type {n} is defined {} times: {}",
            wheres.len(),
            wheres.join(", ")
        ));
    }
    let edges: usize = lib_edges.values().map(BTreeSet::len).sum();
    if json {
        let report = serde_json::json!({
            "library_modules": lib_files.len(),
            "library_module_edges": edges,
            "upward_imports": upward,
            "imports_from_wire_into_the_core": wire_up,
            "import_cycles": all_cycles,
            "duplicate_type_names": dups,
            "ok": failures.is_empty(),
        });
        println!("{report}");
    } else {
        eprintln!(
            "layers: {} library modules, {edges} dependencies between them; \
             {} upward imports ({wire_up} from wire into the core), {} import cycles, \
             {} public type names defined twice",
            lib_files.len(),
            upward.len(),
            all_cycles.len(),
            dups.len()
        );
        for f in &failures {
            eprintln!("  {f}");
        }
    }
    if failures.is_empty() {
        Ok(())
    } else {
        Err(format!("{} violations", failures.len()))
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn use_trees_expand() {
        let mut out = Vec::new();
        expand("", "crate::a::{b,c::{d,e as f},g::*}", &mut out);
        assert_eq!(
            out,
            [
                "crate::a::b",
                "crate::a::c::d",
                "crate::a::c::e",
                "crate::a::g"
            ]
        );
    }

    #[test]
    fn code_after_a_test_module_still_counts() {
        let text = "use crate::a;\n#[cfg(test)]\nmod tests {\n    use crate::b;\n    \
                    fn f() { let c = '}'; }\n}\nuse crate::c;\n#[cfg(test)]\nmod other;\n\
                    use crate::d;\n";
        let paths: BTreeSet<String> = paths_in(&code_of(text)).into_iter().collect();
        assert_eq!(
            paths,
            BTreeSet::from(["crate::a", "crate::c", "crate::d"].map(String::from))
        );
    }

    #[test]
    fn a_cycle_is_found_and_a_chain_is_not() {
        let m = |s: &str| vec![s.to_string()];
        let mut edges = BTreeMap::new();
        edges.insert(m("a"), BTreeSet::from([m("b")]));
        edges.insert(m("b"), BTreeSet::from([m("c")]));
        edges.insert(m("c"), BTreeSet::new());
        assert!(cycles(&edges).is_empty());
        edges.insert(m("c"), BTreeSet::from([m("a")]));
        assert_eq!(cycles(&edges).len(), 1);
    }
}
