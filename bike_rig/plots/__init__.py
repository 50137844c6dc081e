"""Figures of a session: the paper's section 10 figures and the lab's own views.

matplotlib's object API on an Agg canvas, never pyplot. Each figure function takes
:class:`bike_rig.offline.subjects.Subject` objects (or a trial record) and returns a
:class:`matplotlib.figure.Figure`. :mod:`.registry` lists every kind of figure once, for
``bike-rig plot`` and the report; :mod:`.style` saves a figure as PNG/SVG; :mod:`.output`
checks the output directory and names the files.
"""
