//! The project's documentation stands alone: every citation `docs/methods.md § NAME` in the
//! sources names a heading of `docs/methods.md`, and nothing cites notes outside the repository
//! (`papers.md`, `OVERLAP.md`).

use std::path::Path;

/// The citations `docs/methods.md § …` in `text` that do not start with one of `sections`
/// (followed by a non-alphanumeric character), each as the 40 characters after the `§`.
/// Comment line breaks (`\n//! `, `\n/// `, `\n// `) count as spaces.
fn unknown_citations(text: &str, sections: &[String]) -> Vec<String> {
    let mut flat = String::with_capacity(text.len());
    for (k, line) in text.lines().enumerate() {
        let t = line.trim_start();
        let body = ["//!", "///", "//"]
            .iter()
            .find_map(|p| t.strip_prefix(p))
            .unwrap_or(line);
        if k > 0 {
            flat.push(' ');
        }
        flat.push_str(body.trim());
    }
    flat.match_indices("docs/methods.md §")
        .map(|(i, m)| flat[i + m.len()..].trim_start())
        .filter(|rest| {
            !sections.iter().any(|s| {
                rest.strip_prefix(s.as_str())
                    .is_some_and(|after| !after.starts_with(char::is_alphanumeric))
            })
        })
        .map(|rest| rest.chars().take(40).collect())
        .collect()
}

/// The headings (`##` to `####`) of a Markdown text.
fn headings(markdown: &str) -> Vec<String> {
    markdown
        .lines()
        .filter_map(|l| l.strip_prefix("##"))
        .map(|h| h.trim_start_matches('#').trim().to_string())
        .collect()
}

/// Every `.rs`, `.md` and `.toml` file below `dir` (no `target`, no hidden folders).
fn source_files(dir: &Path, out: &mut Vec<std::path::PathBuf>) {
    let Ok(entries) = std::fs::read_dir(dir) else {
        return;
    };
    for e in entries.flatten() {
        let p = e.path();
        let name = e.file_name().to_string_lossy().to_string();
        if p.is_dir() {
            if !name.starts_with('.') && name != "target" {
                source_files(&p, out);
            }
        } else if name.ends_with(".rs") || name.ends_with(".md") || name.ends_with(".toml") {
            out.push(p);
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn every_methods_citation_names_a_section_and_no_outside_notes_are_cited() {
        let root = crate::workspace_root();
        let methods = std::fs::read_to_string(root.join("docs/methods.md")).expect("methods.md");
        let sections = headings(&methods);
        let mut files = Vec::new();
        for dir in ["crates", "xtask", "docs"] {
            source_files(&root.join(dir), &mut files);
        }
        files.push(root.join("README.md"));
        let (mut missing, mut outside) = (Vec::new(), Vec::new());
        let this_file = Path::new(file!()).file_name();
        for f in &files {
            if f.file_name() == this_file {
                continue;
            }
            let Ok(text) = std::fs::read_to_string(f) else {
                continue;
            };
            for s in unknown_citations(&text, &sections) {
                missing.push(format!("{}: § {s}", f.display()));
            }
            if f.file_name().is_some_and(|n| n != "methods.md")
                && (text.contains("papers.md") || text.contains("OVERLAP.md"))
            {
                outside.push(f.display().to_string());
            }
        }
        assert!(
            missing.is_empty(),
            "citations of missing sections: {missing:?}"
        );
        assert!(
            outside.is_empty(),
            "files citing notes outside the repository: {outside:?}"
        );
    }

    #[test]
    fn citations_and_headings_are_read_as_written() {
        let sections = ["LWPR".to_string(), "Overlap error".to_string()];
        let text = "//! see docs/methods.md § Overlap\n//! error, step 3) and (docs/methods.md § LWPR).\n\
                    /// docs/methods.md § LWPRX and docs/methods.md § Tracking (x)";
        assert_eq!(
            unknown_citations(text, &sections),
            ["LWPRX and docs/methods.md § Tracking (x)", "Tracking (x)"]
        );
        assert_eq!(
            headings("# T\n## LWPR\ntext\n### Overlap error\n"),
            ["LWPR", "Overlap error"]
        );
    }
}
