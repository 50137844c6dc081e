"""HTML building blocks of the report: escaping, numbers with σ, tables, the page frame.

Every piece of text that reaches the page goes through :func:`esc` (``html.escape``, quotes
included). Numbers with σ are printed with σ to two significant digits and the value to the
same decimal place; each such cell also carries the unrounded numbers in ``data-value`` and
``data-sigma`` attributes (``repr`` of the float), so the page can be checked or scraped
without parsing rounded text. The page has no external CSS, JavaScript or fonts.
"""

from __future__ import annotations

import html
import math
from collections.abc import Iterable, Sequence

from ..core.textfmt import format_value_sigma

__all__ = [
    "Raw",
    "esc",
    "number_cell",
    "page",
    "section",
    "table",
    "value_sigma_cells",
]


#: Significant digits of every σ on the page: None, the one rule (:func:`~bike_rig.core.textfmt.sigma_digits`).
SIGMA_DIGITS: int | None = None


class Raw(str):
    """HTML that is already escaped (built by this module); inserted verbatim."""


def esc(text: object) -> str:
    """``text`` as HTML text, ``&<>"'`` escaped."""
    return html.escape(str(text), quote=True)


def _attr(value: float | None) -> str:
    """A float for a ``data-`` attribute: ``repr`` (round-trips), ``nan`` or ``none``."""
    if value is None:
        return "none"
    return repr(float(value))


def value_sigma_cells(value: float | None, sigma: float | None, unit: str = "") -> Raw:
    """Two ``<td>``: the value and its σ (rounded, see :func:`format_value_sigma`).

    Both cells carry the unrounded ``data-value`` and ``data-sigma``. ``value`` None prints
    "none" (e.g. a bicycle without a weave speed).
    """
    if value is None:
        return Raw('<td class="num" data-value="none">none</td><td class="num sigma"></td>')
    v, s = format_value_sigma(value, sigma, digits=SIGMA_DIGITS)
    data = f' data-value="{_attr(value)}" data-sigma="{_attr(sigma)}"'
    u = f" {esc(unit)}" if unit else ""
    return Raw(f'<td class="num"{data}>{esc(v)}{u}</td><td class="num sigma"{data}>{esc(s)}</td>')


def number_cell(value: float | None, fmt: str = ".4g", unit: str = "") -> Raw:
    """One ``<td>`` with a number printed with ``fmt`` (its exact value in ``data-value``)."""
    if value is None or not math.isfinite(value):
        return Raw(f'<td class="num" data-value="{_attr(value)}">–</td>')
    u = f" {esc(unit)}" if unit else ""
    return Raw(f'<td class="num" data-value="{_attr(value)}">{esc(format(value, fmt))}{u}</td>')


def _cell(c: str) -> str:
    return c if isinstance(c, Raw) else f"<td>{esc(c)}</td>"


def table(
    head: Sequence[str | Raw],
    rows: Iterable[Sequence[str | Raw]],
    css_class: str = "",
    table_id: str = "",
    caption: str = "",
    row_classes: Sequence[str] | None = None,
) -> Raw:
    """A ``<table>``.

    Header entries and plain-text cells are escaped; :class:`Raw` cells (whole ``<td>``
    elements, e.g. from :func:`value_sigma_cells`) are inserted as they are.
    ``row_classes`` gives each body row a CSS class ("" for none).
    """
    attrs = (f' id="{esc(table_id)}"' if table_id else "") + (f' class="{esc(css_class)}"' if css_class else "")
    parts = [f"<table{attrs}>"]
    if caption:
        parts.append(f"<caption>{esc(caption)}</caption>")
    parts.append("<thead><tr>" + "".join(h if isinstance(h, Raw) else f"<th>{esc(h)}</th>" for h in head))
    parts.append("</tr></thead><tbody>")
    for k, row in enumerate(rows):
        cls = row_classes[k] if row_classes is not None and row_classes[k] else ""
        tr = f'<tr class="{esc(cls)}">' if cls else "<tr>"
        parts.append(tr + "".join(_cell(c) for c in row) + "</tr>")
    parts.append("</tbody></table>")
    return Raw("\n".join(parts))


def section(section_id: str, title: str, body: Sequence[str]) -> Raw:
    """A ``<section>`` with an ``<h2>`` heading; ``body`` is HTML (trusted)."""
    return Raw(f'<section id="{esc(section_id)}">\n<h2>{esc(title)}</h2>\n' + "\n".join(body) + "\n</section>")


_CSS = """
body { font-family: sans-serif; margin: 0 auto; max-width: 72rem; padding: 1rem 2rem; color: #222; }
h1 { margin-bottom: 0.2rem; } h2 { border-bottom: 1px solid #bbb; margin-top: 2.2rem; }
nav ul { columns: 3; list-style: none; padding: 0; }
table { border-collapse: collapse; margin: 0.8rem 0; font-size: 0.92rem; max-width: 100%; }
caption { text-align: left; font-weight: bold; padding: 0.3rem 0; }
th, td { border: 1px solid #ccc; padding: 0.15rem 0.4rem; vertical-align: top; }
td.trial-id, td[data-key] { overflow-wrap: anywhere; min-width: 7ch; }
table.trials { font-size: 0.8rem; } table.trials th, table.trials td { padding: 0.1rem 0.25rem; }
th { background: #f0f0f0; }
td.num { text-align: right; font-variant-numeric: tabular-nums; white-space: nowrap; }
td.sigma { color: #555; }
tr.bad td { background: #fff0f0; } tr.unused td { color: #777; }
.note { color: #555; font-style: italic; }
.flag { color: #a00; }
figure { margin: 1.2rem 0; } figure img { max-width: 100%; height: auto; border: 1px solid #ddd; }
figcaption { color: #444; font-size: 0.9rem; }
dl.facts { display: grid; grid-template-columns: max-content auto; gap: 0.2rem 1rem; }
dl.facts dt { font-weight: bold; } dl.facts dd { margin: 0; }
"""


def page(title: str, body: Sequence[str], figures: int) -> str:
    """The whole HTML document (UTF-8, inline CSS, no scripts or external resources).

    Args:
        title: The page title (plain text).
        body: The sections (trusted HTML).
        figures: How many figures the page embeds; stated in ``<main data-figures>`` for
            checks of the rendered page.
    """
    return (
        "<!DOCTYPE html>\n"
        '<html lang="en">\n<head>\n<meta charset="utf-8">\n'
        '<meta name="viewport" content="width=device-width, initial-scale=1">\n'
        f"<title>{esc(title)}</title>\n<style>{_CSS}</style>\n</head>\n"
        f'<body>\n<main id="report" data-figures="{figures}">\n' + "\n".join(body) + "\n</main>\n</body>\n</html>\n"
    )
