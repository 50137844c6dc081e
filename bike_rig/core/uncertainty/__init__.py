"""Uncertainty of everything the core computes.

Complex-step Jacobians and covariance propagation (:mod:`.uncertain`), the canonical matrices
with σ (:mod:`.matrix_sigma`), the eigenvalues' σ over speed (:mod:`.eigen_sigma`), the critical
speeds' σ (:mod:`.speed_sigma`) and their Monte Carlo check (:mod:`.speed_mc`), the
uncertainty budget (:mod:`.budget`) and the Monte Carlo σ printed where hanging lines are
nearly parallel (:mod:`.mc_sigma`).

The package imports none of its modules here, so that :mod:`bike_rig.core.benchmark` can use
:mod:`.uncertain` without a cycle.
"""
