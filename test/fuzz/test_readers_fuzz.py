"""The bounded fuzz campaign of every file reader: seeded mutations and hypothesis properties.

Every input must end ``ok`` or in a one-line BikeRigError (``clean``): never a crash, a hang or
a warning. ``tools/fuzz.py`` runs the long campaign (10,000 inputs per reader).
"""

from __future__ import annotations

import io
from pathlib import Path

import numpy as np
import pytest
import yaml
from hypothesis import Phase, given, settings
from hypothesis import strategies as st
from hypothesis.extra import numpy as hnp
from scipy.io import savemat

from test.fuzz.campaign import fuzz_target
from test.fuzz.harness import run_reader
from test.fuzz.targets import Target, targets

#: The suite's campaign: seed and mutated inputs per reader (about 25 s in all on one core).
SEED = 20261125
INPUTS = {"trial-mat": 150, "bag": 200, "bag-metadata": 250, "yeadon-measurements": 150, "yeadon-configuration": 150}
DEFAULT_INPUTS = 300
#: No reader may take longer on one input in the suite [s].
TIME_LIMIT_S = 5.0

#: Hypothesis within bounds: no shrinking (a failure prints its example; shrinking one took 5 min).
_PHASES = (Phase.explicit, Phase.reuse, Phase.generate)
_SETTINGS = settings(max_examples=60, deadline=None, phases=_PHASES, database=None)


@pytest.fixture(scope="module")
def fuzz_dir(tmp_path_factory: pytest.TempPathFactory) -> Path:
    return tmp_path_factory.mktemp("fuzz")


@pytest.fixture(scope="module")
def by_name(fuzz_dir: Path) -> dict[str, Target]:
    return {t.name: t for t in targets(fuzz_dir)}


NAMES = [
    "measurements",
    "parameters",
    "bp-text",
    "rig",
    "graph",
    "rider",
    "yeadon-measurements",
    "yeadon-configuration",
    "trial-csv",
    "trial-npy",
    "trial-mat",
    "bag",
    "bag-metadata",
    "ride-csv",
]


@pytest.mark.parametrize("name", NAMES)
def test_mutated_inputs_never_crash_or_hang(name: str, by_name: dict[str, Target], fuzz_dir: Path) -> None:
    """Byte flips, truncations, duplications, splices and tokens of the valid files (seed printed)."""
    target = by_name[name]
    tally = fuzz_target(
        target, fuzz_dir, SEED, INPUTS.get(name, DEFAULT_INPUTS), time_limit_s=TIME_LIMIT_S, measure_memory=False
    )
    print(f"seed {SEED}: {tally.line()}")
    assert tally.counts["ok"] >= len(target.seeds)  # the valid seeds are read
    assert tally.counts["clean"] > tally.inputs // 3  # most mutations are refused, each in one line
    assert not tally.failures, f"seed {SEED}: {tally.failures[:5]}"


def _assert_clean(target: Target, path: Path) -> None:
    outcome = run_reader(target.reader, path, TIME_LIMIT_S, measure_memory=False)
    assert outcome.kind in ("ok", "clean"), outcome


_SCALARS = st.one_of(
    st.none(),
    st.booleans(),
    st.integers(),
    st.floats(),
    st.text(max_size=20),
    st.sampled_from(["1e308", "nan", "1.0 +/- -2", "[1, 2]", "2001-13-45"]),
)
_TREES = st.recursive(
    _SCALARS,
    lambda children: st.lists(children, max_size=4) | st.dictionaries(st.text(max_size=10), children, max_size=4),
    max_leaves=30,
)


def _replace_leaves(doc: object, tree: object, depth: int = 0) -> object:
    """``doc`` with one of its leaves (chosen by the tree's shape) replaced by ``tree``."""
    if isinstance(doc, dict) and doc:
        key = sorted(doc, key=str)[hash(str(tree)) % len(doc)]
        return {**doc, key: _replace_leaves(doc[key], tree, depth + 1)}
    if isinstance(doc, list) and doc:
        i = len(str(tree)) % len(doc)
        return doc[:i] + [_replace_leaves(doc[i], tree, depth + 1)] + doc[i + 1 :]
    return tree


@pytest.mark.parametrize(
    "name",
    [
        "measurements",
        "parameters",
        "rig",
        "graph",
        "rider",
        "yeadon-measurements",
        "yeadon-configuration",
        "bag-metadata",
    ],
)
def test_yaml_readers_take_any_value_anywhere(name: str, by_name: dict[str, Target], fuzz_dir: Path) -> None:
    """A valid document with any YAML value (a scalar of any type, a list, a mapping) in place of one of its own."""
    target = by_name[name]
    base = yaml.safe_load(target.seeds[0])

    @_SETTINGS
    @given(tree=_TREES)
    def check(tree: object) -> None:
        path = fuzz_dir / f"h-{name}.yaml"
        path.write_text(yaml.safe_dump(_replace_leaves(base, tree), allow_unicode=True))
        _assert_clean(target, path)

    check()


@pytest.mark.parametrize("name", ["measurements", "bp-text", "rider", "trial-csv", "ride-csv"])
def test_text_readers_take_any_text(name: str, by_name: dict[str, Target], fuzz_dir: Path) -> None:
    target = by_name[name]

    @_SETTINGS
    @given(text=st.text(max_size=400) | st.binary(max_size=400).map(lambda b: b.decode("latin-1")))
    def check(text: str) -> None:
        path = fuzz_dir / f"t-{name}{target.suffix}"
        path.write_text(text, encoding="utf-8", errors="surrogatepass")
        _assert_clean(target, path)

    check()


_ARRAYS = hnp.arrays(
    dtype=st.sampled_from([np.float64, np.float32, np.int16, np.uint8, np.complex128, np.bool_, "U3", "<M8[s]"]),
    shape=hnp.array_shapes(min_dims=0, max_dims=3, min_side=0, max_side=6),
)


def test_npy_reader_takes_any_array(by_name: dict[str, Target], fuzz_dir: Path) -> None:
    target = by_name["trial-npy"]

    @_SETTINGS
    @given(array=_ARRAYS)
    def check(array: np.ndarray) -> None:
        path = fuzz_dir / "h.npy"
        np.save(path, array)
        _assert_clean(target, path)

    check()


@settings(max_examples=25, deadline=None, phases=_PHASES, database=None)
@given(
    fields=st.dictionaries(
        st.sampled_from(["data", "time", "sampleRate", "ActualRate", "part", "pendulum", "angleOrder", "trial"]),
        st.one_of(
            st.text(max_size=8),
            st.floats(),
            st.integers(-(2**31), 2**31 - 1),
            hnp.arrays(np.float64, hnp.array_shapes(max_dims=2, max_side=5)),
        ),
        max_size=6,
    )
)
def test_mat_reader_takes_any_fields(fields: dict[str, object], tmp_path_factory: pytest.TempPathFactory) -> None:
    """BicycleParameters' fields holding anything: strings, NaN, huge or negative rates, matrices."""
    path = tmp_path_factory.mktemp("mat") / "h.mat"
    buf = io.BytesIO()
    savemat(buf, fields)
    path.write_bytes(buf.getvalue())
    from bike_rig.core.trials import read_trial

    _assert_clean(Target("trial-mat", lambda p: read_trial(p, 1000.0), ".mat"), path)
