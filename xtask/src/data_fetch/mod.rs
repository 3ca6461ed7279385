//! `cargo xtask data fetch [--dir DIR]`: downloads the eight sequences of the Oxford affine
//! covariant regions benchmark (Mikolajczyk et al., IJCV 2005) from the VGG page, unpacks them
//! into `DIR/oxford-affine/<seq>/` (images converted losslessly to PNG, homographies copied byte
//! for byte) and checks that every image decodes. `DIR` then works as `--data DIR` /
//! `VISGUIDE_DATA`.
//!
//! Atomic per sequence: the archive is streamed into a hidden temporary folder next to the
//! target, which is renamed into place only after everything unpacked and checked; on any
//! failure (network error, truncated download, corrupt archive, undecodable image) the
//! temporary folder is removed, so no half-written sequence is ever left behind. Sequences
//! already present are verified, not downloaded again.

mod archive;
pub mod pnm;
#[cfg(test)]
mod tests;

use std::path::{Path, PathBuf};
use std::time::Duration;

use clap::{Args, Subcommand};

use crate::Result;

/// The benchmark's eight sequences.
pub const SEQUENCES: [&str; 8] = [
    "bark", "bikes", "boat", "graf", "leuven", "trees", "ubc", "wall",
];

/// Where the VGG page serves the archives (`<base>/<seq>.tar.gz`).
pub const DEFAULT_BASE_URL: &str =
    "https://www.robots.ox.ac.uk/~vgg/research/affine/det_eval_files";

/// Arguments of `cargo xtask data`.
#[derive(Args)]
pub struct DataArgs {
    /// What to do.
    #[command(subcommand)]
    pub action: DataAction,
}

/// `cargo xtask data` actions.
#[derive(Subcommand)]
pub enum DataAction {
    /// Download, unpack and check the Oxford affine benchmark.
    Fetch(FetchArgs),
}

/// Arguments of `cargo xtask data fetch`.
#[derive(Args, Clone, Debug)]
pub struct FetchArgs {
    /// Data folder; sequences go to `DIR/oxford-affine/<seq>/`. Default: $VISGUIDE_DATA, else
    /// target/visguide-data.
    #[arg(long, value_name = "DIR")]
    pub dir: Option<PathBuf>,
    /// Sequences to fetch (default: all eight).
    #[arg(long, value_delimiter = ',', value_name = "NAME[,NAME…]")]
    pub sequences: Vec<String>,
    /// Base URL of the archives.
    #[arg(long, default_value = DEFAULT_BASE_URL)]
    pub base_url: String,
}

/// Runs `cargo xtask data`.
pub fn run(args: &DataArgs) -> Result<()> {
    match &args.action {
        DataAction::Fetch(f) => {
            let dir = f.dir.clone().unwrap_or_else(|| {
                std::env::var_os("VISGUIDE_DATA")
                    .map(PathBuf::from)
                    .unwrap_or_else(|| crate::workspace_root().join("target").join("visguide-data"))
            });
            let names: Vec<String> = if f.sequences.is_empty() {
                SEQUENCES.iter().map(|s| s.to_string()).collect()
            } else {
                f.sequences.clone()
            };
            for name in &names {
                let status = fetch_sequence(&f.base_url, &dir, name)?;
                eprintln!("{name}: {status}");
            }
            eprintln!("data in {} (use --data {0})", dir.display());
            Ok(())
        }
    }
}

/// What [`fetch_sequence`] did.
#[derive(Debug, Clone, PartialEq, Eq)]
pub enum Fetched {
    /// Already there and verified: this many images.
    Present(usize),
    /// Downloaded: this many images and homographies.
    Downloaded(usize, usize),
}

impl std::fmt::Display for Fetched {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        match self {
            Fetched::Present(n) => write!(f, "present, {n} images check out"),
            Fetched::Downloaded(i, h) => {
                write!(f, "downloaded, {i} images decoded, {h} homographies")
            }
        }
    }
}

/// Removes a folder when dropped unless disarmed: the temporary folder of a failed fetch.
struct TempDir(Option<PathBuf>);

impl Drop for TempDir {
    fn drop(&mut self) {
        if let Some(p) = self.0.take() {
            let _ = std::fs::remove_dir_all(p);
        }
    }
}

fn valid_name(name: &str) -> bool {
    !name.is_empty()
        && name
            .chars()
            .all(|c| c.is_ascii_alphanumeric() || c == '-' || c == '_')
}

/// Fetches one sequence into `data_dir/oxford-affine/<name>` (see the module doc).
pub fn fetch_sequence(base_url: &str, data_dir: &Path, name: &str) -> Result<Fetched> {
    if !valid_name(name) {
        return Err(format!("invalid sequence name `{name}`").into());
    }
    let root = data_dir.join("oxford-affine");
    let target = root.join(name);
    if target.exists() {
        let n = archive::verify(&target).map_err(|e| {
            format!(
                "{} exists but does not check out ({e}); remove it and fetch again",
                target.display()
            )
        })?;
        return Ok(Fetched::Present(n));
    }
    // Every file-system error names its path.
    let named = |p: &Path| {
        let p = p.display().to_string();
        move |e: std::io::Error| format!("{p}: {e}")
    };
    std::fs::create_dir_all(&root).map_err(named(&root))?;
    let temp = root.join(format!(".{name}.partial-{}", std::process::id()));
    if temp.exists() {
        std::fs::remove_dir_all(&temp).map_err(named(&temp))?;
    }
    std::fs::create_dir(&temp).map_err(named(&temp))?;
    let mut guard = TempDir(Some(temp.clone()));
    let url = format!("{}/{name}.tar.gz", base_url.trim_end_matches('/'));
    let agent: ureq::Agent = ureq::Agent::config_builder()
        .timeout_connect(Some(Duration::from_secs(30)))
        .timeout_global(Some(Duration::from_secs(600)))
        .build()
        .into();
    let response = agent
        .get(&url)
        .call()
        .map_err(|e| format!("GET {url}: {e}"))?;
    let reader = response.into_body().into_reader();
    let unpacked = archive::unpack(reader, &temp).map_err(|e| format!("{url}: {e}"))?;
    archive::verify(&temp)?;
    std::fs::rename(&temp, &target).map_err(named(&target))?;
    guard.0 = None;
    Ok(Fetched::Downloaded(
        unpacked.images.len(),
        unpacked.homographies.len(),
    ))
}
