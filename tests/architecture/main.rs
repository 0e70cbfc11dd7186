//! The layering of `src/` (issue 30 item 5, docs/architecture.md): no file imports a file that
//! imports it back. The graph is read from the sources, not from the compiler: each file's
//! `use crate::…`, `use super::…`, `use self::…`, a child module used by its bare name, and
//! `crate::…` / `super::…` paths in code, resolved to the deepest file they name. Test code
//! (`#[cfg(test)]` items) is left out, and so is a file's use of its own ancestors (a child
//! reading the shared types its parent `mod.rs` defines): what is checked is that no two
//! files depend on each other through the rest of the tree.

use std::collections::{BTreeMap, BTreeSet};
use std::path::{Path, PathBuf};

/// A module of one of the package's two crates: the library (`src/lib.rs`) or the command
/// (`src/main.rs` and `src/cli/`), by its path below the crate root.
#[derive(Clone, Debug, PartialEq, Eq, PartialOrd, Ord)]
struct Module {
    bin: bool,
    path: Vec<String>,
}

impl Module {
    fn file_name(&self, files: &BTreeMap<Module, String>) -> String {
        files
            .get(self)
            .cloned()
            .unwrap_or_else(|| format!("{:?}", self.path))
    }
}

/// The module a file under `src/` is, from its path (`a/mod.rs` and `a.rs` are `a`).
fn module_of(rel: &Path) -> Module {
    let mut path: Vec<String> = rel
        .iter()
        .map(|s| s.to_string_lossy().into_owned())
        .collect();
    let last = path.pop().expect("a file name");
    let stem = last.trim_end_matches(".rs").to_string();
    let bin = rel == Path::new("main.rs") || path.first().is_some_and(|p| p == "cli");
    if !matches!(stem.as_str(), "mod" | "lib" | "main") {
        path.push(stem);
    }
    Module { bin, path }
}

#[derive(Clone, Debug, PartialEq)]
enum Tok {
    Ident(String),
    Punct(char),
    /// `::`
    Sep,
}

/// The file's tokens with comments, string and character literals and lifetimes left out.
fn tokens(src: &str) -> Vec<Tok> {
    let c: Vec<char> = src.chars().collect();
    let mut out = Vec::new();
    let mut i = 0;
    while i < c.len() {
        let ch = c[i];
        if ch == '/' && c.get(i + 1) == Some(&'/') {
            while i < c.len() && c[i] != '\n' {
                i += 1;
            }
        } else if ch == '/' && c.get(i + 1) == Some(&'*') {
            let mut depth = 0;
            while i < c.len() {
                if c[i] == '/' && c.get(i + 1) == Some(&'*') {
                    depth += 1;
                    i += 2;
                } else if c[i] == '*' && c.get(i + 1) == Some(&'/') {
                    depth -= 1;
                    i += 2;
                    if depth == 0 {
                        break;
                    }
                } else {
                    i += 1;
                }
            }
        } else if ch == 'r'
            && matches!(c.get(i + 1), Some('#') | Some('"'))
            && raw_string_end(&c, i + 1).is_some()
        {
            i = raw_string_end(&c, i + 1).unwrap();
        } else if ch == 'b' && c.get(i + 1) == Some(&'r') && raw_string_end(&c, i + 2).is_some() {
            i = raw_string_end(&c, i + 2).unwrap();
        } else if ch == '"' {
            i += 1;
            while i < c.len() && c[i] != '"' {
                i += if c[i] == '\\' { 2 } else { 1 };
            }
            i += 1;
        } else if ch == '\'' {
            // A character literal ('a', '\n', '\u{..}') or a lifetime ('a): skip either.
            if c.get(i + 1) == Some(&'\\') {
                i += 3;
                while i < c.len() && c[i] != '\'' {
                    i += 1;
                }
                i += 1;
            } else if c.get(i + 2) == Some(&'\'') {
                i += 3;
            } else {
                i += 1;
                while i < c.len() && (c[i].is_alphanumeric() || c[i] == '_') {
                    i += 1;
                }
            }
        } else if ch.is_alphabetic() || ch == '_' {
            let start = i;
            while i < c.len() && (c[i].is_alphanumeric() || c[i] == '_') {
                i += 1;
            }
            out.push(Tok::Ident(c[start..i].iter().collect()));
        } else if ch.is_ascii_digit() {
            while i < c.len() && (c[i].is_alphanumeric() || c[i] == '_' || c[i] == '.') {
                i += 1;
            }
        } else if ch == ':' && c.get(i + 1) == Some(&':') {
            out.push(Tok::Sep);
            i += 2;
        } else {
            if !ch.is_whitespace() {
                out.push(Tok::Punct(ch));
            }
            i += 1;
        }
    }
    out
}

