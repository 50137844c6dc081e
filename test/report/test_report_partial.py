"""An incomplete session bag: a partial report; the commands that need its parameters refuse it.

The report says what is missing and shows the trials; ``plot`` draws the trial figures and says
what is missing; ``params``, ``model``, ``budget`` and a model figure end in one line naming the
missing keys.
"""

from __future__ import annotations

import dataclasses
import re
from pathlib import Path

import matplotlib.pyplot as plt
import pytest
from matplotlib.text import Text

from bike_rig.bag.simulated import write_simulated_bag
from bike_rig.offline.subjects import SubjectError, load_parameters, load_subject
from bike_rig.plots.registry import FIGURES
from test.support.cli import run_cli
from test.support.simulated import short_session

#: The measurement keys whose trials are kept; every other key is missing.
KEPT = 3


@pytest.fixture(scope="module")
def incomplete_bag(tmp_path_factory: pytest.TempPathFactory) -> tuple[Path, tuple[str, ...]]:
    """A simulated session with only the trials of its first keys; the other keys are missing."""
    session = short_session()
    keys = list(dict.fromkeys(t.key for t in session.trials))
    kept = set(keys[:KEPT])
    partial = dataclasses.replace(session, trials=tuple(t for t in session.trials if t.key in kept))
    bag = write_simulated_bag(tmp_path_factory.mktemp("partial") / "bag", partial, pause_s=2.0)
    return bag, tuple(keys[KEPT:])


def test_the_subject_is_partial(incomplete_bag: tuple[Path, tuple[str, ...]]) -> None:
    bag, missing = incomplete_bag
    with pytest.raises(SubjectError, match="incomplete: no usable trial for"):
        load_subject(bag)
    subject = load_subject(bag, partial=True)
    assert not subject.complete and set(subject.missing) == set(missing)
    assert len({t.key for t in subject.trials}) == KEPT
    with pytest.raises(SubjectError, match=re.escape(missing[0])):
        _ = subject.parameters
    with pytest.raises(SubjectError, match=re.escape(missing[-1])):
        load_parameters(bag)


def test_report_of_an_incomplete_bag_is_partial(incomplete_bag: tuple[Path, tuple[str, ...]], tmp_path: Path) -> None:
    bag, missing = incomplete_bag
    out = tmp_path / "out"
    code, _, err = run_cli("report", str(bag), "-o", str(out), "-j", "1")
    assert code == 0, err
    html = (out / "index.html").read_text(encoding="utf-8")
    assert "partial bicycle parameter report" in html
    header = html[html.index('<header id="top">') : html.index("</header>")]
    assert "<dt>missing</dt>" in header and all(k in header for k in missing)
    assert 'id="table-trials"' in html and 'id="table-timeline"' in html and 'id="table-readings"' in html
    assert 'id="fig-trial-overview"' in html and 'id="fig-fit-1"' in html
    assert 'id="table-parameters"' not in html and 'id="fig-side-view"' not in html
    for sid in ("parameters", "model", "budget"):
        sec = html[html.index(f'<section id="{sid}">') :]
        sec = sec[: sec.index("</section>")]
        assert "Not computed" in sec and missing[0] in sec and "<table" not in sec


@pytest.mark.parametrize("command", ["budget", "model", "params"])
def test_commands_needing_parameters_refuse(incomplete_bag: tuple[Path, tuple[str, ...]], command: str) -> None:
    bag, missing = incomplete_bag
    code, out, err = run_cli(command, str(bag))
    assert code != 0 and not out.strip()
    lines = err.strip().splitlines()
    assert len(lines) == 1 and "Traceback" not in err
    assert str(bag) in lines[0] and "incomplete" in lines[0] and all(k in lines[0] for k in missing)


def test_plot_of_an_incomplete_bag_draws_its_trials_and_says_what_is_missing(
    incomplete_bag: tuple[Path, tuple[str, ...]], tmp_path: Path
) -> None:
    bag, missing = incomplete_bag
    subject = load_subject(bag, partial=True)
    for kind in ("trials", "all"):
        out = tmp_path / kind
        code, written, err = run_cli("plot", kind, str(bag), "-o", str(out))
        assert code == 0, err
        files = sorted(Path(p).name for p in written.split())
        # the overview and one fit per trial it has; no model figure (it has no parameters)
        fits = [f for f in files if f.startswith("fit_browser_")]
        assert "trials_browser.png" in files and len(files) == 1 + len(fits)
        assert len(fits) == (len(subject.trials) if kind == "all" else 0)
        assert sorted(p.name for p in out.iterdir()) == files
        note = err.strip().splitlines()
        assert len(note) == 1 and "Traceback" not in err
        assert str(bag) in note[0] and "incomplete" in note[0] and all(k in note[0] for k in missing)
        assert ("no eigen, locus, modes, bode, side figures" in note[0]) == (kind == "all")
    fig = FIGURES["trials"].draw(subject)
    heading = [t.get_text() for t in fig.findobj(Text) if "incomplete session" in t.get_text()]
    assert len(heading) == 1 and all(k in heading[0] for k in missing)  # the figure says it too
    plt.close(fig)


def test_plot_of_a_model_figure_of_an_incomplete_bag_is_refused(
    incomplete_bag: tuple[Path, tuple[str, ...]], tmp_path: Path
) -> None:
    bag, missing = incomplete_bag
    code, out, err = run_cli("plot", "eigen", str(bag), "-o", str(tmp_path / "figs"))
    assert code == 2 and not out.strip()
    lines = err.strip().splitlines()
    assert len(lines) == 1 and "Traceback" not in err
    assert str(bag) in lines[0] and "incomplete" in lines[0] and all(k in lines[0] for k in missing)
    assert not any((tmp_path / "figs").iterdir())
