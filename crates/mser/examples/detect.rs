//! Detects MSERs in an image and writes them as an Oxford region file.
//!
//! `cargo run --release -p mser --example detect -- IMAGE.png [OUT.mser] [--larsson2009]`

use std::time::Instant;

fn main() -> Result<(), Box<dyn std::error::Error>> {
    let args: Vec<String> = std::env::args().skip(1).collect();
    let Some(path) = args.first() else {
        eprintln!("usage: detect IMAGE.png [OUT] [--larsson2009]");
        std::process::exit(2);
    };
    let params = if args.iter().any(|a| a == "--larsson2009") {
        mser::MserParams::larsson2009()
    } else {
        mser::MserParams::default()
    };
    let gray = mser::load_gray(path)?;
    let img = mser::GrayView::from_image(&gray)?;
    let mut det = mser::Mser::new(params)?;
    let mut regions = det.detect(&img)?; // warm-up
    let mut times = Vec::new();
    for _ in 0..10 {
        let t0 = Instant::now();
        regions = det.detect(&img)?;
        times.push(t0.elapsed().as_secs_f64() * 1e3);
    }
    times.sort_by(f64::total_cmp);
    let dark = regions
        .iter()
        .filter(|r| r.polarity == mser::Polarity::Dark)
        .count();
    println!(
        "{path}: {}x{}, {} regions ({dark} dark, {} bright), median {:.2} ms",
        img.width(),
        img.height(),
        regions.len(),
        regions.len() - dark,
        times[times.len() / 2]
    );
    if let Some(out) = args.get(1).filter(|a| !a.starts_with("--")) {
        let ellipses = regions
            .iter()
            .map(|r| r.ellipse())
            .collect::<Result<Vec<_>, _>>()?;
        mser::save_regions(out, &ellipses)?;
        println!("wrote {out}");
    }
    Ok(())
}
