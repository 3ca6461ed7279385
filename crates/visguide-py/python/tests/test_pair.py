"""visguide.fd.match_images: the visguide crate's image-pair pipeline (regions -> descriptors ->
matches -> homography), identical to the Rust crate on the same images (tests/reference.json),
from arrays and from files."""

import math

import numpy as np
import pytest
from conftest import synthetic_image

from visguide.fd import match_images

# The settings of `pair_cases` in tests/reference.rs.
MSER = dict(preset="opencv", delta=3, min_area=10, min_diversity=0.0)
SETTINGS = {
    "fd_corr_affine": dict(MSER, ratio=0.8),
    "abs_fd_ssd_canonical": dict(
        MSER,
        method="abs_fd_ssd",
        sampling="canonical",
        ratio=0.9,
        preselection=0.0009,
        ransac_threshold=2.0,
        ransac_iterations=300,
        ransac_confidence=0.99,
        ransac_seed=5,
    ),
}


def images():
    img = synthetic_image()
    return img, np.ascontiguousarray(np.rot90(img))


def nan_to_none(v):
    return None if isinstance(v, float) and math.isnan(v) else v


def check_equal_to_reference(got, ref):
    assert got["frames1"].tolist() == ref["frames1"]
    assert got["frames2"].tolist() == ref["frames2"]
    assert list(got["described"]) == ref["described"]
    a = got["all"]
    rows = [[int(i), int(j), e, r] for i, j, e, r in zip(a["i"], a["j"], a["error"].tolist(), a["ratio"].tolist())]
    assert rows == ref["all"]
    acc = got["accepted"]
    assert len(acc["i"]) == len(ref["accepted"])
    for k, r in enumerate(ref["accepted"]):
        assert [int(acc["i"][k]), int(acc["j"][k]), float(acc["error"][k]), float(acc["ratio"][k])] == r["match"]
        assert nan_to_none(float(acc["rotation"][k])) == r["rotation"]
        affine = acc["affine"][k].ravel().tolist()
        assert (None if all(math.isnan(v) for v in affine) else affine) == r["affine"]
    h, rh = got["homography"], ref["homography"]
    if rh is None:
        assert h is None
    else:
        assert h["H"].ravel().tolist() == rh["H"]
        assert h["inliers"].tolist() == rh["inliers"]
        assert (h["inlier_count"], h["rms"], h["iterations"]) == (rh["inlier_count"], rh["rms"], rh["iterations"])


@pytest.mark.parametrize("case", sorted(SETTINGS))
def test_arrays_give_the_rust_crates_result(reference, case):
    img1, img2 = images()
    check_equal_to_reference(match_images(img1, img2, **SETTINGS[case]), reference["pair"][case])


def write_pgm(path, img):
    h, w = img.shape
    path.write_bytes(b"P5\n%d %d\n255\n" % (w, h) + img.tobytes())


@pytest.mark.parametrize("case", sorted(SETTINGS))
def test_files_give_the_same_result(reference, tmp_path, case):
    img1, img2 = images()
    p1, p2 = tmp_path / "a.pgm", tmp_path / "b.pgm"
    write_pgm(p1, img1)
    write_pgm(p2, img2)
    ref = reference["pair"][case]
    check_equal_to_reference(match_images(p1, str(p2), **SETTINGS[case]), ref)
    # Mixed, and non-contiguous arrays.
    check_equal_to_reference(match_images(img1, p2, **SETTINGS[case]), ref)
    check_equal_to_reference(match_images(img1, np.rot90(img1), **SETTINGS[case]), ref)


def test_the_rotation_is_found():
    img1, img2 = images()
    r = match_images(img1, img2, **SETTINGS["fd_corr_affine"])
    h = r["homography"]
    assert h is not None and h["inlier_count"] >= 4
    H = h["H"] / h["H"][2, 2]
    # np.rot90 maps (x, y) to (y, W - 1 - x).
    w = img1.shape[1]
    expected = np.array([[0.0, 1.0, 0.0], [-1.0, 0.0, w - 1.0], [0.0, 0.0, 1.0]])
    assert np.abs(H - expected).max() < 1e-9
    # Every accepted rotation is the quarter turn (image coordinates, y down).
    rot = r["accepted"]["rotation"]
    assert np.all(np.abs(np.angle(np.exp(1j * (rot + np.pi / 2)))) < 0.1)


def test_without_homography_and_deterministic():
    img1, img2 = images()
    a = match_images(img1, img2, homography=False, **MSER)
    assert a["homography"] is None
    b = match_images(img1, img2, **MSER)
    assert b["homography"] is not None
    assert a["accepted"]["i"].tolist() == b["accepted"]["i"].tolist()
    c = match_images(img1, img2, **MSER)
    assert c["homography"]["H"].tolist() == b["homography"]["H"].tolist()


def test_errors(tmp_path):
    img1, img2 = images()
    with pytest.raises(OSError):
        match_images(tmp_path / "missing.png", img2)
    bad = tmp_path / "bad.png"
    bad.write_bytes(b"not an image")
    with pytest.raises(OSError):
        match_images(img1, bad)
    with pytest.raises(TypeError):
        match_images(img1.astype(np.float32), img2)
    with pytest.raises(TypeError):
        match_images(img1, 42)
    with pytest.raises(TypeError):
        match_images(img1, img2, bogus=1)
    for kw in [
        dict(ratio=0.0),
        dict(ratio=float("nan")),
        dict(preselection=float("inf")),
        dict(method="nope"),
        dict(sampling="nope"),
        dict(preset="nope"),
        dict(delta=0),
        dict(ransac_threshold=-1.0),
        dict(ransac_confidence=1.0),
        dict(ransac_iterations=0),
    ]:
        with pytest.raises(ValueError):
            match_images(img1, img2, **kw)
    with pytest.raises(ValueError):
        match_images(np.zeros((0, 5), np.uint8), img2)
