"""Python overhead of visguide: the same MSER detection and LWPR batch update called from Python
and from Rust (examples/overhead.rs, on the same bytes), and cv2.MSER.detectRegions in the same
process. Thread CPU time (time.thread_time and clock_gettime(CLOCK_THREAD_CPUTIME_ID), the same
clock), median over 5 blocks of the mean of REPS runs, because the machine may be shared.

Before timing, the outputs are asserted equal: every field of every MSER region bit for bit
(floats compared by their IEEE bits), and the trained LWPR model's binary form byte for byte.

    python overhead.py IMAGE.png [REPS]    (needs opencv-python to read the image, and cargo)
"""

import json
import pathlib
import struct
import subprocess
import sys
import tempfile
import time

import cv2
import numpy as np

from visguide import lwpr, mser


def median_cpu(reps, f):
    """Seconds of thread CPU time per call: median over 5 blocks of the mean of REPS calls (as
    the Rust side measures)."""
    t = []
    for _ in range(5):
        t0 = time.thread_time()
        for _ in range(reps):
            f()
        t.append((time.thread_time() - t0) / reps)
    return sorted(t)[2]


def bits(v):
    """The IEEE-754 bits of a float, as Rust's f64::to_bits."""
    return str(struct.unpack("<Q", struct.pack("<d", v))[0])


def region_line(r):
    """One region as examples/overhead.rs writes it."""
    floats = [r.variation, *r.centroid, *r.ellipse]
    ints = [r.level, *r.seed, r.area, *r.bbox, *r.moments]
    return " ".join([r.polarity, *map(str, ints), *map(bits, floats)])


def main():
    path = sys.argv[1]
    reps = int(sys.argv[2]) if len(sys.argv) > 2 else 21
    img = cv2.imread(path, cv2.IMREAD_GRAYSCALE)
    h, w = img.shape
    rng = np.random.default_rng(0)
    x = rng.uniform(-1, 1, (20000, 2))
    y = np.maximum.reduce([np.exp(-10 * x[:, 0] ** 2), np.exp(-50 * x[:, 1] ** 2), 1.25 * np.exp(-5 * (x**2).sum(1))])
    y = (y + rng.normal(0, 0.1, len(y)))[:, None]
    tmp = pathlib.Path(tempfile.mkdtemp())
    (tmp / "img.raw").write_bytes(img.tobytes())
    (tmp / "samples.f64").write_bytes(np.c_[x, y].astype("<f8").tobytes())
    crate = pathlib.Path(__file__).resolve().parents[2]
    out = subprocess.run(
        ["cargo", "run", "-q", "--release", "-p", "visguide-py", "--example", "overhead", "--",
         str(tmp / "img.raw"), str(w), str(h), str(tmp / "samples.f64"), str(reps), str(tmp)],
        cwd=crate, check=True, capture_output=True, text=True,
    ).stdout
    rust = json.loads(out)

    regions = mser.detect(img)
    assert len(regions) == rust["mser_regions"], (len(regions), rust["mser_regions"])
    rust_lines = (tmp / "regions.txt").read_text().splitlines()
    for i, (ours, theirs) in enumerate(zip(map(region_line, regions), rust_lines)):
        assert ours == theirs, f"region {i} differs:\n  Python {ours}\n  Rust   {theirs}"
    py_mser = median_cpu(reps, lambda: mser.detect(img))
    cv2.setNumThreads(1)
    cv = cv2.MSER_create(delta=5, min_area=60, max_area=14400, max_variation=0.25, min_diversity=0.2)
    cv_regions = len(cv.detectRegions(img)[0])
    cv_mser = median_cpu(reps, lambda: cv.detectRegions(img))

    def train():
        m = lwpr.LWPR(2, 1)
        m.init_D = 50 * np.eye(2)
        m.init_alpha = 250 * np.ones((2, 2))
        m.update_batch(x, y)
        train.model = m

    py_lwpr = median_cpu(reps, train)
    m = train.model
    assert m.to_bytes() == (tmp / "model.bin").read_bytes(), "the LWPR models differ"
    print(f"image {path} ({w}x{h}), thread CPU time per call (median of 5 blocks of {reps} calls)")
    print("outputs asserted equal: every region bit for bit, the LWPR model byte for byte")
    print(f"mser.detect (Python)        {py_mser * 1e3:8.2f} ms  {len(regions)} regions")
    print(f"mser::detect (Rust)         {rust['mser_cpu_s'] * 1e3:8.2f} ms  ratio {py_mser / rust['mser_cpu_s']:.3f}")
    print(f"cv2 MSER.detectRegions      {cv_mser * 1e3:8.2f} ms  {cv_regions} regions (OpenCV {cv2.__version__})")
    print(f"LWPR.update_batch (Python)  {py_lwpr * 1e3:8.2f} ms  {len(x)} samples")
    print(f"Lwpr::update_into (Rust)    {rust['lwpr_cpu_s'] * 1e3:8.2f} ms  ratio {py_lwpr / rust['lwpr_cpu_s']:.3f}")


if __name__ == "__main__":
    main()
