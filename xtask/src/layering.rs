//! The layering of docs/ARCHITECTURE.md as a test: every `Cargo.toml` below `crates/` may depend
//! (normally, for builds or for tests) only on the workspace crates its layer allows, and no
//! crate depends on `xtask`. Third-party dependencies are not checked here.

/// The seven method crates, bottom layers first.
const METHODS: &[&str] = &[
    "chan-repr",
    "lwpr",
    "mser",
    "fd-match",
    "arm-sim",
    "cbt-tracker",
    "servo-loop",
];

/// The workspace crates `name` may depend on (all dependency kinds; `X@dev` only as a
/// dev-dependency), or `None` for a crate the layering does not know yet (which must be added
/// here before it may depend on any workspace crate).
fn allowed(name: &str) -> Option<Vec<&'static str>> {
    Some(match name {
        "chan-repr" | "lwpr" | "mser" | "fd-match" | "arm-sim" => vec![],
        "cbt-tracker" => vec!["chan-repr"],
        // Its tests and benches drive the simulated arm; the library itself does not.
        "servo-loop" => vec!["lwpr", "chan-repr", "arm-sim@dev"],
        "visguide" => METHODS.to_vec(),
        "visguide-py" => [METHODS, &["visguide"]].concat(),
        _ => return None,
    })
}

/// Whether a dependency name is a crate of this workspace.
fn is_workspace(name: &str) -> bool {
    METHODS.contains(&name) || matches!(name, "visguide" | "visguide-py" | "xtask")
}

/// The workspace crates a manifest depends on, each with whether only as a dev-dependency.
/// A small line-based reader: dependency tables are `[dependencies]`, `[dev-dependencies]`,
/// `[build-dependencies]`, their `[target.….…]` forms and `[dependencies.NAME]` headers.
fn workspace_deps(manifest: &str) -> Vec<(String, bool)> {
    let mut out: Vec<(String, bool)> = Vec::new();
    let mut add = |name: &str, dev: bool| {
        let name = name.trim().trim_matches('"');
        if is_workspace(name) {
            match out.iter_mut().find(|(n, _)| n == name) {
                Some(e) => e.1 &= dev,
                None => out.push((name.to_string(), dev)),
            }
        }
    };
    let mut table: Option<bool> = None; // Some(dev) inside a dependency table
    for line in manifest.lines() {
        let line = line.split('#').next().unwrap_or("").trim();
        if let Some(header) = line.strip_prefix('[') {
            let header = header.trim_end_matches(']').trim_matches('[').trim();
            let kind = header.rsplit('.').find(|p| p.ends_with("dependencies"));
            table = None;
            if let Some(kind) = kind {
                let dev = kind == "dev-dependencies";
                match header.split_once(&format!("{kind}.")) {
                    Some((_, name)) if !name.is_empty() => add(name, dev),
                    _ if header.ends_with("dependencies") => table = Some(dev),
                    _ => {}
                }
            }
            continue;
        }
        if let Some(dev) = table {
            let key = line.split(['=', '.']).next().unwrap_or("");
            if !key.is_empty() {
                add(key, dev);
            }
        }
    }
    out
}

/// The forbidden edges of one crate, as `crate -> dependency` strings.
fn violations(name: &str, manifest: &str) -> Vec<String> {
    let allowed = allowed(name);
    workspace_deps(manifest)
        .into_iter()
        .filter(|(dep, dev)| {
            let ok = allowed.as_ref().is_some_and(|a| {
                a.contains(&dep.as_str()) || (*dev && a.contains(&format!("{dep}@dev").as_str()))
            });
            !ok
        })
        .map(|(dep, dev)| format!("{name} -> {dep}{}", if dev { " (dev)" } else { "" }))
        .collect()
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn every_crate_respects_the_layering() {
        let crates = crate::workspace_root().join("crates");
        let mut checked = 0;
        let mut bad = Vec::new();
        for entry in std::fs::read_dir(&crates).expect("crates/ is readable") {
            let dir = entry.expect("a directory entry").path();
            let Ok(manifest) = std::fs::read_to_string(dir.join("Cargo.toml")) else {
                continue;
            };
            let name = manifest
                .lines()
                .find_map(|l| l.trim().strip_prefix("name = "))
                .map(|n| n.trim_matches('"').to_string())
                .expect("a package name");
            bad.extend(violations(&name, &manifest));
            checked += 1;
        }
        assert!(checked >= 7, "only {checked} crates found under {crates:?}");
        assert!(
            bad.is_empty(),
            "dependency edges the layering forbids: {bad:?}"
        );
    }

    #[test]
    fn the_reader_finds_every_kind_of_edge() {
        let m = "[package]\nname = \"x\"\n\n[dependencies]\nlwpr.workspace = true\n\
                 mser = { path = \"../mser\" } # comment\nserde = \"1\"\n\n\
                 [dev-dependencies]\narm-sim.workspace = true\nlwpr.workspace = true\n\n\
                 [target.'cfg(unix)'.dependencies]\nchan-repr = \"0.1\"\n\n\
                 [build-dependencies.xtask]\npath = \"../../xtask\"\n";
        let mut d = workspace_deps(m);
        d.sort();
        let want = [
            ("arm-sim", true),
            ("chan-repr", false),
            ("lwpr", false),
            ("mser", false),
            ("xtask", false),
        ];
        assert_eq!(
            d,
            want.iter()
                .map(|(n, dev)| (n.to_string(), *dev))
                .collect::<Vec<_>>()
        );
    }

    #[test]
    fn a_forbidden_edge_is_reported() {
        let upward = "[dependencies]\ncbt-tracker.workspace = true\n";
        assert_eq!(
            violations("chan-repr", upward),
            ["chan-repr -> cbt-tracker"]
        );
        let test_only = "[dev-dependencies]\narm-sim.workspace = true\n";
        assert!(violations("servo-loop", test_only).is_empty());
        let in_library = "[dependencies]\narm-sim.workspace = true\n";
        assert_eq!(
            violations("servo-loop", in_library),
            ["servo-loop -> arm-sim"]
        );
        let on_xtask = "[dependencies]\nxtask = { path = \"../../xtask\" }\n";
        assert_eq!(violations("visguide", on_xtask), ["visguide -> xtask"]);
        assert_eq!(
            violations("new-crate", upward),
            ["new-crate -> cbt-tracker"]
        );
    }
}
