"""visguide.mser against the Rust crate's regions (tests/reference.json), array layouts, dtypes
and parameter errors."""

import numpy as np
import pytest
from conftest import points_digest

from visguide import mser

CASES = {
    "opencv_min_area_10": dict(preset="opencv", min_area=10, delta=3, min_diversity=0.0),
    "larsson2009_min_area_10": dict(preset="larsson2009", min_area=10),
}


def as_json(r):
    """A Region in the layout of tests/reference.json."""
    return {
        "polarity": r.polarity,
        "level": r.level,
        "seed": list(r.seed),
        "area": r.area,
        "variation": r.variation,
        "bbox": list(r.bbox),
        "moments": list(r.moments),
        "ellipse": list(r.ellipse),
        "pixels": points_digest(r.pixels),
        "contour": r.contour.tolist(),
    }


@pytest.mark.parametrize("case", sorted(CASES))
def test_regions_equal_the_rust_crate(reference, image, case):
    expected = reference["mser"][case]
    got = mser.detect(image, pixels=True, contours=True, **CASES[case])
    assert len(expected) >= 2
    assert [as_json(r) for r in got] == expected


def test_opencv_compatible_skips_the_outer_ring(reference, image):
    expected = reference["mser"]["inner_ring_pixels_min_area_10"]
    got = mser.detect(image, opencv_compatible=True, pixels=True, **CASES["opencv_min_area_10"])
    assert [points_digest(r.pixels) for r in got] == expected
    h, w = image.shape
    for r in got:
        x, y = r.pixels[:, 0], r.pixels[:, 1]
        assert x.min() >= 1 and y.min() >= 1 and x.max() <= w - 2 and y.max() <= h - 2
        # Everything else is shifted consistently with the pixels.
        assert r.area == len(r.pixels)
        assert r.bbox == (x.min(), y.min(), x.max(), y.max())
        assert r.seed == tuple(r.pixels[0])
        n, sx, sy, sxx, sxy, syy = r.moments
        assert (n, sx, sy) == (len(x), x.sum(), y.sum())
        assert (sxx, sxy, syy) == ((x * x).sum(), (x * y).sum(), (y * y).sum())
        u, v = r.ellipse[:2]
        assert u == pytest.approx(x.mean(), abs=1e-12) and v == pytest.approx(y.mean(), abs=1e-12)


def test_opencv_compatible_ignores_min_diversity_like_opencv_4(image):
    a = mser.detect(image, opencv_compatible=True, min_area=10, min_diversity=0.0)
    b = mser.detect(image, opencv_compatible=True, min_area=10, min_diversity=0.9)
    assert [r.seed for r in a] == [r.seed for r in b]


def signature(regions):
    return [(r.polarity, r.level, r.seed, r.area, r.pixels.tolist()) for r in regions]


def test_any_strides_give_the_same_regions(image):
    ref = signature(mser.detect(image, min_area=10, pixels=True))
    big = np.zeros((image.shape[0] + 10, image.shape[1] + 30), dtype=np.uint8)
    big[4 : 4 + image.shape[0], 7 : 7 + image.shape[1]] = image
    views = {
        "row stride > width (read in place)": big[4 : 4 + image.shape[0], 7 : 7 + image.shape[1]],
        "Fortran order": np.asfortranarray(image),
        "transposed twice": image.T.copy().T,
        "column step": np.repeat(image, 2, axis=1)[:, ::2],
        "negative row stride": image[::-1].copy()[::-1],
        "negative column stride": image[:, ::-1].copy()[:, ::-1],
        "read-only": np.frombuffer(image.tobytes(), dtype=np.uint8).reshape(image.shape),
    }
    for name, v in views.items():
        assert not v.flags.writeable or name != "read-only"
        assert np.array_equal(v, image), name
        assert signature(mser.detect(v, min_area=10, pixels=True)) == ref, name


def test_a_sub_image_is_detected_as_its_own_image(image):
    sub = image[10:60, 20:90]
    assert signature(mser.detect(sub, min_area=10, pixels=True)) == signature(
        mser.detect(np.ascontiguousarray(sub), min_area=10, pixels=True)
    )


@pytest.mark.parametrize(
    "bad",
    [
        np.zeros((8, 8), dtype=np.float64),
        np.zeros((8, 8), dtype=np.int16),
        np.zeros((8, 8), dtype=np.int8),
        np.zeros((8, 8), dtype=bool),
        np.zeros((8, 8, 3), dtype=np.uint8),
        np.zeros(8, dtype=np.uint8),
        [[1, 2], [3, 4]],
        "image",
        None,
    ],
)
def test_wrong_dtype_or_rank_is_a_type_error(bad):
    with pytest.raises(TypeError):
        mser.detect(bad)


@pytest.mark.parametrize(
    "kwargs",
    [
        dict(delta=0),
        dict(delta=256),
        dict(delta=-1),
        dict(min_area=-5),
        dict(min_area=0),
        dict(min_area=100, max_area=10),
        dict(max_variation=float("nan")),
        dict(max_variation=-1.0),
        dict(min_diversity=1.5),
        dict(polarities="up"),
        dict(variation="downward"),
        dict(preset="vlfeat"),
        dict(opencv_compatible=True, polarities="dark"),
    ],
)
def test_bad_parameters_are_value_errors(image, kwargs):
    with pytest.raises(ValueError):
        mser.detect(image, **kwargs)


