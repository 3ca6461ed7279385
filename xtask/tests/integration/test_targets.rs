//! Every test file is compiled, and each crate's integration tests link once.
//!
//! A crate's integration tests are the modules of one binary, `tests/integration/main.rs`:
//! cargo builds each file directly under `tests/` as a binary of its own, linked against the
//! crate and all its dependencies, and 88 such binaries took over a quarter of CI's clean build
//! (502 of 1,825 s of build time; 237 s as one binary per crate). A file stays a
//! binary of its own only when it needs a process of its own (it installs a `#[global_allocator]`
//! to count allocations), or when it is the crate's only test target.
//!
//! The price of one binary is that a file under `tests/integration/` that no `mod` names is
//! silently never compiled. So this walks each test target's module tree (`mod name;`, with or
//! without `#[path]`) and fails on any `.rs` file under a crate's `tests/` that no test target
//! reaches.

use std::collections::BTreeSet;
use std::path::{Path, PathBuf};

use crate::metadata::{cargo_metadata, workspace_root};
use crate::walk::entries_below;

/// The `mod name;` declarations of a Rust file: (name, the `#[path]` given, if any). Inline
/// modules (`mod name { ... }`) are not followed.
fn declared_modules(text: &str) -> Vec<(String, Option<String>)> {
    let mut out = Vec::new();
    let mut path: Option<String> = None;
    for line in text.lines() {
        let t = line.trim();
        if let Some(rest) = t.strip_prefix("#[path = \"") {
            path = rest.strip_suffix("\"]").map(str::to_string);
            continue;
        }
        if t.starts_with("#[") {
            continue; // another attribute (`#[cfg]`, `#[allow]`) between `#[path]` and `mod`
        }
        let decl = t
            .strip_prefix("pub(crate) ")
            .or_else(|| t.strip_prefix("pub "))
            .unwrap_or(t);
        if let Some(name) = decl.strip_prefix("mod ").and_then(|r| r.strip_suffix(';')) {
            out.push((name.trim().to_string(), path.take()));
        }
        path = None;
    }
    out
}

/// The files of `root`'s module tree: the root, and every file a `mod` reaches from it.
fn module_tree(root: &Path) -> BTreeSet<PathBuf> {
    let mut seen = BTreeSet::new();
    // (file, whether its children live beside it: a crate root, `main.rs` or `mod.rs`)
    let mut stack = vec![(root.to_path_buf(), true)];
    while let Some((file, owns_dir)) = stack.pop() {
        if !seen.insert(file.clone()) {
            continue;
        }
        let Ok(text) = std::fs::read_to_string(&file) else {
            continue;
        };
        let dir = file.parent().unwrap().to_path_buf();
        for (name, path) in declared_modules(&text) {
            if let Some(p) = path {
                stack.push((dir.join(p), true));
                continue;
            }
            let base = if owns_dir {
                dir.clone()
            } else {
                dir.join(file.file_stem().unwrap())
            };
            let flat = base.join(format!("{name}.rs"));
            if flat.exists() {
                stack.push((flat, false));
            } else {
                stack.push((base.join(&name).join("mod.rs"), true));
            }
        }
    }
    seen
}

/// Every `.rs` file under `dir`, recursively (none if there is no `dir`).
fn rust_files(dir: &Path) -> Vec<PathBuf> {
    if !dir.is_dir() {
        return Vec::new();
    }
    entries_below(dir)
        .into_iter()
        .filter(|p| p.is_file() && p.extension().is_some_and(|x| x == "rs"))
        .collect()
}

/// One package as the check sees it: its folder and its test targets (name, root file).
struct Package {
    name: String,
    dir: PathBuf,
    tests: Vec<(String, PathBuf)>,
    /// Every target's root (library, binaries, tests, benches, examples): a `tests/` file may
    /// also be included by the library's unit tests with `#[path]`.
    roots: Vec<PathBuf>,
}

fn packages(root: &Path) -> Vec<Package> {
    let meta = cargo_metadata(root);
    let mut out = Vec::new();
    for p in meta["packages"].as_array().unwrap() {
        let manifest = PathBuf::from(p["manifest_path"].as_str().unwrap());
        let mut tests = Vec::new();
        let mut roots = Vec::new();
        for t in p["targets"].as_array().unwrap() {
            let src = PathBuf::from(t["src_path"].as_str().unwrap());
            let kinds: Vec<&str> = t["kind"]
                .as_array()
                .unwrap()
                .iter()
                .map(|k| k.as_str().unwrap())
                .collect();
            if kinds.contains(&"test") {
                tests.push((t["name"].as_str().unwrap().to_string(), src.clone()));
            }
            roots.push(src);
        }
        out.push(Package {
            name: p["name"].as_str().unwrap().to_string(),
            dir: manifest.parent().unwrap().to_path_buf(),
            tests,
            roots,
        });
    }
    out
}

