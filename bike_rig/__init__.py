"""bike_rig: a bicycle's physical parameters from a pendulum rig, and its Whipple model.

Measure a bicycle's physical parameters on a pendulum rig (Moore et al.) and turn them into the
Whipple benchmark model's eigenvalues.
"""

__version__ = "0.1.0"
