"""visguide.mser.detect(opencv_compatible=True) against cv2.MSER on a shared Oxford image (needs
opencv-python and VISGUIDE_DATA; skipped with a note otherwise), as the mser crate's Rust
cross-check does against OpenCV 4.6."""

import numpy as np
import pytest
from conftest import oxford_dir

from visguide import mser

cv2 = pytest.importorskip("cv2", reason="opencv-python is not installed: no comparison with cv2.MSER")


def raster_set(points, width):
    """A region's pixels as a hashable key, whatever their order: sorted raster indices."""
    a = np.asarray(points, dtype=np.int64).reshape(-1, 2)
    return np.sort(a[:, 1] * width + a[:, 0]).tobytes()


@pytest.mark.parametrize("sequence", ["graf", "boat"])
def test_opencv_compatible_equals_cv2_mser(sequence):
    d = oxford_dir()
    if d is None:
        pytest.skip("VISGUIDE_DATA/oxford-affine is not available")
    img = cv2.imread(str(d / sequence / "img1.png"), cv2.IMREAD_GRAYSCALE)
    assert img is not None and img.dtype == np.uint8
    cv2.setNumThreads(1)
    # OpenCV 4.x ignores min_diversity on grey images and OpenCV 5 applies its own version of it,
    # so the parameters both versions mean the same way have min_diversity 0.
    params = dict(delta=5, min_area=60, max_area=14400, max_variation=0.25, min_diversity=0.0)
    theirs, _ = cv2.MSER_create(**params).detectRegions(img)
    ours = mser.detect(img, opencv_compatible=True, pixels=True, **params)
    theirs = {raster_set(r, img.shape[1]) for r in theirs}
    ours = {raster_set(r.pixels, img.shape[1]) for r in ours}
    both = len(theirs & ours)
    print(
        f"{sequence} img1, OpenCV {cv2.__version__}: ours {len(ours)}, OpenCV {len(theirs)}; "
        f"OpenCV's in ours {both / len(theirs):.4f}, ours in OpenCV's {both / len(ours):.4f}"
    )
    assert len(theirs) > 500
    assert both / len(theirs) > 0.99 and both / len(ours) > 0.99
