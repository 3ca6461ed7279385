//! The workspace's layering (docs/ARCHITECTURE.md), checked on every `Cargo.toml`: this reads
//! the manifests through `cargo metadata --no-deps` and fails on a dependency edge the layers
//! forbid.
//!
//! - `chan-repr` and `lwpr` at the bottom: no workspace dependency.
//! - `mser`, `fd-match`, `arm-sim` independent of each other (the bottom layer allowed).
//! - `cbt-tracker` on `chan-repr`; `servo-loop` on `lwpr` and `chan-repr`.
//! - `visguide` (facade) above the seven, `visguide-py` above `visguide`; none of the seven
//!   depends on either.
//! - No crate depends on `xtask`; no cycles.
//!
//! Normal and build dependencies must follow the table. Dev-dependencies (tests, benches) may
//! connect any two of the seven (servo-loop's tests drive `arm-sim`), but never reach up to
//! `visguide`, `visguide-py` or `xtask`. A workspace crate missing from the table is an error:
//! place it in a layer first.

use std::collections::{BTreeMap, BTreeSet};
use std::path::{Path, PathBuf};

use crate::metadata::{cargo_metadata, workspace_root};

const SEVEN: [&str; 7] = [
    "chan-repr",
    "lwpr",
    "mser",
    "fd-match",
    "arm-sim",
    "cbt-tracker",
    "servo-loop",
];

/// The workspace crates each crate may depend on (normal and build dependencies).
fn allowed(krate: &str) -> Option<Vec<&'static str>> {
    let bottom = vec!["chan-repr", "lwpr"];
    Some(match krate {
        "chan-repr" | "lwpr" => vec![],
        "mser" | "fd-match" | "arm-sim" => bottom,
        "cbt-tracker" => vec!["chan-repr"],
        "servo-loop" => vec!["lwpr", "chan-repr"],
        "visguide" => SEVEN.to_vec(),
        "visguide-py" => SEVEN.iter().copied().chain(["visguide"]).collect(),
        "xtask" => SEVEN.iter().copied().chain(["visguide"]).collect(),
        _ => return None,
    })
}

/// A dependency edge between two workspace crates.
#[derive(Debug, Clone, PartialEq, Eq, PartialOrd, Ord)]
struct Edge {
    from: String,
    to: String,
    dev: bool,
}

/// The edges between the workspace's own crates, read from its manifests.
fn workspace_edges(root: &Path) -> (BTreeSet<String>, Vec<Edge>) {
    let meta = cargo_metadata(root);
    let packages = meta["packages"].as_array().unwrap();
    let names: BTreeSet<String> = packages
        .iter()
        .map(|p| p["name"].as_str().unwrap().to_string())
        .collect();
    let mut edges = Vec::new();
    for p in packages {
        for d in p["dependencies"].as_array().unwrap() {
            let to = d["name"].as_str().unwrap();
            if names.contains(to) {
                edges.push(Edge {
                    from: p["name"].as_str().unwrap().to_string(),
                    to: to.to_string(),
                    dev: d["kind"].as_str() == Some("dev"),
                });
            }
        }
    }
    edges.sort();
    edges.dedup();
    (names, edges)
}

/// Every violation of the layering, one line each (empty: the layering holds).
fn violations(names: &BTreeSet<String>, edges: &[Edge]) -> Vec<String> {
    let mut out = Vec::new();
    for n in names {
        if allowed(n).is_none() {
            out.push(format!(
                "{n}: not in the layering table (xtask/tests/integration/layering.rs)"
            ));
        }
    }
    let above = ["visguide", "visguide-py", "xtask"];
    for e in edges {
        let ok = if e.dev {
            !above.contains(&e.to.as_str())
                || allowed(&e.from).is_some_and(|a| a.contains(&e.to.as_str()))
        } else {
            allowed(&e.from).is_some_and(|a| a.contains(&e.to.as_str()))
        };
        if !ok {
            let kind = if e.dev {
                "dev-dependency"
            } else {
                "dependency"
            };
            out.push(format!("{} -> {} ({kind}) is forbidden", e.from, e.to));
        }
    }
    // Cycles, over every kind of edge.
    let mut next: BTreeMap<&str, Vec<&str>> = BTreeMap::new();
    for e in edges {
        next.entry(&e.from).or_default().push(&e.to);
    }
    fn reaches<'a>(
        from: &'a str,
        to: &str,
        next: &BTreeMap<&'a str, Vec<&'a str>>,
        seen: &mut BTreeSet<&'a str>,
    ) -> bool {
        next.get(from)
            .into_iter()
            .flatten()
            .any(|&n| n == to || (seen.insert(n) && reaches(n, to, next, seen)))
    }
    for n in names {
        if reaches(n, n, &next, &mut BTreeSet::new()) {
            out.push(format!("{n} is on a dependency cycle"));
        }
    }
    out
}

#[test]
fn the_workspace_follows_its_layering() {
    let (names, edges) = workspace_edges(&workspace_root());
    for krate in SEVEN.iter().chain(&["xtask"]) {
        assert!(names.contains(*krate), "{krate} is not a workspace member");
    }
    let v = violations(&names, &edges);
    assert!(v.is_empty(), "layering violated:\n{}", v.join("\n"));
}