/// The index after a raw string starting at `c[i]` (`#…#"…"#…#` or `"…"`), if it is one.
fn raw_string_end(c: &[char], mut i: usize) -> Option<usize> {
    let mut hashes = 0;
    while c.get(i) == Some(&'#') {
        hashes += 1;
        i += 1;
    }
    if c.get(i) != Some(&'"') {
        return None;
    }
    i += 1;
    while i < c.len() {
        if c[i] == '"' && (1..=hashes).all(|k| c.get(i + k) == Some(&'#')) {
            return Some(i + 1 + hashes);
        }
        i += 1;
    }
    None
}

fn ident(t: Option<&Tok>) -> Option<&str> {
    match t {
        Some(Tok::Ident(s)) => Some(s),
        _ => None,
    }
}

/// The tokens without the items under `#[cfg(test)]` (a `mod tests { … }`, a `use`, a `fn`).
fn without_test_items(t: Vec<Tok>) -> Vec<Tok> {
    let attr = |i: usize| -> bool {
        let want = [
            Tok::Punct('#'),
            Tok::Punct('['),
            Tok::Ident("cfg".into()),
            Tok::Punct('('),
            Tok::Ident("test".into()),
            Tok::Punct(')'),
            Tok::Punct(']'),
        ];
        t.len() >= i + want.len() && t[i..i + want.len()] == want
    };
    let mut out = Vec::new();
    let mut i = 0;
    while i < t.len() {
        if !attr(i) {
            out.push(t[i].clone());
            i += 1;
            continue;
        }
        i += 7;
        // The item ends at its first `;` outside brackets, or with the `}` closing its body.
        let mut depth = 0i32;
        while i < t.len() {
            match t[i] {
                Tok::Punct('(') | Tok::Punct('[') => depth += 1,
                Tok::Punct(')') | Tok::Punct(']') => depth -= 1,
                Tok::Punct(';') if depth == 0 => {
                    i += 1;
                    break;
                }
                Tok::Punct('{') if depth == 0 => {
                    let mut braces = 0;
                    while i < t.len() {
                        match t[i] {
                            Tok::Punct('{') => braces += 1,
                            Tok::Punct('}') => braces -= 1,
                            _ => {}
                        }
                        i += 1;
                        if braces == 0 {
                            break;
                        }
                    }
                    break;
                }
                _ => {}
            }
            i += 1;
        }
    }
    out
}

/// A path a file names: where (inside which inline modules), the segments, the name it is
/// imported as, and whether it is a re-export (`pub use`), which makes no dependency.
#[derive(Clone, Debug)]
struct Named {
    inline: Vec<String>,
    path: Vec<String>,
    alias: Option<String>,
    reexport: bool,
}

