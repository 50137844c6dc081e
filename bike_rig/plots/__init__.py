"""Figures of a session (matplotlib, object API, Agg canvas; never pyplot): the paper's section 10
figures and the lab's own views. Each figure function takes :class:`bike_rig.subjects.Subject`
objects (or core records) and returns a :class:`matplotlib.figure.Figure`; :mod:`.style` saves
them as PNG/SVG or embeds them in the report."""
