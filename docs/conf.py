"""Sphinx configuration of the bike_rig manual (``make docs``; MyST Markdown pages).

The reference pages are generated from the code at build time: the command line from the
parsers (sphinx-argparse), the topics from ``bike_rig.config.topics`` and each node's parameters from
its ``ParamSpec`` list (:mod:`docs._generate`).
"""

from __future__ import annotations

import sys
from pathlib import Path

HERE = Path(__file__).resolve().parent
sys.path.insert(0, str(HERE.parent))
sys.path.insert(0, str(HERE))

from _generate import write_reference  # noqa: E402

project = "bike_rig"
author = "bike_rig developers"
copyright = "bike_rig developers; derived data BSD-2-Clause, see the data's attribution"
extensions = ["myst_parser", "sphinxarg.ext"]
source_suffix = {".md": "markdown"}
myst_enable_extensions = ["colon_fence", "dollarmath"]
myst_heading_anchors = 3
exclude_patterns = ["_build", "speed-notes.txt"]
html_theme = "alabaster"
html_title = "bike_rig manual"
suppress_warnings = ["myst.xref_missing"]

write_reference(HERE / "reference")
