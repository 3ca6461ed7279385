"""visguide: Methods for Visually Guided Robotic Systems (F. Larsson, 2009) from Rust, for NumPy.

Submodules:

- :mod:`visguide.mser` -- Maximally Stable Extremal Regions on 2-D ``uint8`` arrays.
- :mod:`visguide.lwpr` -- Locally Weighted Projection Regression (``LWPR``).
- :mod:`visguide.fd` -- Fourier descriptors of contours, matched by correlation.

Errors: ``ValueError`` for bad input, ``OSError`` for files, ``TypeError`` for arrays of the
wrong dtype or rank.
"""

from . import fd, lwpr, mser

__all__ = ["fd", "lwpr", "mser"]