/// The paths a `use` tree starting at `t[*i]` names, each with its alias; `*i` ends after it.
fn use_tree(
    t: &[Tok],
    i: &mut usize,
    prefix: &[String],
    out: &mut Vec<(Vec<String>, Option<String>)>,
) {
    let mut path = prefix.to_vec();
    let mut alias = None;
    loop {
        match t.get(*i) {
            Some(Tok::Ident(s)) if s == "as" => {
                alias = ident(t.get(*i + 1)).map(str::to_string);
                *i += 2;
                break;
            }
            Some(Tok::Ident(s)) if s == "self" && !path.is_empty() => *i += 1,
            Some(Tok::Ident(s)) => {
                path.push(s.clone());
                *i += 1;
            }
            Some(Tok::Sep) => *i += 1,
            Some(Tok::Punct('{')) => {
                *i += 1;
                while !matches!(t.get(*i), Some(Tok::Punct('}')) | None) {
                    use_tree(t, i, &path, out);
                    if t.get(*i) == Some(&Tok::Punct(',')) {
                        *i += 1;
                    }
                }
                *i += 1;
                return;
            }
            Some(Tok::Punct('*')) => {
                path.push("*".into());
                *i += 1;
            }
            _ => break,
        }
    }
    out.push((path, alias));
}

/// Whether the `use` at `t[i]` is a re-export: `pub use`, `pub(crate) use`, `pub(super) use`.
fn is_reexport(t: &[Tok], i: usize) -> bool {
    if i >= 1 && ident(t.get(i - 1)) == Some("pub") {
        return true;
    }
    if i >= 1 && t[i - 1] == Tok::Punct(')') {
        let open = t[..i - 1].iter().rposition(|x| *x == Tok::Punct('('));
        return open.is_some_and(|o| o >= 1 && ident(t.get(o - 1)) == Some("pub"));
    }
    false
}

/// Every path the file names that may lead to another file of its crate: `use` trees, and in
/// code the paths starting with `crate`, `super` or `self` or with a child module's name.
fn paths(t: &[Tok], children: &BTreeSet<String>) -> Vec<Named> {
    let mut out = Vec::new();
    let mut inline: Vec<(String, i32)> = Vec::new();
    let mut depth = 0;
    let mut i = 0;
    while i < t.len() {
        let here: Vec<String> = inline.iter().map(|(m, _)| m.clone()).collect();
        match &t[i] {
            Tok::Punct('{') => depth += 1,
            Tok::Punct('}') => {
                depth -= 1;
                if inline.last().is_some_and(|(_, d)| *d == depth) {
                    inline.pop();
                }
            }
            Tok::Ident(k) if k == "mod" => {
                if let (Some(name), Some(Tok::Punct('{'))) = (ident(t.get(i + 1)), t.get(i + 2)) {
                    inline.push((name.to_string(), depth));
                }
            }
            Tok::Ident(k) if k == "use" => {
                let reexport = is_reexport(t, i);
                i += 1;
                let mut found = Vec::new();
                use_tree(t, &mut i, &[], &mut found);
                out.extend(found.into_iter().map(|(path, alias)| Named {
                    inline: here.clone(),
                    path,
                    alias,
                    reexport,
                }));
                continue;
            }
            Tok::Ident(first)
                if t.get(i + 1) == Some(&Tok::Sep) && (i == 0 || t[i - 1] != Tok::Sep) =>
            {
                let rooted = matches!(first.as_str(), "crate" | "super" | "self");
                // `pub(in crate::x)` names a visibility, not a dependency.
                let visibility = i >= 1 && ident(t.get(i - 1)) == Some("in");
                if (rooted || children.contains(first)) && !visibility {
                    let mut path = vec![first.clone()];
                    let mut j = i + 1;
                    while t.get(j) == Some(&Tok::Sep) {
                        match ident(t.get(j + 1)) {
                            Some(s) => path.push(s.to_string()),
                            None => break,
                        }
                        j += 2;
                    }
                    out.push(Named {
                        inline: here.clone(),
                        path,
                        alias: None,
                        reexport: false,
                    });
                    i = j;
                    continue;
                }
            }
            _ => {}
        }
        i += 1;
    }
    out
}

