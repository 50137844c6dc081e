"""Physically impossible but well-formed inputs: no command may print a result that breaks a plausibility rule.

Each input is a valid file (a parameter file, or a ``Measured.txt``) with values changed to
break one rule of :mod:`bike_rig.core.plausibility` on purpose (a negative mass, λ beyond ±π/2,
a tensor that is not positive definite, a compound period too short for its arm, a frame's
torsional period of minutes...) or changed at random (which may or may not break one). Each is
run through ``bike-rig params`` (and every few through ``model``) in this process; then:

* exit status 2: one error line on stderr, nothing on stdout (``refused``);
* exit status 0: the parameters, computed again without the layer (the readers alone, and
  :func:`~bike_rig.core.benchmark.compute_parameters`), must break no rule (``ok``); one that does is
  a ``violation``;
* anything else (a traceback, a numpy warning, another status) is a ``crash``.

Input ``i`` is made by ``random.Random(f"{seed}:physics:{i}")``: any failure is reproduced from
the seed and the index (:func:`physics_input`). The suite runs a small seeded campaign
(test/fuzz/test_physics_fuzz.py); ``tools/fuzz.py --reader physics`` the long one.
"""

from __future__ import annotations

import contextlib
import io
import math
import random
import re
import warnings
from collections.abc import Callable
from dataclasses import dataclass, field
from pathlib import Path

from bike_rig.cli.main import main
from bike_rig.config.paths import config_file
from bike_rig.core.benchmark import ParameterSet, compute_parameters
from bike_rig.core.errors import BikeRigError
from bike_rig.core.io_bp import read_bp_measured
from bike_rig.core.io_yaml import load_yaml_document, parameters_from_document
from bike_rig.core.plausibility import violations
from bike_rig.core.reading_ranges import UnitMistakeWarning
from bike_rig.core.symbols import PARAMETER_NAMES
from test.support.paper import shared_dir

__all__ = ["PhysicsInput", "PhysicsTally", "physics_campaign", "physics_input"]

BENCHMARK = config_file("bicycles/benchmark.yaml")
KINDS = ("refused", "ok", "violation", "crash")


@dataclass(frozen=True)
class PhysicsInput:
    """One input: the file's text, its suffix and the rule it was made to break ("random": none in particular)."""

    text: str
    suffix: str
    rule: str


def _browser_measured() -> str:
    return (shared_dir() / "data" / "bicycleparameters" / "Browser" / "RawData" / "BrowserMeasured.txt").read_text()


def _set_parameter(text: str, key: str, value: float) -> str:
    out, n = re.subn(rf"^  {key}: \[.*\]$", f"  {key}: [{value!r}, 0.0]", text, flags=re.M)
    assert n == 1, key
    return out


def _set_reading(text: str, key: str, value: float) -> str:
    out, n = re.subn(rf"^{key} = .*$", f"{key} = {value!r}+/-0.001", text, flags=re.M)
    assert n == 1, key
    return out


def _value(text: str, key: str) -> float:
    found = re.search(rf"^(?:  {key}: \[|{key} = )([-+]?[0-9.]+(?:[eE][-+]?\d+)?)", text, flags=re.M)
    assert found is not None, key
    return float(found.group(1))