/// Every breach of the rules above, one line each (empty: they hold).
fn violations(packages: &[Package]) -> Vec<String> {
    let mut out = Vec::new();
    for p in packages {
        if p.tests.len() > 1 {
            for (name, src) in &p.tests {
                let own_process =
                    std::fs::read_to_string(src).is_ok_and(|t| t.contains("#[global_allocator]"));
                if name != "integration" && !own_process {
                    out.push(format!(
                        "{}: test binary `{name}` ({}) should be a module of \
                         tests/integration/ (it installs no #[global_allocator])",
                        p.name,
                        src.display()
                    ));
                }
            }
        }
        let reached: BTreeSet<PathBuf> = p
            .roots
            .iter()
            .flat_map(|r| module_tree(r))
            .filter_map(|f| std::fs::canonicalize(f).ok())
            .collect();
        for f in rust_files(&p.dir.join("tests")) {
            let canonical = std::fs::canonicalize(&f).unwrap();
            if !reached.contains(&canonical) {
                out.push(format!(
                    "{}: {} is compiled by no target (name it with `mod` in tests/integration/main.rs)",
                    p.name,
                    f.display()
                ));
            }
        }
    }
    out
}

#[test]
fn every_test_file_is_compiled_and_each_crate_links_its_tests_once() {
    let found = packages(&workspace_root());
    assert!(found.len() >= 10, "{} packages", found.len());
    let v = violations(&found);
    assert!(v.is_empty(), "test targets:\n{}", v.join("\n"));
}

/// The check finds what it must, on a synthetic crate: an orphan file beside the modules, an
/// orphan in a nested folder, and a second test binary; and it passes the same crate without
/// them (a module reached through `#[path]`, a nested `mod.rs`, a module of a module, and a
/// binary with a global allocator are all fine).
#[test]
fn orphans_and_extra_binaries_in_a_synthetic_crate_are_found() {
    let dir = std::env::temp_dir().join(format!("visguide-test-targets-{}", std::process::id()));
    let _ = std::fs::remove_dir_all(&dir);
    let write = |rel: &str, text: &str| {
        let p = dir.join(rel);
        std::fs::create_dir_all(p.parent().unwrap()).unwrap();
        std::fs::write(p, text).unwrap();
    };
    write(
        "src/lib.rs",
        "#[cfg(test)]\n#[path = \"../tests/integration/common/shared.rs\"]\nmod shared;\n",
    );
    write(
        "tests/integration/main.rs",
        "mod common;\nmod solver;\n#[path = \"../../peer/harness.rs\"]\nmod harness;\n",
    );
    write("tests/integration/common/mod.rs", "pub mod scene;\n");
    write("tests/integration/common/scene.rs", "");
    write("tests/integration/common/shared.rs", "");
    write(
        "tests/integration/solver.rs",
        "#[cfg(feature = \"x\")]\nmod edge_cases;\n",
    );
    write("tests/integration/solver/edge_cases.rs", "");
    write("peer/harness.rs", "");
    write(
        "tests/alloc.rs",
        "#[global_allocator]\nstatic A: Counting = Counting;\n",
    );
    let root_of = |t: &str| match t {
        "integration" => dir.join("tests/integration/main.rs"),
        _ => dir.join(format!("tests/{t}.rs")),
    };
    let package = |tests: &[&str]| Package {
        name: "demo".into(),
        dir: dir.clone(),
        tests: tests.iter().map(|t| (t.to_string(), root_of(t))).collect(),
        roots: std::iter::once(dir.join("src/lib.rs"))
            .chain(tests.iter().map(|t| root_of(t)))
            .collect(),
    };
    assert_eq!(
        violations(&[package(&["integration", "alloc"])]),
        Vec::<String>::new()
    );

    write(
        "tests/integration/forgotten.rs",
        "#[test]\nfn never_runs() {}\n",
    );
    write("tests/integration/common/stale.rs", "");
    write("tests/own_binary.rs", "#[test]\nfn links_alone() {}\n");
    let v = violations(&[package(&["integration", "alloc", "own_binary"])]);
    let names: Vec<&str> = v
        .iter()
        .map(|l| {
            ["forgotten.rs", "stale.rs", "`own_binary`"]
                .into_iter()
                .find(|n| l.contains(n))
                .unwrap_or(l)
        })
        .collect();
    assert_eq!(
        names,
        ["`own_binary`", "stale.rs", "forgotten.rs"],
        "{v:#?}"
    );
    std::fs::remove_dir_all(&dir).unwrap();
}