/// The names each module (a file, or an inline module inside one, by its full path)
/// re-exports: name → (the file, the inline modules, the path re-exported).
type Reexports =
    BTreeMap<(bool, Vec<String>), BTreeMap<String, (Module, Vec<String>, Vec<String>)>>;

/// `path`, named inside `inline` modules of `from`, as segments from its crate's root; `None`
/// for a path of another crate (`std::…`, `serde::…`).
fn absolute(
    from: &Module,
    inline: &[String],
    path: &[String],
    files: &BTreeMap<Module, String>,
    reexports: &Reexports,
) -> Option<Vec<String>> {
    let mut base: Vec<String> = from.path.iter().chain(inline).cloned().collect();
    let mut segs = path;
    match segs.first().map(String::as_str) {
        Some("crate") => {
            base.clear();
            segs = &segs[1..];
        }
        Some("self") => segs = &segs[1..],
        Some("super") => {
            while segs.first().is_some_and(|s| s == "super") {
                base.pop()?;
                segs = &segs[1..];
            }
        }
        // A relative path: its first name must be a module (a file, or an inline module with
        // re-exports) below `base`, else it is another crate's.
        _ => {
            let first: Vec<String> = base.iter().chain(&segs[..1]).cloned().collect();
            let known = files.contains_key(&Module {
                bin: from.bin,
                path: first.clone(),
            }) || reexports.contains_key(&(from.bin, first));
            if !known {
                return None;
            }
        }
    }
    Some(base.into_iter().chain(segs.iter().cloned()).collect())
}

/// The module file that an absolute path leads to: through the re-exports it passes, to the
/// deepest file it names.
fn resolve(
    bin: bool,
    abs: &[String],
    files: &BTreeMap<Module, String>,
    reexports: &Reexports,
    hops: usize,
) -> Option<Module> {
    if hops < 16 {
        for k in (0..abs.len()).rev() {
            let entry = reexports
                .get(&(bin, abs[..k].to_vec()))
                .and_then(|m| m.get(&abs[k]));
            if let Some((file, inline, target)) = entry {
                if let Some(mut next) = absolute(file, inline, target, files, reexports) {
                    next.extend(abs[k + 1..].iter().cloned());
                    return resolve(bin, &next, files, reexports, hops + 1);
                }
            }
        }
    }
    let mut best = None;
    let mut cand = Module {
        bin,
        path: Vec::new(),
    };
    for s in abs {
        cand.path.push(s.clone());
        if files.contains_key(&cand) {
            best = Some(cand.clone());
        }
    }
    best.or_else(|| {
        files
            .contains_key(&Module {
                bin,
                path: Vec::new(),
            })
            .then(|| Module {
                bin,
                path: Vec::new(),
            })
    })
}

/// The dependency graph between the files `sources` (path below `src/`, text).
fn graph(
    sources: &[(PathBuf, String)],
) -> (BTreeMap<Module, String>, BTreeMap<Module, BTreeSet<Module>>) {
    let files: BTreeMap<Module, String> = sources
        .iter()
        .map(|(p, _)| (module_of(p), format!("src/{}", p.display())))
        .collect();
    let named: Vec<(Module, Vec<Named>)> = sources
        .iter()
        .map(|(p, text)| {
            let from = module_of(p);
            let children: BTreeSet<String> = files
                .keys()
                .filter(|m| {
                    m.bin == from.bin
                        && m.path.len() == from.path.len() + 1
                        && m.path.starts_with(&from.path)
                })
                .map(|m| m.path.last().unwrap().clone())
                .collect();
            let found = paths(&without_test_items(tokens(text)), &children);
            (from, found)
        })
        .collect();
    let mut reexports = Reexports::new();
    for (from, found) in &named {
        for n in found.iter().filter(|n| n.reexport) {
            let Some(name) = n.alias.clone().or_else(|| n.path.last().cloned()) else {
                continue;
            };
            if name == "*" || name == "_" {
                continue;
            }
            let module: Vec<String> = from.path.iter().chain(&n.inline).cloned().collect();
            reexports
                .entry((from.bin, module))
                .or_default()
                .insert(name, (from.clone(), n.inline.clone(), n.path.clone()));
        }
    }
    let mut edges: BTreeMap<Module, BTreeSet<Module>> = BTreeMap::new();
    for (from, found) in &named {
        for n in found.iter().filter(|n| !n.reexport) {
            let Some(abs) = absolute(from, &n.inline, &n.path, &files, &reexports) else {
                continue;
            };
            let Some(to) = resolve(from.bin, &abs, &files, &reexports, 0) else {
                continue;
            };
            let ancestor = to.path.len() < from.path.len() && from.path.starts_with(&to.path);
            if to != *from && !ancestor {
                edges.entry(from.clone()).or_default().insert(to);
            }
        }
    }
    (files, edges)
}

