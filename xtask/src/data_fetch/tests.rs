//! `data fetch` against a local HTTP server on 127.0.0.1 that serves archives the tests build.

use std::collections::HashMap;
use std::io::{BufRead, BufReader, Write};
use std::net::TcpListener;
use std::path::PathBuf;

use super::*;

/// How the server answers one path.
#[derive(Clone)]
enum Reply {
    /// 200 with the whole body.
    Full(Vec<u8>),
    /// 200 announcing the whole length, but the connection closes after half the bytes.
    Truncated(Vec<u8>),
}

/// Serves `routes` on 127.0.0.1 (404 for anything else) for `connections` requests; returns the
/// base URL.
fn serve(routes: HashMap<String, Reply>, connections: usize) -> String {
    let listener = TcpListener::bind("127.0.0.1:0").unwrap();
    let addr = listener.local_addr().unwrap();
    std::thread::spawn(move || {
        for stream in listener.incoming().take(connections) {
            let Ok(mut stream) = stream else { continue };
            let mut reader = BufReader::new(stream.try_clone().unwrap());
            let mut request = String::new();
            reader.read_line(&mut request).unwrap();
            // Skip the headers.
            loop {
                let mut line = String::new();
                if reader.read_line(&mut line).unwrap() == 0 || line == "\r\n" {
                    break;
                }
            }
            let path = request.split_whitespace().nth(1).unwrap_or("").to_string();
            let (status, body, sent) = match routes.get(&path) {
                Some(Reply::Full(b)) => ("200 OK", b.clone(), b.len()),
                Some(Reply::Truncated(b)) => ("200 OK", b.clone(), b.len() / 2),
                None => ("404 Not Found", b"not found".to_vec(), 9),
            };
            let head = format!(
                "HTTP/1.1 {status}\r\nContent-Type: application/x-gzip\r\nContent-Length: {}\r\nConnection: close\r\n\r\n",
                body.len()
            );
            let _ = stream.write_all(head.as_bytes());
            let _ = stream.write_all(&body[..sent]);
            let _ = stream.flush();
        }
    });
    format!("http://{addr}/affine")
}

fn grey(w: u32, h: u32, seed: u32) -> image::GrayImage {
    image::GrayImage::from_fn(w, h, |x, y| {
        image::Luma([((x * 7 + y * 13 + seed) % 251) as u8])
    })
}

fn ppm(w: u32, h: u32) -> (Vec<u8>, image::RgbImage) {
    let img = image::RgbImage::from_fn(w, h, |x, y| image::Rgb([x as u8 * 9, y as u8 * 11, 200]));
    let mut bytes = format!("P6\n# CREATOR: XV Version 3.10a\n{w} {h}\n255\n").into_bytes();
    bytes.extend_from_slice(img.as_raw());
    (bytes, img)
}

const H2: &str = "   8.7976964e-01   3.1245438e-01  -3.9430589e+01\n  -1.8389418e-01   9.3847198e-01   1.5315784e+02\n   1.9641425e-04  -1.6015275e-05   1.0000000e+00\n";
const H3: &str = "-5.7780461e-01 -7.4653534e-03 -1.8849466e-01\n8.4414658e-04 -5.8051698e-01 4.5205045E+00\n2.0525034e-06 -1.0250081e-05 -5.7604815e-01\n";

/// A gzip-compressed tar like the benchmark's, with `files` under `prefix`.
fn archive(prefix: &str, files: &[(&str, Vec<u8>)]) -> Vec<u8> {
    let gz = flate2::write::GzEncoder::new(Vec::new(), flate2::Compression::fast());
    let mut tar = tar::Builder::new(gz);
    for (name, bytes) in files {
        let mut header = tar::Header::new_gnu();
        header.set_size(bytes.len() as u64);
        header.set_mode(0o644);
        header.set_cksum();
        tar.append_data(&mut header, format!("{prefix}{name}"), bytes.as_slice())
            .unwrap();
    }
    tar.into_inner().unwrap().finish().unwrap()
}

