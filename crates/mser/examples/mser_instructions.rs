//! A fixed workload for instruction counting under callgrind, where wall-clock time is too noisy
//! (a shared, loaded machine): one warm-up detection, then one measured detection in a function
//! of its own, with ours (`ours`: `Mser::detect`; `ours-pixels`: `Mser::detect_with_pixels`) or
//! OpenCV's detector (feature `opencv`), both polarities, default parameters.
//!
//! ```text
//! cargo build --release -p mser --features opencv --example mser_instructions
//! valgrind --tool=callgrind --toggle-collect='*instructions*measured*' \
//!     target/release/examples/mser_instructions ours|ours-pixels|opencv IMAGE.png [dark|bright|both [MIN_DIVERSITY]]
//! ```
//!
//! The optional third argument restricts ours to one polarity (default both), to see how the
//! work splits between the two tasks of `Mser::detect_parallel`. The optional fourth sets
//! `min_diversity` (default 0.2); `cargo xtask bench mser` uses 0 on both sides.
//!
//! The `Collected` total of each run is the instruction count of one steady-state detection
//! (buffers already allocated); the ratio of the two is the instruction-count ratio.

fn main() -> Result<(), Box<dyn std::error::Error>> {
    let args: Vec<String> = std::env::args().skip(1).collect();
    let (Some(which), Some(path)) = (args.first(), args.get(1)) else {
        eprintln!(
            "usage: instructions ours|ours-pixels|opencv IMAGE.png [dark|bright|both [MIN_DIVERSITY]]"
        );
        std::process::exit(2);
    };
    let gray = mser::load_gray(path)?;
    let img = mser::GrayView::from_image(&gray)?;
    let polarities = match args.get(2).map(String::as_str) {
        None | Some("both") => mser::Polarities::Both,
        Some("dark") => mser::Polarities::Dark,
        Some("bright") => mser::Polarities::Bright,
        Some(other) => return Err(format!("unknown polarity {other}").into()),
    };
    let mut params = mser::MserParams {
        polarities,
        ..mser::MserParams::default()
    };
    if let Some(d) = args.get(3) {
        params.min_diversity = d.parse()?;
    }
    let n = match which.as_str() {
        "ours" => {
            let mut det = mser::Mser::new(params)?;
            det.detect(&img)?;
            measured_ours(&mut det, &img)?
        }
        "ours-pixels" => {
            let mut det = mser::Mser::new(params)?;
            det.detect_with_pixels(&img)?;
            measured_ours_pixels(&mut det, &img)?
        }
        "opencv" => opencv(&img, &params)?,
        other => return Err(format!("unknown detector {other}").into()),
    };
    println!("{which}: {n} regions");
    Ok(())
}

#[inline(never)]
fn measured_ours(det: &mut mser::Mser, img: &mser::GrayView) -> mser::Result<usize> {
    Ok(det.detect(img)?.len())
}

#[inline(never)]
fn measured_ours_pixels(det: &mut mser::Mser, img: &mser::GrayView) -> mser::Result<usize> {
    Ok(det.detect_with_pixels(img)?.len())
}

#[cfg(feature = "opencv")]
fn opencv(img: &mser::GrayView, params: &mser::MserParams) -> mser::Result<usize> {
    #[inline(never)]
    fn measured_opencv(cv: &mut mser::OpenCvMser, mat: &opencv::core::Mat) -> mser::Result<usize> {
        cv.detect_mat(mat)
    }
    mser::set_opencv_threads(1)?;
    let mut cv = mser::OpenCvMser::new(params)?;
    let mat = mser::OpenCvMser::mat(img)?;
    cv.detect_mat(&mat)?;
    measured_opencv(&mut cv, &mat)
}

#[cfg(not(feature = "opencv"))]
fn opencv(_: &mser::GrayView, _: &mser::MserParams) -> mser::Result<usize> {
    Err(mser::MserError::InvalidParameter {
        name: "detector",
        reason: "build with --features opencv".into(),
    })
}
