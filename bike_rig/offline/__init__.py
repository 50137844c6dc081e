"""Recordings and input files read offline: a bag's session, its replay, its timeline, rides, subjects."""
