"""Region detection and matching over a folder of images, on one machine or a Dask cluster.

Every image is matched against a reference image: MSER regions (Paper A's setting) → outer
contours → Fourier descriptors → symmetric ratio-test matches. Each image is one task; the
reference descriptors are computed once and shipped to the workers. The result of an image
depends only on its bytes (visguide is deterministic and thread-count independent), so the
distributed run returns exactly the sequential one, in the same order.

Why Dask and not Ray: the work is a flat map over files, which ``Client.map`` expresses
directly; ``dask[distributed]`` is pure Python and a ``LocalCluster`` starts in seconds in CI,
where Ray would add a large binary wheel and a cluster runtime for no gain here.

    python dask_scaleout.py FOLDER [REFERENCE] [--workers N]   (images stored as .npy arrays)
"""

import argparse
import pathlib

import numpy as np

from visguide import fd, mser

PARAMS = dict(preset="larsson2009")


def contours(img, params):
    return [r.contour for r in mser.detect(img, contours=True, **params)]


def match_image(path, reference_contours, params=PARAMS):
    """Matches of one image file against the reference: (name, [(query, target, ratio), ...])."""
    img = np.load(path)
    ref = fd.describe(reference_contours)
    m = fd.match(ref, fd.describe(contours(img, params)), ratio=0.8)
    return pathlib.Path(path).name, list(zip(m["query"].tolist(), m["target"].tolist(), m["ratio"].tolist()))


def run_sequential(paths, reference, params=PARAMS):
    ref = contours(np.load(reference), params)
    return [match_image(str(p), ref, params) for p in paths]


def run_dask(paths, reference, client, params=PARAMS):
    ref = client.scatter(contours(np.load(reference), params), broadcast=True)
    futures = client.map(match_image, [str(p) for p in paths], reference_contours=ref, params=params)
    return client.gather(futures)


def main():
    ap = argparse.ArgumentParser()
    ap.add_argument("folder")
    ap.add_argument("reference", nargs="?")
    ap.add_argument("--workers", type=int, default=2)
    args = ap.parse_args()
    paths = sorted(pathlib.Path(args.folder).glob("*.npy"))
    reference = args.reference or paths[0]
    from dask.distributed import Client, LocalCluster

    with LocalCluster(n_workers=args.workers, threads_per_worker=1) as cluster, Client(cluster) as client:
        results = run_dask(paths, reference, client)
    assert results == run_sequential(paths, reference)
    for name, matches in results:
        print(f"{name}: {len(matches)} matches")


if __name__ == "__main__":
    main()