/// A synthetic workspace on disk: `crates` as (name, dependencies, dev-dependencies).
fn synthetic_workspace(tag: &str, crates: &[(&str, &[&str], &[&str])]) -> PathBuf {
    let root = std::env::temp_dir().join(format!("visguide-layering-{tag}-{}", std::process::id()));
    let _ = std::fs::remove_dir_all(&root);
    let members: Vec<String> = crates.iter().map(|(n, ..)| format!("\"{n}\"")).collect();
    std::fs::create_dir_all(&root).unwrap();
    std::fs::write(
        root.join("Cargo.toml"),
        format!(
            "[workspace]\nresolver = \"3\"\nmembers = [{}]\n",
            members.join(", ")
        ),
    )
    .unwrap();
    for (name, deps, dev) in crates {
        let dir = root.join(name);
        std::fs::create_dir_all(dir.join("src")).unwrap();
        std::fs::write(dir.join("src/lib.rs"), "").unwrap();
        let list = |ds: &[&str]| -> String {
            ds.iter()
                .map(|d| format!("{d} = {{ path = \"../{d}\" }}\n"))
                .collect()
        };
        std::fs::write(
            dir.join("Cargo.toml"),
            format!(
                "[package]\nname = \"{name}\"\nversion = \"0.1.0\"\nedition = \"2024\"\n\n\
                 [dependencies]\n{}\n[dev-dependencies]\n{}",
                list(deps),
                list(dev)
            ),
        )
        .unwrap();
    }
    root
}

/// The check itself fails where it must: on synthetic manifests with forbidden edges, and
/// passes the same workspace without them.
#[test]
fn forbidden_edges_in_synthetic_manifests_are_found() {
    let good: Vec<(&str, &[&str], &[&str])> = vec![
        ("chan-repr", &[], &[]),
        ("lwpr", &[], &[]),
        ("mser", &[], &[]),
        ("fd-match", &["chan-repr"], &["mser"]),
        ("arm-sim", &[], &[]),
        ("cbt-tracker", &["chan-repr"], &[]),
        ("servo-loop", &["lwpr", "chan-repr"], &["arm-sim"]),
        ("visguide", &["mser", "servo-loop"], &[]),
        ("xtask", &["visguide", "lwpr"], &[]),
    ];
    let root = synthetic_workspace("good", &good);
    let (names, edges) = workspace_edges(&root);
    assert_eq!(violations(&names, &edges), Vec::<String>::new());
    std::fs::remove_dir_all(&root).unwrap();

    let bad: Vec<(&str, &[&str], &[&str])> = vec![
        ("chan-repr", &["lwpr"], &[]), // the bottom depends on nothing
        ("lwpr", &[], &["visguide"]),  // not even tests reach the facade
        ("mser", &["fd-match"], &[]),  // the middle layer is independent
        ("fd-match", &[], &[]),
        ("arm-sim", &["servo-loop"], &[]), // upward
        ("cbt-tracker", &["chan-repr", "lwpr"], &[]),
        ("servo-loop", &["lwpr", "chan-repr"], &["xtask"]),
        ("visguide", &["arm-sim"], &[]),
        ("xtask", &["visguide"], &[]),
        ("helpers", &[], &[]), // not placed in a layer
    ];
    let root = synthetic_workspace("bad", &bad);
    let (names, edges) = workspace_edges(&root);
    let mut v = violations(&names, &edges);
    v.sort();
    // The upward edges also close cycles: servo-loop → xtask → visguide → arm-sim →
    // servo-loop, and through lwpr → visguide and chan-repr → lwpr.
    let want = [
        "arm-sim -> servo-loop (dependency) is forbidden",
        "arm-sim is on a dependency cycle",
        "cbt-tracker -> lwpr (dependency) is forbidden",
        "chan-repr -> lwpr (dependency) is forbidden",
        "chan-repr is on a dependency cycle",
        "helpers: not in the layering table (xtask/tests/integration/layering.rs)",
        "lwpr -> visguide (dev-dependency) is forbidden",
        "lwpr is on a dependency cycle",
        "mser -> fd-match (dependency) is forbidden",
        "servo-loop -> xtask (dev-dependency) is forbidden",
        "servo-loop is on a dependency cycle",
        "visguide is on a dependency cycle",
        "xtask is on a dependency cycle",
    ];
    assert_eq!(v, want);
    std::fs::remove_dir_all(&root).unwrap();
}

/// A cycle is reported (cargo itself refuses a cycle of normal dependencies, so this builds
/// the edge list directly; a dev-dependency cycle is one cargo accepts).
#[test]
fn cycles_are_found() {
    let names: BTreeSet<String> = ["lwpr", "servo-loop"]
        .iter()
        .map(|s| s.to_string())
        .collect();
    let edge = |from: &str, to: &str, dev| Edge {
        from: from.into(),
        to: to.into(),
        dev,
    };
    let edges = [
        edge("servo-loop", "lwpr", false),
        edge("lwpr", "servo-loop", true),
    ];
    let v = violations(&names, &edges);
    assert!(
        v.contains(&"lwpr is on a dependency cycle".to_string()),
        "{v:?}"
    );
    assert!(
        v.contains(&"servo-loop is on a dependency cycle".to_string()),
        "{v:?}"
    );
}