/// Tarjan's strongly connected components of a graph given by successor lists.
struct Tarjan<'a> {
    succ: &'a [Vec<usize>],
    index: Vec<usize>,
    low: Vec<usize>,
    on_stack: Vec<bool>,
    stack: Vec<usize>,
    next: usize,
    components: Vec<Vec<usize>>,
}

impl Tarjan<'_> {
    fn visit(&mut self, v: usize) {
        self.index[v] = self.next;
        self.low[v] = self.next;
        self.next += 1;
        self.stack.push(v);
        self.on_stack[v] = true;
        for &w in &self.succ[v] {
            if self.index[w] == usize::MAX {
                self.visit(w);
                self.low[v] = self.low[v].min(self.low[w]);
            } else if self.on_stack[w] {
                self.low[v] = self.low[v].min(self.index[w]);
            }
        }
        if self.low[v] == self.index[v] {
            let mut component = Vec::new();
            loop {
                let w = self.stack.pop().unwrap();
                self.on_stack[w] = false;
                component.push(w);
                if w == v {
                    break;
                }
            }
            self.components.push(component);
        }
    }
}

/// The strongly connected components of more than one file, each as one cycle through it
/// spelled out file by file (the shortest way back to its first file).
fn cycles(edges: &BTreeMap<Module, BTreeSet<Module>>) -> Vec<Vec<Module>> {
    let nodes: Vec<&Module> = edges
        .keys()
        .chain(edges.values().flatten())
        .collect::<BTreeSet<_>>()
        .into_iter()
        .collect();
    let index_of: BTreeMap<&Module, usize> =
        nodes.iter().enumerate().map(|(k, m)| (*m, k)).collect();
    let succ: Vec<Vec<usize>> = nodes
        .iter()
        .map(|m| {
            edges
                .get(*m)
                .map(|s| s.iter().map(|w| index_of[w]).collect())
                .unwrap_or_default()
        })
        .collect();
    let n = nodes.len();
    let mut tarjan = Tarjan {
        succ: &succ,
        index: vec![usize::MAX; n],
        low: vec![0; n],
        on_stack: vec![false; n],
        stack: Vec::new(),
        next: 0,
        components: Vec::new(),
    };
    for v in 0..n {
        if tarjan.index[v] == usize::MAX {
            tarjan.visit(v);
        }
    }
    let components: Vec<Vec<usize>> = tarjan
        .components
        .into_iter()
        .filter(|c| c.len() > 1)
        .collect();
    components
        .into_iter()
        .map(|component| {
            let inside: BTreeSet<usize> = component.iter().copied().collect();
            let start = *component.iter().min().unwrap();
            let mut prev = vec![usize::MAX; n];
            let mut queue = std::collections::VecDeque::from([start]);
            let mut end = start;
            'search: while let Some(v) = queue.pop_front() {
                for &w in &succ[v] {
                    if w == start {
                        end = v;
                        break 'search;
                    }
                    if inside.contains(&w) && prev[w] == usize::MAX {
                        prev[w] = v;
                        queue.push_back(w);
                    }
                }
            }
            let mut cycle = vec![end];
            while *cycle.last().unwrap() != start {
                cycle.push(prev[*cycle.last().unwrap()]);
            }
            cycle.reverse();
            cycle.into_iter().map(|k| nodes[k].clone()).collect()
        })
        .collect()
}