def test_empty_images_are_value_errors():
    for shape in [(0, 5), (5, 0), (0, 0)]:
        with pytest.raises(ValueError, match="empty image"):
            mser.detect(np.zeros(shape, dtype=np.uint8))


def test_tiny_images_work():
    assert mser.detect(np.zeros((1, 1), dtype=np.uint8)) == []
    assert mser.detect(np.zeros((2, 2), dtype=np.uint8), opencv_compatible=True) == []


def test_presets():
    assert mser.preset("opencv") == dict(
        delta=5,
        min_area=60,
        max_area=14400,
        max_variation=0.25,
        min_diversity=0.2,
        polarities="both",
        variation="symmetric",
    )
    larsson = mser.preset("larsson2009")
    assert (larsson["delta"], larsson["min_area"], larsson["max_area"]) == (15, 50, None)
    for name in mser.PRESETS:
        mser.preset(name)
    with pytest.raises(ValueError):
        mser.preset("nope")


@pytest.mark.parametrize("name", mser.PRESETS)
def test_preset_values_are_what_detect_uses(image, name):
    explicit = mser.detect(image, **mser.preset(name), pixels=True)
    assert signature(explicit) == signature(mser.detect(image, preset=name, pixels=True))


def test_unknown_keywords_are_type_errors(image):
    with pytest.raises(TypeError, match="min_size"):
        mser.detect(image, min_size=3)


def test_polarities_split_the_regions(image):
    both = mser.detect(image, min_area=10)
    dark = mser.detect(image, min_area=10, polarities="dark")
    bright = mser.detect(image, min_area=10, polarities="bright")
    assert [r.seed for r in both] == [r.seed for r in dark + bright]
    assert {r.polarity for r in dark} <= {"dark"} and {r.polarity for r in bright} <= {"bright"}
    # Bright regions of the image are dark regions of its negative (levels mapped back).
    neg = mser.detect(255 - image, min_area=10, polarities="dark")
    assert len(bright) > 0
    assert sorted((r.seed, r.area, r.level) for r in bright) == sorted(
        (r.seed, r.area, 255 - r.level) for r in neg
    )


def test_pixels_and_contours_only_on_request(image):
    r = mser.detect(image, min_area=10)[0]
    assert r.pixels is None and r.contour is None
    r = mser.detect(image, min_area=10, contours=True)[0]
    assert r.pixels is None and r.contour.dtype == np.int32 and r.contour.shape[1] == 2
    assert "Region(" in repr(r)


def test_ellipse_scaled(image):
    r = mser.detect(image, min_area=10)[0]
    assert r.ellipse_scaled(2.0) == r.ellipse
    u, v, a, b, c = r.ellipse_scaled(1.0)
    assert a == pytest.approx(4 * r.ellipse[2])
    # 0, NaN, and scales whose square under- or overflows (these used to panic in Rust).
    for bad in (0.0, -1.0, float("nan"), float("inf"), 1e-200, 1e200):
        with pytest.raises(ValueError):
            r.ellipse_scaled(bad)


@pytest.mark.parametrize("kwargs", [dict(min_area=5, delta=2), dict(CASES["opencv_min_area_10"], opencv_compatible=True)])
def test_regions_are_what_the_docs_say(image, kwargs):
    """The module's order (dark first, then bright; dark by ascending, bright by descending
    level; then the first pixel's row and column) and each Region attribute's documented
    meaning: level, seed, pixels in raster order, the contour counter-clockwise on screen from
    the seed, the inclusive bbox, the raw moments and the centroid."""
    regions = mser.detect(image, pixels=True, contours=True, **kwargs)
    assert {r.polarity for r in regions} == {"dark", "bright"}
    keys = [
        (r.polarity == "bright", r.level if r.polarity == "dark" else 255 - r.level, r.seed[1], r.seed[0])
        for r in regions
    ]
    assert keys == sorted(keys) and len(set(keys)) == len(keys)
    for r in regions:
        x, y = r.pixels[:, 0].astype(np.int64), r.pixels[:, 1].astype(np.int64)
        values = image[y, x]
        # The level is the region's brightest pixel (dark regions) or its darkest (bright ones).
        assert r.level == (values.max() if r.polarity == "dark" else values.min())
        assert np.array_equal(np.lexsort((x, y)), np.arange(len(x))), "not in raster order"
        assert r.seed == (x[0], y[0]) and r.area == len(x)
        assert r.bbox == (x.min(), y.min(), x.max(), y.max())
        assert r.moments == (len(x), x.sum(), y.sum(), (x * x).sum(), (x * y).sum(), (y * y).sum())
        assert r.centroid == pytest.approx((x.mean(), y.mean()), abs=1e-12)
        c = r.contour.astype(np.int64)
        assert tuple(c[0]) == r.seed
        # Counter-clockwise on screen (y down): a negative shoelace sum (0 for a chain).
        assert (c[:, 0] * np.roll(c[:, 1], -1) - np.roll(c[:, 0], -1) * c[:, 1]).sum() <= 0
        # Every contour point is a region pixel.
        assert set(map(tuple, c.tolist())) <= set(zip(x.tolist(), y.tolist()))
