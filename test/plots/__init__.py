"""Tests of the figures (bike_rig.plots): the numbers behind each figure, not pixels."""
