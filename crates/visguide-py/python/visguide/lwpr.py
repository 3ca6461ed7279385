"""Locally Weighted Projection Regression (Vijayakumar, D'Souza & Schaal 2005).

:class:`LWPR` has the vocabulary of the reference library's Python module (``update``,
``predict``, ``predict_conf``, ``predict_J``, ``rf_center``, ``rf_D`` and the meta-parameters
``init_D``, ``init_alpha``, ``w_gen``, ... as attributes), plus ``update_batch`` /
``predict_batch`` over arrays (without the GIL), ``save`` / ``load``, ``to_bytes`` /
``from_bytes`` and pickling. ``write_XML`` / ``read_XML`` (and ``LWPR(filename)``) use the
reference library's XML model files, so models move between it and this package. Training is the Rust crate's, number for number.

>>> import numpy as np
>>> from visguide.lwpr import LWPR
>>> model = LWPR(1, 1)
>>> model.init_D = [[20.0]]
>>> x = np.linspace(0, 1, 500)[:, None]
>>> _ = model.update_batch(x, 2 * x)
>>> bool(abs(model.predict([0.5])[0] - 1.0) < 0.05)
True
"""

from ._visguide import LWPR

__all__ = ["LWPR"]
