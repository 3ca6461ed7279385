"""Fourier descriptors of closed contours matched by correlation (Larsson, Felsberg & Forssén,
DICTA 2009; Paper A of the thesis).

``describe(contours, sampling=...)`` turns a list of ``(N, 2)`` contour arrays (e.g. the
``contour`` of :func:`visguide.mser.detect` regions) into :class:`Descriptors`;
``match(a, b, method=..., ratio=0.5)`` returns the symmetric ratio-test matches with, for
``"fd_corr"``, the rotation and start-point shift of each pair.

``match_images(image1, image2, ...)`` runs the whole chain of the ``visguide`` crate on two
images (arrays or files): MSER regions, their contours' descriptors, symmetric matches with the
ratio test, each match's rotation and local affine map, and a seeded RANSAC homography with its
inliers -- the same numbers as the Rust crate and the ``visguide match`` command.

Samplings: ``"arc_length"``, ``"affine"`` (default), ``"canonical"``. Methods: ``"fd_corr"``
(default), ``"abs_fd_ssd"``, ``"afd0_ssd"``, ``"afd1_ssd"``, ``"fd_ssd"``.
"""

from ._visguide import Descriptors, describe
from ._visguide import match as match
from ._visguide import match_images

SAMPLINGS = ("arc_length", "affine", "canonical")
METHODS = ("fd_corr", "abs_fd_ssd", "afd0_ssd", "afd1_ssd", "fd_ssd")

__all__ = ["METHODS", "SAMPLINGS", "Descriptors", "describe", "match", "match_images"]
