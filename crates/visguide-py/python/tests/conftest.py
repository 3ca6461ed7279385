"""Shared inputs of the visguide tests: the reference values that the Rust crates compute
(``tests/reference.json``, checked by ``cargo test -p visguide-py --test reference``) and the
synthetic image they were computed on."""

import json
import os
import pathlib

import numpy as np
import pytest

CRATE = pathlib.Path(__file__).resolve().parents[2]
REFERENCE = CRATE / "tests" / "reference.json"

with open(REFERENCE) as _f:
    _REFERENCE = json.load(_f)

# (cx, cy, r², level) of the test image's discs, as tests/reference.rs defines them.
DISCS = [tuple(d) for d in _REFERENCE["image"]["discs"]]


def fnv1a(data: bytes) -> str:
    """FNV-1a (64 bit) as a hex string, the digest tests/reference.rs stores for large arrays."""
    h = 0xCBF29CE484222325
    for b in data:
        h = ((h ^ b) * 0x100000001B3) & 0xFFFFFFFFFFFFFFFF
    return f"{h:016x}"


def points_digest(points) -> dict:
    """Length and digest of an (N, 2) point array (little-endian u32 x, y per point)."""
    a = np.asarray(points, dtype="<u4").reshape(-1, 2)
    return {"len": len(a), "fnv1a": fnv1a(a.tobytes())}


def bytes_digest(data: bytes) -> dict:
    return {"len": len(data), "fnv1a": fnv1a(data)}


def synthetic_image(width=96, height=72):
    """The test image of tests/reference.rs (discs on a ramp), as a (height, width) uint8 array."""
    y, x = np.mgrid[0:height, 0:width].astype(np.int64)
    img = 100 + (x * 5 + y * 3) % 23
    done = np.zeros(img.shape, dtype=bool)
    for cx, cy, r2, level in DISCS:
        inside = ((x - cx) ** 2 + (y - cy) ** 2 < r2) & ~done
        img[inside] = (level + (x + y) % 3)[inside]
        done |= inside
    return img.astype(np.uint8)


@pytest.fixture(scope="session")
def reference():
    return _REFERENCE


@pytest.fixture(scope="session")
def image(reference):
    """The image the reference values were computed on (its digest checks the formula)."""
    img = synthetic_image(reference["image"]["width"], reference["image"]["height"])
    assert bytes_digest(img.tobytes()) == reference["image"]["pixels"]
    return img


def oxford_dir():
    """VISGUIDE_DATA/oxford-affine, or None (tests that need it skip)."""
    root = os.environ.get("VISGUIDE_DATA")
    if not root:
        return None
    d = pathlib.Path(root) / "oxford-affine"
    return d if d.is_dir() else None