def _parameter_rules(rng: random.Random, base: str) -> list[tuple[str, dict[str, float]]]:
    """Each rule of the layer broken in the benchmark bicycle's parameter file: (rule, changed values)."""

    def v(key: str) -> float:
        return _value(base, key)

    big = rng.uniform(1.05, 4.0)
    return [
        ("mass", {rng.choice(["mB", "mF", "mH", "mR"]): rng.choice([0.0, -rng.uniform(0.01, 90.0)])}),
        ("gravity", {"g": rng.choice([0.0, -9.81, -rng.uniform(0.0, 20.0)])}),
        ("length", {rng.choice(["rR", "rF", "w"]): rng.choice([0.0, -rng.uniform(0.0, 2.0)])}),
        ("tilt", {"lam": rng.choice([1.0, -1.0]) * rng.choice([math.pi / 2, rng.uniform(math.pi / 2, 10.0)])}),
        (
            "inertia",
            {rng.choice([n for n in PARAMETER_NAMES if n.startswith("I") and "xz" not in n]): -rng.uniform(0.0, 10.0)},
        ),
        ("definite", {"IBxz": rng.choice([1, -1]) * math.sqrt(v("IBxx") * v("IBzz")) * big}),
        ("definite", {"IHxz": rng.choice([1, -1]) * math.sqrt(v("IHxx") * v("IHzz")) * big}),
        ("triangle", {"IRyy": 2.0 * v("IRxx") * rng.uniform(1.06, 4.0)}),
        ("triangle", {"IFyy": 2.0 * v("IFxx") * rng.uniform(1.06, 4.0)}),
        ("triangle", {"IByy": (v("IBxx") + v("IBzz")) * rng.uniform(1.1, 4.0)}),
        ("ground", {rng.choice(["zB", "zH"]): rng.uniform(0.0, 2.0)}),
    ]


def _reading_rules(rng: random.Random, base: str) -> list[tuple[str, dict[str, float]]]:
    """Rules broken through the raw readings of Browser's Measured.txt."""
    g = _value(base, "g")
    short = {}
    for p in "RF":
        need = 2 * math.pi * math.sqrt(_value(base, f"l{p}") / g)
        short[p] = need * rng.uniform(0.02, 0.98)
    return [
        ("compound period", {f"Tc{(p := rng.choice('RF'))}1": short[p]}),
        ("compound period", {"TcB1": rng.uniform(0.05, 1.0)}),
        ("torsional period", {f"TtB{rng.randint(1, 3)}": rng.uniform(4.0, 400.0)}),
        ("torsional period", {f"TtH{rng.randint(1, 3)}": rng.uniform(3.0, 400.0)}),
        ("wheel triangle", {"TtR1": rng.uniform(0.05, 0.45)}),
    ]


def _random_change(rng: random.Random, text: str, keys: list[str]) -> dict[str, float]:
    key = rng.choice(keys)
    value = _value(text, key)
    factor = rng.choice([0.0, -1.0, 1e-3, 1e-2, 1e3, rng.uniform(0.0, 5.0), rng.uniform(-5.0, 0.0)])
    return {key: value * factor if factor or rng.random() < 0.5 else rng.uniform(-3.0, 3.0)}


#: The inputs' kinds, in turn: each rule broken in the parameter file, each through the readings,
#: and random changes of either (one input in six).
_KINDS: tuple[tuple[str, int], ...] = (
    *(("parameters", i) for i in range(11)),
    *(("readings", i) for i in range(5)),
    *(("parameters", -1),) * 2,
    *(("readings", -1),) * 2,
)


def physics_input(seed: int, index: int) -> PhysicsInput:
    """Input ``index`` of the campaign with ``seed`` (its kind: ``_KINDS[index % len(_KINDS)]``)."""
    rng = random.Random(f"{seed}:physics:{index}")
    source, which = _KINDS[index % len(_KINDS)]
    if source == "parameters":
        base = BENCHMARK.read_text()
        rule, changes = _parameter_rules(rng, base)[which] if which >= 0 else ("random", {})
        for _ in range(rng.randint(1, 3) if which < 0 else 0):
            changes.update(_random_change(rng, base, list(PARAMETER_NAMES)))
        text = base
        for k, val in changes.items():
            text = _set_parameter(text, k, val)
        return PhysicsInput(text, ".yaml", rule)
    base = _browser_measured()
    rule, changes = _reading_rules(rng, base)[which] if which >= 0 else ("random", {})
    keys = [m.group(1) for m in re.finditer(r"^([A-Za-z]+\d*) = [-+0-9.eE]+\+/-", base, flags=re.M)]
    for _ in range(rng.randint(1, 2) if which < 0 else 0):
        changes.update(_random_change(rng, base, keys))
    text = base
    for k, val in changes.items():
        text = _set_reading(text, k, val)
    return PhysicsInput(text, "Measured.txt", rule)


