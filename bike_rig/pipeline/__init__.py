"""The ROS-free pipeline: one module per stage, in the order the data flows.

* :mod:`.acquire`: trial events and sample batches as plain records;
* :mod:`.fit` (and :mod:`.fit_state`, the live bookkeeping): a trial's batches → its period;
* :mod:`.assemble`: static readings + trial results → the 25 benchmark parameters;
* :mod:`.model`: parameters → canonical matrices, eigenvalues, critical speeds, state space;
* :mod:`.offline`: one runner over a recorded or simulated session, calling the same stages.

The nodes (:mod:`bike_rig.ros.nodes`) are thin adapters around these stages; the offline replay,
simulated sessions and the report run them without a ROS runtime. Nothing here imports ROS.
"""
