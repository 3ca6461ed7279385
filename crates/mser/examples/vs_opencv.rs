//! Times ours against OpenCV on the Oxford img1 images (feature `opencv`).
//!
//! `VISGUIDE_DATA=... cargo run --release -p mser --features opencv --example vs_opencv`

#[cfg(feature = "opencv")]
fn main() -> Result<(), Box<dyn std::error::Error>> {
    use std::time::Instant;
    let root = std::path::PathBuf::from(std::env::var("VISGUIDE_DATA")?).join("oxford-affine");
    mser::set_opencv_threads(1)?;
    let p = mser::MserParams::default();
    for seq in ["graf", "boat", "leuven"] {
        let g = mser::load_gray(root.join(seq).join("img1.png"))?;
        let img = mser::GrayView::from_image(&g)?;
        let mut ours = mser::Mser::new(p.clone())?;
        let mut cv = mser::OpenCvMser::new(&p)?;
        let mat = mser::OpenCvMser::mat(&img)?;
        let med = |f: &mut dyn FnMut()| {
            f();
            let mut t: Vec<f64> = (0..31)
                .map(|_| {
                    let t0 = Instant::now();
                    f();
                    t0.elapsed().as_secs_f64() * 1e3
                })
                .collect();
            t.sort_by(f64::total_cmp);
            t[3]
        };
        let (mut n1, mut n2) = (0, 0);
        let a = med(&mut || n1 = ours.detect(&img).unwrap().len());
        let b = med(&mut || n2 = cv.detect_mat(&mat).unwrap());
        println!(
            "{seq}: ours {a:.2} ms ({n1}), opencv {} {b:.2} ms ({n2}), ratio {:.2}",
            mser::opencv_version(),
            b / a
        );
    }
    Ok(())
}

#[cfg(not(feature = "opencv"))]
fn main() {
    eprintln!("build with --features opencv");
}
