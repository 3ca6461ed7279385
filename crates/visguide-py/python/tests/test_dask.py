"""The Dask scale-out example on a local two-worker cluster gives exactly the sequential result
(skipped with a note when dask.distributed is not installed)."""

import pathlib
import sys

import numpy as np
import pytest
from conftest import synthetic_image

pytest.importorskip("distributed", reason="dask[distributed] is not installed: no scale-out test")
from dask.distributed import Client, LocalCluster  # noqa: E402

sys.path.insert(0, str(pathlib.Path(__file__).resolve().parents[1] / "examples"))
import dask_scaleout  # noqa: E402


def test_dask_run_equals_the_sequential_run(tmp_path):
    base = synthetic_image(160, 120)
    rng = np.random.default_rng(5)
    images = [base, np.rot90(base), base[:, ::-1], np.clip(base.astype(int) + rng.integers(-3, 4, base.shape), 0, 255)]
    for i, img in enumerate(images * 2):
        np.save(tmp_path / f"img{i}.npy", np.ascontiguousarray(img, dtype=np.uint8))
    paths = sorted(tmp_path.glob("*.npy"))
    params = dict(min_area=10, delta=3, min_diversity=0.0)
    sequential = dask_scaleout.run_sequential(paths, paths[0], params)
    assert len(sequential) == 8 and sum(len(m) for _, m in sequential) > 0
    with LocalCluster(n_workers=2, threads_per_worker=1, processes=True, dashboard_address=None) as cluster:
        with Client(cluster) as client:
            distributed = dask_scaleout.run_dask(paths, paths[0], client, params)
    assert distributed == sequential
