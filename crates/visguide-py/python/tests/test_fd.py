"""visguide.fd against the fd-match crate (tests/reference.json): descriptors of MSER contours
for every sampling, matches for every method, and bad input."""

import math

import numpy as np
import pytest
from conftest import fnv1a

from visguide import fd, mser

PARAMS = dict(min_area=10, delta=3, min_diversity=0.0)


def digest(a):
    a = np.ascontiguousarray(a)
    return {"len": a.size * (2 if np.iscomplexobj(a) else 1), "fnv1a": fnv1a(a.astype("<c16" if np.iscomplexobj(a) else "<f8").tobytes())}


def contours(img):
    return [r.contour for r in mser.detect(img, contours=True, **PARAMS)]


def as_json(m):
    out = []
    for i in range(len(m["query"])):
        al = None if math.isnan(m["rotation"][i]) else [m["rotation"][i], m["shift"][i]]
        out.append([int(m["query"][i]), int(m["target"][i]), m["error"][i], m["ratio"][i], al])
    return out


@pytest.mark.parametrize("sampling", fd.SAMPLINGS)
def test_descriptors_and_matches_equal_the_rust_crate(reference, image, sampling):
    ref = reference["fd"][sampling]
    # np.rot90 is a view with a negative stride: it goes through the copy path.
    a = fd.describe(contours(image), sampling=sampling)
    b = fd.describe(contours(np.rot90(image)), sampling=sampling)
    assert a.sampling == sampling and len(a) == len(ref["sources_a"])
    assert a.sources.tolist() == ref["sources_a"] and b.sources.tolist() == ref["sources_b"]
    assert [i for i, _ in a.rejected] == ref["rejected_a"]
    assert digest(a.fd) == ref["fd"]
    assert digest(a.magnitudes) == ref["magnitudes"]
    assert digest(a.afd0) == ref["afd0"]
    assert digest(a.afd1) == ref["afd1"]
    assert np.allclose(a.magnitudes, np.abs(a.fd), rtol=1e-12, atol=0)
    for method in fd.METHODS:
        expected = ref["methods"][method]
        assert as_json(fd.match(a, b, method=method, ratio=None)) == expected["matches"], method
        assert a.min_errors(method).tolist() == expected["min_errors"], method


@pytest.mark.parametrize("sampling", fd.SAMPLINGS)
def test_descriptors_and_matches_are_laid_out_as_documented(image, sampling):
    """``fd`` is ``(k, N-1)`` with unit-norm rows (N = 51 by default), ``magnitudes`` of the
    same shape; ``match`` gives equal-length arrays in ascending ``query``, with
    ``query_contour`` / ``target_contour`` the descriptors' ``sources``."""
    a = fd.describe(contours(image), sampling=sampling)
    b = fd.describe(contours(np.rot90(image)), sampling=sampling)
    assert len(a) > 2 and a.fd.shape == (len(a), 50) and a.magnitudes.shape == a.fd.shape
    assert np.allclose(np.linalg.norm(a.fd, axis=1), 1.0, rtol=0, atol=1e-12)
    for method in fd.METHODS:
        m = fd.match(a, b, method=method, ratio=None)
        assert len({len(v) for v in m.values()}) == 1 and len(m["query"]) > 1, method
        q = m["query"].tolist()
        assert q == sorted(set(q)), method
        assert np.array_equal(m["query_contour"], a.sources[m["query"]]), method
        assert np.array_equal(m["target_contour"], b.sources[m["target"]]), method


def test_ratio_threshold_filters_the_mutual_matches(image):
    a = fd.describe(contours(image))
    b = fd.describe(contours(np.rot90(image)))
    all_ = fd.match(a, b, ratio=None)
    for t in [0.1, 0.5, 0.9]:
        kept = fd.match(a, b, ratio=t)
        keep = all_["ratio"] < t
        for k in all_:
            assert np.array_equal(kept[k], all_[k][keep], equal_nan=True), k
    default = fd.match(a, b)
    assert np.array_equal(default["query"], fd.match(a, b, ratio=0.5)["query"])
    # Without alignment the rotation and shift are NaN.
    ssd = fd.match(a, b, method="abs_fd_ssd", ratio=None)
    assert np.isnan(ssd["rotation"]).all() and np.isnan(ssd["shift"]).all()


