"""Ride validation: measured weave eigenvalues of an instrumented bicycle.

- :mod:`.record`: a ride record (times s, roll rate rad/s, optional speed m/s and steer torque
  N m) and its CSV reader (the bag reader is :mod:`bike_rig.bag.ride`)
- :mod:`.segment`: automatic segmentation of a long record into free decays after kicks
- :mod:`.eigen`: each segment's measured eigenvalue with σ, and segments at one speed combined;
  :mod:`.realmode` the models, :mod:`.choice` which one, :mod:`.noise` the σ, :mod:`.envelope`
  whether a segment is a free decay
- :mod:`.verdict`: the comparison with the model in words; :mod:`.weave_mc` the model's Monte
  Carlo σ where the first-order one is not defined
- :mod:`.ridesim` and :mod:`.calibration`: realistic simulated segments (rider, saturation) and
  the σ's calibration on them
- :mod:`.posterior` and :mod:`.variants`: the parameters' posterior given the rides (the rig's
  covariance the prior) and the model variants compared (rider, gain scale, freed parameters);
  :mod:`.weave_model` the model's weave eigenvalue they fit (continuous or sampled assist)

The prediction and the comparison are in :mod:`bike_rig.pipeline.ride`; the simulated ride in
:mod:`bike_rig.core.sim.ride`.
"""
