//! The module graph (docs/ARCHITECTURE.md "Layers"): every `crate::` path in `src/` goes to a
//! module of the same or a lower layer, and the top-level modules import each other without a
//! cycle. The test reads the source text, so it fails as soon as someone adds an upward import.

use std::collections::{BTreeMap, BTreeSet};
use std::path::{Path, PathBuf};

/// The layers, lowest first: a module may use its own layer and the ones below.
const LAYERS: &[&[&str]] = &[
    &["error", "fsio", "heap"],
    &["photometry"],
    &["scene"],
    &["transport"],
    &["relight", "render", "metrics"],
    &["session", "accuracy"],
    &["report"],
    &["cli", "tui"],
];

fn layer_of(module: &str) -> Option<usize> {
    LAYERS.iter().position(|layer| layer.contains(&module))
}

fn rust_files(dir: &Path, out: &mut Vec<PathBuf>) {
    for entry in std::fs::read_dir(dir).unwrap() {
        let path = entry.unwrap().path();
        if path.is_dir() {
            rust_files(&path, out);
        } else if path.extension().is_some_and(|e| e == "rs") {
            out.push(path);
        }
    }
}

/// The top-level module a source file belongs to (`src/transport/bake.rs` → `transport`,
/// `src/relight.rs` → `relight`); `None` for the crate roots.
fn module_of(src: &Path, file: &Path) -> Option<String> {
    let relative = file.strip_prefix(src).unwrap();
    let first = relative
        .components()
        .next()?
        .as_os_str()
        .to_string_lossy()
        .into_owned();
    let name = first.strip_suffix(".rs").unwrap_or(&first).to_string();
    (!matches!(name.as_str(), "lib" | "main")).then_some(name)
}

/// The top-level modules named by `crate::…` paths in `text`, comments left out.
fn crate_paths(text: &str) -> BTreeSet<String> {
    let mut found = BTreeSet::new();
    for line in text.lines() {
        let code = line.split("//").next().unwrap_or("");
        let mut rest = code;
        while let Some(at) = rest.find("crate::") {
            let after = &rest[at + "crate::".len()..];
            let name: String = after
                .chars()
                .take_while(|c| c.is_ascii_alphanumeric() || *c == '_')
                .collect();
            if !name.is_empty() {
                found.insert(name);
            }
            rest = after;
        }
    }
    found
}

/// The import graph of the top-level modules of `src`.
fn imports(src: &Path) -> BTreeMap<String, BTreeSet<String>> {
    let mut files = Vec::new();
    rust_files(src, &mut files);
    let mut graph: BTreeMap<String, BTreeSet<String>> = BTreeMap::new();
    for file in files {
        let Some(module) = module_of(src, &file) else {
            continue;
        };
        let text = std::fs::read_to_string(&file).unwrap();
        let targets = graph.entry(module.clone()).or_default();
        for target in crate_paths(&text) {
            if target != module {
                targets.insert(target);
            }
        }
    }
    graph
}

#[test]
fn no_module_imports_from_a_higher_layer() {
    let src = Path::new(env!("CARGO_MANIFEST_DIR")).join("src");
    let graph = imports(&src);
    assert!(
        graph.contains_key("session") && graph.contains_key("tui"),
        "{graph:?}"
    );
    let mut violations = Vec::new();
    for (module, targets) in &graph {
        let layer = layer_of(module).unwrap_or_else(|| panic!("module `{module}` has no layer in LAYERS"));
        for target in targets {
            let target_layer = layer_of(target)
                .unwrap_or_else(|| panic!("`{module}` uses `crate::{target}`, which has no layer"));
            if target_layer > layer {
                violations.push(format!(
                    "{module} (layer {layer}) uses {target} (layer {target_layer})"
                ));
            }
        }
    }
    assert!(
        violations.is_empty(),
        "upward imports:\n{}",
        violations.join("\n")
    );
}

#[test]
fn the_top_level_modules_have_no_import_cycle() {
    let src = Path::new(env!("CARGO_MANIFEST_DIR")).join("src");
    let graph = imports(&src);
    // Depth-first search for a back edge.
    fn visit<'a>(
        node: &'a str,
        graph: &'a BTreeMap<String, BTreeSet<String>>,
        path: &mut Vec<&'a str>,
        done: &mut BTreeSet<&'a str>,
    ) -> Option<String> {
        if let Some(start) = path.iter().position(|&n| n == node) {
            return Some(format!("{} → {node}", path[start..].join(" → ")));
        }
        if !done.insert(node) {
            return None;
        }
        path.push(node);
        for next in graph.get(node).into_iter().flatten() {
            if let Some(cycle) = visit(next, graph, path, done) {
                return Some(cycle);
            }
        }
        path.pop();
        None
    }
    let mut done = BTreeSet::new();
    for module in graph.keys() {
        let mut path = Vec::new();
        if let Some(cycle) = visit(module, &graph, &mut path, &mut done) {
            panic!("import cycle: {cycle}");
        }
    }
}

/// The checker itself: it finds `crate::` paths in code, not in comments.
#[test]
fn crate_paths_are_read_from_code_only() {
    let text = "use crate::scene::{Scene, Light};\nlet x = crate::photometry::Curve::new(); // crate::tui\n/// [`crate::session`]\n";
    let found: Vec<String> = crate_paths(text).into_iter().collect();
    assert_eq!(found, ["photometry", "scene"]);
}