fn rust_files(dir: &Path, root: &Path, out: &mut Vec<(PathBuf, String)>) {
    for entry in std::fs::read_dir(dir).unwrap() {
        let p = entry.unwrap().path();
        if p.is_dir() {
            rust_files(&p, root, out);
        } else if p.extension().is_some_and(|e| e == "rs") {
            let text = std::fs::read_to_string(&p).unwrap();
            out.push((p.strip_prefix(root).unwrap().to_path_buf(), text));
        }
    }
}

fn describe(cycles: &[Vec<Module>], files: &BTreeMap<Module, String>) -> String {
    cycles
        .iter()
        .map(|c| {
            let mut names: Vec<String> = c.iter().map(|m| m.file_name(files)).collect();
            names.push(names[0].clone());
            names.join(" -> ")
        })
        .collect::<Vec<_>>()
        .join("\n")
}

#[test]
fn no_file_of_src_imports_a_file_that_imports_it_back() {
    let root = Path::new(env!("CARGO_MANIFEST_DIR")).join("src");
    let mut sources = Vec::new();
    rust_files(&root, &root, &mut sources);
    let (files, edges) = graph(&sources);
    // The scan sees the layers it checks: the relaxed solve reads the bond network.
    let network = module_of(Path::new("homogenize/network.rs"));
    assert!(
        edges
            .get(&module_of(Path::new("homogenize/relaxed.rs")))
            .is_some_and(|s| s.contains(&network)),
        "the scan lost the use of homogenize/network.rs by homogenize/relaxed.rs"
    );
    let found = cycles(&edges);
    assert!(
        found.is_empty(),
        "import cycles between files of src/:\n{}",
        describe(&found, &files)
    );
}

/// The check fails on a cycle, whichever way it is written, and not on test code, a child's
/// use of its parent or a name in a string or comment.
#[test]
fn a_planted_cycle_is_found_and_named() {
    let src = |p: &str, t: &str| (PathBuf::from(p), t.to_string());
    let base = vec![
        src("lib.rs", "pub mod a;\npub mod b;\nmod c;\n"),
        src("a/mod.rs", "mod x;\nmod y;\npub use x::X;\npub use y::Y as Why;\n"),
        src("a/x.rs", "use super::Shared; pub struct X;\n"),
        src("a/y.rs", "pub struct Y(crate::b::B);\n"),
        src(
            "b.rs",
            "//! use crate::a::y;\nconst S: &str = \"crate::a::y\";\npub struct B(crate::a::X);\n#[cfg(test)]\nmod tests { use crate::a::y::Y; }\n",
        ),
        src("c.rs", "pub(in crate::a) struct C;\n"),
    ];
    let (files, edges) = graph(&base);
    assert!(
        cycles(&edges).is_empty(),
        "{}",
        describe(&cycles(&edges), &files)
    );
    for planted in [
        "use crate::a::{x::X, y};\npub struct B;\n",
        "use crate::a::y as why;\npub struct B(why::Y);\n",
        "pub fn f() -> crate::a::y::Y { todo!() }\n",
        "mod inner { use super::super::a::{self, y::Y}; }\n",
        "use crate::a::Why;\npub struct B(Why);\n",
    ] {
        let mut sources = base.clone();
        sources[4] = src("b.rs", planted);
        let (files, edges) = graph(&sources);
        let text = describe(&cycles(&edges), &files);
        assert!(
            text.contains("src/b.rs") && text.contains("src/a/y.rs"),
            "{planted:?}: {text:?}"
        );
    }
}
