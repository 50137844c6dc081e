"""Tests of the session report (:mod:`bike_rig.report`)."""