def test_rotated_contours_match_with_the_rotation():
    t = np.linspace(0, 2 * np.pi, 200, endpoint=False)
    radius = [20 + 4 * np.cos((s + 2) * t) + 2 * np.sin(3 * t + s) for s in range(4)]
    shapes = [np.c_[r * np.cos(t), r * np.sin(t)] for r in radius]
    phi = 0.6
    rot = np.array([[np.cos(phi), -np.sin(phi)], [np.sin(phi), np.cos(phi)]])
    # Arc-length sampling keeps the orientation (the canonical frame would remove it).
    a = fd.describe(shapes, sampling="arc_length")
    b = fd.describe([1.5 * s @ rot.T + 40 for s in shapes[::-1]], sampling="arc_length")
    m = fd.match(a, b, ratio=None)
    assert m["query"].tolist() == [0, 1, 2, 3] and m["target"].tolist() == [3, 2, 1, 0]
    assert (m["error"] < 1e-3).all()
    assert np.allclose(m["rotation"], phi, atol=1e-2)


def test_integer_float_and_strided_contours_are_the_same():
    t = np.linspace(0, 2 * np.pi, 60, endpoint=False)
    c = np.round(np.c_[30 + 20 * np.cos(t), 30 + 10 * np.sin(t)])
    wide = np.zeros((len(c), 4))
    wide[:, ::2] = c
    d = [fd.describe([x]).fd for x in (c, c.astype(np.int32), wide[:, ::2], np.asfortranarray(c))]
    for x in d[1:]:
        assert np.array_equal(x, d[0])


def test_bad_contours_are_rejected_not_raised():
    d = fd.describe([np.zeros((2, 2)), np.array([[0, 0], [1, 0], [1, 1], [0, 1]]), np.full((5, 2), np.nan)])
    assert len(d) == 1 and d.sources.tolist() == [1]
    assert [i for i, _ in d.rejected] == [0, 2] and all(isinstance(r, str) for _, r in d.rejected)


@pytest.mark.parametrize(
    "call",
    [
        lambda: fd.describe([np.zeros((5, 3))]),
        lambda: fd.describe([], sampling="polar"),
        lambda: fd.describe([], coefficients=50),
        lambda: fd.describe([], samples=10, coefficients=51),
        lambda: fd.match(fd.describe([]), fd.describe([]), method="sad"),
        lambda: fd.match(fd.describe([]), fd.describe([]), ratio=float("nan")),
        lambda: fd.match(fd.describe([]), fd.describe([]), ratio=0.0),
        lambda: fd.match(fd.describe([]), fd.describe([]), ratio=-1.0),
        lambda: fd.match(
            fd.describe([], sampling="canonical"), fd.describe([], sampling="affine")
        ),
        lambda: fd.describe([]).select([3]),
        lambda: fd.describe([]).min_errors("nope"),
    ],
)
def test_bad_input_is_a_value_error(call):
    with pytest.raises(ValueError):
        call()


def test_wrong_types_are_type_errors():
    with pytest.raises(TypeError):
        fd.describe(np.zeros((5, 2)))
    with pytest.raises(TypeError):
        fd.describe([np.zeros(5)])
    with pytest.raises(TypeError):
        fd.match([], [])


def test_select_and_sets_with_different_configurations(image):
    a = fd.describe(contours(image))
    s = a.select([2, 0])
    assert s.sources.tolist() == [a.sources[2], a.sources[0]]
    assert np.array_equal(s.fd, a.fd[[2, 0]])
    assert "Descriptors(len=2" in repr(s)
    with pytest.raises(ValueError):
        fd.match(a, fd.describe(contours(image), coefficients=21))