fn good_files() -> (Vec<(&'static str, Vec<u8>)>, image::RgbImage) {
    let (p1, rgb) = ppm(12, 8);
    let files = vec![
        ("img1.ppm", p1),
        ("img2.pgm", pnm::encode_p5(&grey(10, 9, 1))),
        ("img3.pgm", pnm::encode_p5(&grey(11, 7, 2))),
        ("H1to2p", H2.as_bytes().to_vec()),
        ("H1to3p", H3.as_bytes().to_vec()),
        ("README", b"ignored".to_vec()),
    ];
    (files, rgb)
}

fn data_dir(tag: &str) -> PathBuf {
    let d = std::env::temp_dir().join(format!("visguide-fetch-{tag}-{}", std::process::id()));
    let _ = std::fs::remove_dir_all(&d);
    d
}

/// Everything below `dir/oxford-affine`, as names.
fn listing(dir: &std::path::Path) -> Vec<String> {
    let Ok(rd) = std::fs::read_dir(dir.join("oxford-affine")) else {
        return Vec::new();
    };
    let mut v: Vec<String> = rd
        .map(|e| e.unwrap().file_name().to_string_lossy().into_owned())
        .collect();
    v.sort();
    v
}

#[test]
fn fetches_unpacks_converts_and_then_finds_it_present() {
    let (files, rgb) = good_files();
    let mut routes = HashMap::new();
    routes.insert(
        "/affine/tiny.tar.gz".into(),
        Reply::Full(archive("tiny/", &files)),
    );
    let base = serve(routes, 1);
    let dir = data_dir("ok");
    assert_eq!(
        fetch_sequence(&base, &dir, "tiny").unwrap(),
        Fetched::Downloaded(3, 2)
    );
    let seq = dir.join("oxford-affine/tiny");
    assert_eq!(listing(&dir), vec!["tiny"]);
    // PNGs decode to exactly the original pixels; homographies are byte-identical.
    let img1 = image::open(seq.join("img1.png")).unwrap();
    assert_eq!(img1.as_rgb8().unwrap(), &rgb);
    let img3 = image::open(seq.join("img3.png")).unwrap();
    assert_eq!(img3.as_luma8().unwrap(), &grey(11, 7, 2));
    assert_eq!(std::fs::read_to_string(seq.join("H1to3p")).unwrap(), H3);
    assert!(!seq.join("README").exists());
    // The evaluation reads it.
    let s = crate::eval::paper_a::sequence::Sequence::load("tiny", &seq).unwrap();
    assert_eq!(s.images.len(), 3);
    // A second fetch verifies instead of downloading (the server is gone).
    assert_eq!(
        fetch_sequence(&base, &dir, "tiny").unwrap(),
        Fetched::Present(3)
    );
    std::fs::remove_dir_all(&dir).unwrap();
}

#[test]
fn truncated_download_leaves_nothing_behind() {
    let (files, _) = good_files();
    let mut routes = HashMap::new();
    routes.insert(
        "/affine/tiny.tar.gz".into(),
        Reply::Truncated(archive("", &files)),
    );
    let base = serve(routes, 1);
    let dir = data_dir("trunc");
    assert!(fetch_sequence(&base, &dir, "tiny").is_err());
    assert!(listing(&dir).is_empty(), "left behind: {:?}", listing(&dir));
    let _ = std::fs::remove_dir_all(&dir);
}

#[test]
fn missing_archive_and_bad_contents_leave_nothing_behind() {
    let (mut files, _) = good_files();
    let mut routes = HashMap::new();
    // An image that does not decode.
    files[1].1 = b"P5 10 9 255\n\x00\x01".to_vec();
    routes.insert(
        "/affine/badimg.tar.gz".into(),
        Reply::Full(archive("", &files)),
    );
    // A malformed homography.
    let (mut files, _) = good_files();
    files[3].1 = b"1 0 0 0 1".to_vec();
    routes.insert(
        "/affine/badh.tar.gz".into(),
        Reply::Full(archive("", &files)),
    );
    // Not a gzip file at all.
    routes.insert(
        "/affine/notgz.tar.gz".into(),
        Reply::Full(b"<html>moved</html>".to_vec()),
    );
    // img3 without H1to3p.
    let (mut files, _) = good_files();
    files.remove(4);
    routes.insert(
        "/affine/noh3.tar.gz".into(),
        Reply::Full(archive("", &files)),
    );
    let base = serve(routes, 5);
    let dir = data_dir("bad");
    for name in ["missing", "badimg", "badh", "notgz", "noh3"] {
        let e = fetch_sequence(&base, &dir, name).unwrap_err().to_string();
        assert!(!e.is_empty());
        assert!(listing(&dir).is_empty(), "{name} left {:?}", listing(&dir));
    }
    assert!(fetch_sequence(&base, &dir, "../escape").is_err());
    let _ = std::fs::remove_dir_all(&dir);
}

/// A folder that cannot be made, or a final rename that fails, is an error naming the path
/// (it used to be the bare system message, "Not a directory (os error 20)"), and no temporary
/// folder is left: the data folder is a file; the sequence's name is taken by a dangling
/// symbolic link (`exists()` does not see it, so the download runs and the rename fails).
#[test]
fn a_failed_folder_or_rename_names_the_path_and_leaves_nothing() {
    let dir = data_dir("names");
    std::fs::create_dir_all(&dir).unwrap();
    let file = dir.join("a-file");
    std::fs::write(&file, "not a folder").unwrap();
    let e = fetch_sequence("http://127.0.0.1:9", &file, "tiny")
        .unwrap_err()
        .to_string();
    assert!(
        e.contains(&file.join("oxford-affine").display().to_string()),
        "{e}"
    );
    #[cfg(unix)]
    {
        let (files, _) = good_files();
        let mut routes = HashMap::new();
        routes.insert(
            "/affine/tiny.tar.gz".into(),
            Reply::Full(archive("", &files)),
        );
        let base = serve(routes, 1);
        let data = dir.join("data");
        let seq = data.join("oxford-affine").join("tiny");
        std::fs::create_dir_all(seq.parent().unwrap()).unwrap();
        std::os::unix::fs::symlink(dir.join("nowhere"), &seq).unwrap();
        let e = fetch_sequence(&base, &data, "tiny")
            .unwrap_err()
            .to_string();
        assert!(e.contains(&seq.display().to_string()), "{e}");
        assert_eq!(listing(&data), vec!["tiny"], "left behind");
        assert!(seq.symlink_metadata().unwrap().file_type().is_symlink());
    }
    let _ = std::fs::remove_dir_all(&dir);
}