def _unchecked(path: Path) -> ParameterSet:
    """The parameters as the readers and the paper's equations give them, without the plausibility layer."""
    if path.suffix == ".yaml":
        data, lines = load_yaml_document(path)
        return parameters_from_document(str(path), data, lines)
    return compute_parameters(read_bp_measured(path))


@dataclass
class PhysicsTally:
    """The counts of a physics campaign.

    Attributes:
        counts: Inputs per outcome (:data:`KINDS`).
        by_rule: Per rule the inputs were made to break ("random": none): inputs per outcome.
        failures: (index, what happened) of every violation and crash.
    """

    counts: dict[str, int] = field(default_factory=lambda: dict.fromkeys(KINDS, 0))
    by_rule: dict[str, dict[str, int]] = field(default_factory=dict)
    failures: list[tuple[int, str]] = field(default_factory=list)

    def line(self) -> str:
        """One row: inputs, refused, ok, violations, crashes."""
        c = self.counts
        return (
            f"{'physics':<14} {sum(c.values()):>7} {c['refused']:>7} {c['ok']:>6} {c['violation']:>9} {c['crash']:>7}"
        )

    HEADER = f"{'reader':<14} {'inputs':>7} {'refused':>7} {'ok':>6} {'violation':>9} {'crashes':>7}"


def _run(argv: list[str]) -> tuple[int, str, str, list[str]]:
    out, err = io.StringIO(), io.StringIO()
    with warnings.catch_warnings(record=True) as caught, contextlib.redirect_stdout(out):
        warnings.simplefilter("always")
        with contextlib.redirect_stderr(err):
            code = main(argv)
    shown = [f"{w.category.__name__}: {w.message}" for w in caught if not issubclass(w.category, UnitMistakeWarning)]
    return code, out.getvalue(), err.getvalue(), shown


def _judge(index: int, item: PhysicsInput, path: Path, command: str) -> tuple[str, str]:
    try:
        code, out, err, shown = _run([command, str(path)])
    except Exception as exc:  # a crash is what the campaign looks for
        return "crash", f"{type(exc).__name__}: {' '.join(str(exc).split())[:300]}"
    if shown:
        return "crash", f"a warning printed: {shown[0]}"
    errors = [e for e in err.splitlines() if ": warning: " not in e]
    if code == 2:
        if out or len(errors) != 1:
            return "crash", f"exit 2 with {len(errors)} error lines and {len(out)} characters of output"
        return "refused", ""
    if code != 0:
        return "crash", f"exit status {code}"
    try:
        with warnings.catch_warnings():
            warnings.simplefilter("ignore")
            found = violations(_unchecked(path))
    except BikeRigError as exc:
        return "crash", f"exit 0, yet the readers alone refuse it: {exc}"
    if found:
        return "violation", f"{command} exit 0 with {found[0]} (rule {item.rule!r}, input {index})"
    return "ok", ""


def physics_campaign(
    workdir: Path, seed: int, inputs: int, progress: Callable[[PhysicsTally], None] | None = None
) -> PhysicsTally:
    """Run ``inputs`` impossible (or randomly changed) well-formed inputs through ``params`` and ``model``.

    Every fifth input goes through ``model`` (its speeds), the others through ``params``.
    """
    tally = PhysicsTally()
    for index in range(inputs):
        item = physics_input(seed, index)
        path = workdir / f"physics{index % 2}{item.suffix}"
        path.write_text(item.text)
        kind, why = _judge(index, item, path, "model" if index % 5 == 4 else "params")
        tally.counts[kind] += 1
        per_rule = tally.by_rule.setdefault(item.rule, dict.fromkeys(KINDS, 0))
        per_rule[kind] += 1
        if kind in ("violation", "crash"):
            tally.failures.append((index, why))
        if progress is not None and index % 200 == 199:
            progress(tally)
    return tally
