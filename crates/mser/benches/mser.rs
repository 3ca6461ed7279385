//! Criterion bench: both polarities, default (OpenCV) parameters, one thread, on graf and boat
//! img1 from `$VISGUIDE_DATA/oxford-affine` (a synthetic 800x640 image when absent), against
//! OpenCV's `detectRegions` with feature `opencv`.

use criterion::{Criterion, Throughput, criterion_group, criterion_main};
use mser::{GrayView, Mser, MserParams};

fn images() -> Vec<(String, image::GrayImage)> {
    let root = std::env::var_os("VISGUIDE_DATA")
        .map(|d| std::path::PathBuf::from(d).join("oxford-affine"));
    let mut out = Vec::new();
    if let Some(root) = root.filter(|r| r.join("graf/img1.png").exists()) {
        for seq in ["graf", "boat"] {
            out.push((
                format!("{seq} img1"),
                mser::load_gray(root.join(seq).join("img1.png")).unwrap(),
            ));
        }
    } else {
        eprintln!("VISGUIDE_DATA/oxford-affine not found: benchmarking a synthetic 800x640 image");
        let (w, h) = (800u32, 640u32);
        let img = image::GrayImage::from_fn(w, h, |x, y| {
            let (fx, fy) = (x as f64, y as f64);
            let v = 128.0
                + 60.0 * (fx * 0.07).sin() * (fy * 0.05).cos()
                + 50.0 * ((fx - fy) * 0.013).sin();
            image::Luma([v as u8])
        });
        out.push(("synthetic 800x640".into(), img));
    }
    out
}

fn bench(c: &mut Criterion) {
    let p = MserParams::default();
    let mut g = c.benchmark_group("mser both polarities");
    g.sample_size(20);
    for (name, gray) in images() {
        let img = GrayView::from_image(&gray).unwrap();
        g.throughput(Throughput::Elements((img.width() * img.height()) as u64));
        let mut det = Mser::new(p.clone()).unwrap();
        g.bench_function(format!("ours {name}"), |b| {
            b.iter(|| det.detect(&img).unwrap().len())
        });
        #[cfg(feature = "opencv")]
        {
            mser::set_opencv_threads(1).unwrap();
            let mut cv = mser::OpenCvMser::new(&p).unwrap();
            let mat = mser::OpenCvMser::mat(&img).unwrap();
            g.bench_function(format!("opencv {} {name}", mser::opencv_version()), |b| {
                b.iter(|| cv.detect_mat(&mat).unwrap())
            });
        }
    }
    g.finish();
}

criterion_group!(benches, bench);
criterion_main!(benches);
