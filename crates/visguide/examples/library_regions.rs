//! The library calls `visguide regions` makes, one image after the other on one thread: the
//! reference for the command line's per-image time (`cargo run --release --example
//! library_regions -- DIR OUT`). Reads every `.png` of DIR, detects with the `larsson2009`
//! preset and writes `OUT/<stem>.mser`; prints the thread CPU time per image spent in
//! decoding + detection + writing, and in detection alone.

use std::path::PathBuf;
use std::time::Instant;

fn main() -> Result<(), Box<dyn std::error::Error>> {
    let mut args = std::env::args().skip(1);
    let (dir, out) = match (args.next(), args.next()) {
        (Some(d), Some(o)) => (PathBuf::from(d), PathBuf::from(o)),
        _ => return Err("usage: library_regions DIR OUT".into()),
    };
    std::fs::create_dir_all(&out)?;
    let mut files: Vec<PathBuf> = std::fs::read_dir(&dir)?
        .filter_map(|e| e.ok().map(|e| e.path()))
        .filter(|p| p.extension().is_some_and(|e| e == "png"))
        .collect();
    files.sort();
    let params = visguide::MserSettings::default();
    let (mut all, mut detect) = (0.0, 0.0);
    for f in &files {
        let t0 = Instant::now();
        let img = visguide::load_gray(f)?;
        let p = params.resolve(img.width(), img.height())?;
        let t1 = Instant::now();
        let view = mser::GrayView::from_image(&img)?;
        let regions = mser::detect(&view, &p)?;
        detect += t1.elapsed().as_secs_f64();
        let ellipses = regions
            .iter()
            .map(mser::Region::ellipse)
            .collect::<mser::Result<Vec<_>>>()?;
        let stem = f.file_stem().unwrap().to_string_lossy();
        mser::save_regions(out.join(format!("{stem}.mser")), &ellipses)?;
        all += t0.elapsed().as_secs_f64();
    }
    let n = files.len().max(1) as f64;
    println!(
        "{} images: {:.2} ms per image (decode + detect + write), {:.2} ms detect alone",
        files.len(),
        1e3 * all / n,
        1e3 * detect / n
    );
    Ok(())
}
