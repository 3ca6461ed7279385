"""Channel-based tracking (Paper B of the thesis) and its baselines, one frame at a time.

- :class:`CBT` -- grid Bayesian filter on channel-coded densities, with system and observation
  models learned by :meth:`CBT.learn` from lists of ``(truths, detections)`` arrays per frame
  (no associations needed); its keywords are the fields of the crate's ``CbtConfig`` (order,
  layout, clutter handling, fallbacks, priors, pruning, ...; :meth:`CBT.default_config` lists
  them with their defaults, :attr:`CBT.config` returns a model's), and ``self_learning=True`` /
  :meth:`CBT.learn_online` learn incrementally.
- :class:`Kalman` -- constant-velocity Kalman filter with nearest-neighbour gating.
- :class:`ParticleFilter` -- SIR particle filter with a clutter-aware likelihood (seeded).

All three share ``reset((x, y))``, ``step(detections) -> (x, y, certainty)``,
``step_on_grid(detections) -> (x, y, certainty, left_out)`` (detections off CBT's grid are left
out and counted instead of refusing the frame), ``run(start, frames) -> (T, 3) array`` (without
the GIL), ``estimate()``, ``to_json`` / ``from_json``, ``save`` / ``load`` and pickling.
"""

from ._visguide import CBT, Kalman, ParticleFilter

__all__ = ["CBT", "Kalman", "ParticleFilter"]
