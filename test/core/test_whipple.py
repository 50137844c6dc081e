"""Tests of the Whipple model: Meijaard et al. 2007 benchmark values and self-consistency."""

from __future__ import annotations

import itertools
import math

import numpy as np
import pytest
from hypothesis import HealthCheck, given, settings
from hypothesis import strategies as st
from numpy.typing import NDArray

from bike_rig.core.errors import ModelError
from bike_rig.core.whipple import (
    MODE_LABELS,
    PARAMETER_KEYS,
    WhippleMatrices,
    canonical_matrices,
    characteristic_coefficients,
    characteristic_polynomial,
    critical_speeds,
    eigenvalues,
    quartic_roots,
    stable_speed_range,
    state_space,
)

G = 9.81

#: Meijaard, Papadopoulos, Ruina, Schwab 2007, Table 1 (SI units, lam in rad).
BENCHMARK: dict[str, float] = {
    "w": 1.02,
    "c": 0.08,
    "lam": math.pi / 10,
    "g": G,
    "rR": 0.3,
    "mR": 2.0,
    "IRxx": 0.0603,
    "IRyy": 0.12,
    "xB": 0.3,
    "zB": -0.9,
    "mB": 85.0,
    "IBxx": 9.2,
    "IByy": 11.0,
    "IBzz": 2.8,
    "IBxz": 2.4,
    "xH": 0.9,
    "zH": -0.7,
    "mH": 4.0,
    "IHxx": 0.05892,
    "IHyy": 0.06,
    "IHzz": 0.00708,
    "IHxz": -0.00756,
    "rF": 0.35,
    "mF": 3.0,
    "IFxx": 0.1405,
    "IFyy": 0.28,
}

#: Paper Eq A22–A25 / section 4 values (the paper prints 14 digits).
REFERENCE_MATRICES = {
    "M": [[80.81722, 2.31941332208709], [2.31941332208709, 0.29784188199686]],
    "C1": [[0.0, 33.86641391492494], [-0.85035641456978, 1.68540397397560]],
    "K0": [[-80.95, -2.59951685249872], [-2.59951685249872, -0.80329488458618]],
    "K2": [[0.0, 76.59734589573222], [0.0, 2.65431523794604]],
}

#: Paper Table 2, grouped by mode in MODE_LABELS order (weave, weave, capsize, caster).
REFERENCE_EIGENVALUES = {
    5.0: [
        -0.77534188219585 + 4.46486771378823j,
        -0.77534188219585 - 4.46486771378823j,
        -0.32286642900409,
        -14.07838969279822,
    ],
    10.0: [
        -3.72016840437287 + 10.90681139476287j,
        -3.72016840437287 - 10.90681139476287j,
        0.16105338653172,
        -24.62459635017404,
    ],
}
WEAVE_SPEED = 4.29238253634111
CAPSIZE_SPEED = 6.02426201538837


@pytest.fixture(scope="module")
def bench() -> WhippleMatrices:
    return canonical_matrices(BENCHMARK)


def _perturbed(factors: dict[str, float]) -> dict[str, float]:
    return {k: v * factors.get(k, 1.0) for k, v in BENCHMARK.items()}


def _min_cost_distance(a: NDArray[np.complex128], b: NDArray[np.complex128]) -> NDArray[np.float64]:
    """Per row, the largest distance under the best matching of the 4 roots of a and b."""
    perms = np.array(list(itertools.permutations(range(4))))
    dist = np.abs(b[:, perms] - a[:, None, :])  # (N, 24, 4)
    best = np.argmin(dist.sum(axis=-1), axis=1)
    return np.asarray(dist[np.arange(a.shape[0]), best].max(axis=-1))


def _tolerance(ref: NDArray[np.complex128]) -> NDArray[np.float64]:
    """Root error allowed per row: first-order perturbation bound ~ scale² / gap (plus 1e-9)."""
    scale = 1.0 + np.abs(ref).max(axis=1)
    gaps = [np.abs(ref[:, j] - ref[:, k]) for j, k in itertools.combinations(range(4), 2)]
    gap = np.maximum(np.min(gaps, axis=0), 1e-300)
    return np.asarray(1e-9 * scale + 1e-12 * scale**2 / gap)


def _eigvals_of_a(m: WhippleMatrices, speeds: NDArray[np.float64]) -> NDArray[np.complex128]:
    a, _ = state_space(m, speeds, G)
    return np.asarray(np.linalg.eigvals(a))


# --- canonical matrices -------------------------------------------------------------------------


def test_canonical_matrices_match_paper(bench: WhippleMatrices) -> None:
    for name, ref in REFERENCE_MATRICES.items():
        got = getattr(bench, name)
        ref_arr = np.array(ref)
        assert got.shape == (2, 2)
        # 1e-12 relative; exact zeros of the paper must come out exactly zero.
        np.testing.assert_allclose(got, ref_arr, rtol=1e-12, atol=0.0, err_msg=name)


def test_canonical_matrices_broadcast_over_arrays() -> None:
    widths = np.array([[0.9, 1.02, 1.2], [1.0, 1.1, 1.3]])
    p: dict[str, object] = dict(BENCHMARK)
    p["w"] = widths
    p["mB"] = np.array([80.0, 85.0, 90.0])  # broadcasts against (2, 3)
    m = canonical_matrices(p)  # type: ignore[arg-type]
    for name in ("M", "C1", "K0", "K2"):
        assert getattr(m, name).shape == (2, 3, 2, 2)
    one = canonical_matrices({**BENCHMARK, "w": 1.3, "mB": 90.0})
    np.testing.assert_allclose(m.K2[1, 2], one.K2, rtol=1e-15)
    np.testing.assert_allclose(m.C1[1, 2], one.C1, rtol=1e-15)


def test_complex_step_equals_finite_difference() -> None:
    h = 1e-30
    for key in ("c", "lam", "IBxz", "rF", "mH", "IFyy"):
        x0 = BENCHMARK[key]
        cs = canonical_matrices({**BENCHMARK, key: x0 + 1j * h})
        step = 1e-6 * max(abs(x0), 1.0)
        hi = canonical_matrices({**BENCHMARK, key: x0 + step})
        lo = canonical_matrices({**BENCHMARK, key: x0 - step})
        for name in ("M", "C1", "K0", "K2"):
            exact = np.imag(getattr(cs, name)) / h
            central = (getattr(hi, name) - getattr(lo, name)) / (2 * step)
            assert np.iscomplexobj(getattr(cs, name))
            np.testing.assert_allclose(exact, central, rtol=1e-6, atol=1e-7, err_msg=f"{name}/{key}")
    # The derivative is not trivially zero: dK2/dc and dC1/dlam are not.
    d_c = np.imag(canonical_matrices({**BENCHMARK, "c": 0.08 + 1j * h}).K2) / h
    assert np.abs(d_c).max() > 1.0


def test_complex_step_through_characteristic_polynomial() -> None:
    h = 1e-30
    coef = characteristic_polynomial(canonical_matrices({**BENCHMARK, "mB": 85.0 + 1j * h}), G)
    hi = characteristic_polynomial(canonical_matrices({**BENCHMARK, "mB": 85.0 + 1e-4}), G)
    lo = characteristic_polynomial(canonical_matrices({**BENCHMARK, "mB": 85.0 - 1e-4}), G)
    central = (hi.coefficients - lo.coefficients) / 2e-4
    np.testing.assert_allclose(coef.coefficients.imag / h, central, rtol=1e-6, atol=1e-6)


def test_missing_parameter_is_a_model_error() -> None:
    p = {k: v for k, v in BENCHMARK.items() if k != "IHxz"}
    with pytest.raises(ModelError, match="IHxz"):
        canonical_matrices(p)
    assert set(PARAMETER_KEYS) == set(BENCHMARK)


# --- state space and characteristic polynomial --------------------------------------------------


def test_state_space_shapes_and_structure(bench: WhippleMatrices) -> None:
    speeds = np.array([0.0, 3.0, 7.5])
    a, b = state_space(bench, speeds, G)
    assert a.shape == (3, 4, 4)
    assert b.shape == (4, 2)
    np.testing.assert_array_equal(a[:, :2, :2], 0.0)
    np.testing.assert_array_equal(a[:, :2, 2:], np.broadcast_to(np.eye(2), (3, 2, 2)))
    np.testing.assert_allclose(b[2:] @ bench.M, np.eye(2), atol=1e-14)
    m_inv = np.linalg.inv(bench.M)
    np.testing.assert_allclose(a[1, 2:, 2:], -m_inv @ (3.0 * bench.C1), rtol=1e-12)
    np.testing.assert_allclose(a[2, 2:, :2], -m_inv @ (G * bench.K0 + 7.5**2 * bench.K2), rtol=1e-12, atol=1e-12)
    a_one, _ = state_space(bench, 3.0, G)
    assert a_one.shape == (4, 4)


def test_characteristic_coefficients_are_the_determinant(bench: WhippleMatrices) -> None:
    rng = np.random.default_rng(7)
    v = rng.uniform(0, 12, 25)
    s = rng.normal(size=25) + 1j * rng.normal(size=25)
    coef = characteristic_coefficients(bench, G, v)
    assert coef.shape == (25, 5)
    poly = np.array([np.polyval(c, z) for c, z in zip(coef, s, strict=True)])
    mats = (
        bench.M * s[:, None, None] ** 2
        + bench.C1 * (v * s)[:, None, None]
        + G * bench.K0
        + bench.K2 * (v**2)[:, None, None]
    )
    np.testing.assert_allclose(poly, np.linalg.det(mats), rtol=1e-11)
    c2d = characteristic_polynomial(bench, G).coefficients
    np.testing.assert_allclose(np.polynomial.polynomial.polyval2d(s, v, c2d), np.linalg.det(mats), rtol=1e-11)


def test_hurwitz_determinant_is_v2_times_quadratic_in_v2(bench: WhippleMatrices) -> None:
    # The closed-form weave candidates rest on H(v) = a3 a2 a1 - a4 a1² - a0 a3² = v² Q(v²)
    # with Q quadratic: fit Q on three speeds, predict H at others.
    def hurwitz(v: NDArray[np.float64]) -> NDArray[np.float64]:
        a4, a3, a2, a1, a0 = characteristic_coefficients(bench, G, v).T
        return np.asarray(a3 * a2 * a1 - a4 * a1**2 - a0 * a3**2)

    fit_v = np.array([1.0, 3.0, 7.0])
    q = np.polyfit(fit_v**2, hurwitz(fit_v) / fit_v**2, 2)
    test_v = np.array([0.5, 2.0, 4.29238253634111, 9.0, 15.0])
    np.testing.assert_allclose(hurwitz(test_v), test_v**2 * np.polyval(q, test_v**2), rtol=1e-9, atol=1e-2)
    assert abs(hurwitz(np.array([WEAVE_SPEED]))[0]) < 1e-6 * abs(hurwitz(np.array([3.0]))[0])


# --- eigenvalues --------------------------------------------------------------------------------


def test_benchmark_eigenvalues_and_labels(bench: WhippleMatrices) -> None:
    sweep = eigenvalues(bench, G, [5.0, 10.0])
    assert sweep.labels == MODE_LABELS == ("weave", "weave", "capsize", "caster")
    for row, v in enumerate((5.0, 10.0)):
        np.testing.assert_allclose(sweep.eigenvalues[row], REFERENCE_EIGENVALUES[v], rtol=0, atol=1e-10)
    # Labels by structure: complex pair = weave, the real root nearer zero = capsize.
    assert np.all(sweep.mode("weave").imag != 0)
    np.testing.assert_array_equal(sweep.mode("capsize").imag, 0.0)
    assert sweep.mode("capsize")[0, 0].real == pytest.approx(-0.32286642900409, abs=1e-10)
    assert sweep.mode("caster")[0, 0].real == pytest.approx(-14.07838969279822, abs=1e-10)


def test_benchmark_eigenvalues_at_zero_speed(bench: WhippleMatrices) -> None:
    zero = eigenvalues(bench, G, 0.0).eigenvalues[0]
    np.testing.assert_array_equal(zero.imag, 0.0)
    expected = [5.53094371765393, 3.13164324790656, -3.13164324790656, -5.53094371765393]
    np.testing.assert_allclose(zero.real, expected, rtol=0, atol=1e-10)


def test_single_speeds_are_labelled_like_the_sweep(bench: WhippleMatrices) -> None:
    grid = np.linspace(0.0, 10.0, 2001)
    sweep = eigenvalues(bench, G, grid)
    for v in (0.0, 0.3, 2.0, 5.0, 10.0):
        single = eigenvalues(bench, G, v).eigenvalues[0]
        row = int(np.argmin(np.abs(grid - v)))
        np.testing.assert_allclose(single, sweep.eigenvalues[row], atol=1e-12)


def test_dense_grid_agrees_with_eig_of_state_space(bench: WhippleMatrices) -> None:
    speeds = np.linspace(0.0, 10.0, 4001)
    ours = eigenvalues(bench, G, speeds).eigenvalues
    ref = _eigvals_of_a(bench, speeds)
    err = _min_cost_distance(ours, ref)
    assert np.all(err <= _tolerance(ref))
    far = np.abs(speeds - 0.6843) > 0.01  # away from the weave branch point (double root)
    assert err[far].max() < 1e-10


def _bicycle_factors() -> st.SearchStrategy[dict[str, float]]:
    keys = [k for k in PARAMETER_KEYS if k != "g"]
    return st.fixed_dictionaries({k: st.floats(0.8, 1.25) for k in keys})


@settings(max_examples=60, deadline=None, suppress_health_check=[HealthCheck.too_slow])
@given(
    factors=_bicycle_factors(),
    speeds=st.lists(st.floats(0.0, 15.0), min_size=1, max_size=12),
)
def test_random_bicycles_agree_with_eig(factors: dict[str, float], speeds: list[float]) -> None:
    m = canonical_matrices(_perturbed(factors))
    v = np.array(speeds)
    sweep = eigenvalues(m, G, v)
    np.testing.assert_array_equal(sweep.speeds, v)  # caller's order kept
    ref = _eigvals_of_a(m, v)
    assert np.all(_min_cost_distance(sweep.eigenvalues, ref) <= _tolerance(ref))


@settings(max_examples=40, deadline=None)
@given(
    coef=st.lists(st.floats(-1e3, 1e3, allow_subnormal=False), min_size=4, max_size=4),
    lead=st.floats(0.1, 100.0),
)
def test_quartic_roots_agree_with_numpy(coef: list[float], lead: float) -> None:
    c = np.array([lead, *coef])
    ours = quartic_roots(c)
    ref = np.asarray(np.roots(c), dtype=complex)
    assert ours.shape == (4,)
    # Small residual on the scale of the roots (the closed form has absolute, not relative,
    # accuracy for roots much smaller than the largest one).
    radius = max(1.0, float(np.abs(ours).max()))
    scale = sum(abs(ck) * radius ** (4 - k) for k, ck in enumerate(c))
    assert np.abs(np.polyval(c, ours)).max() <= 1e-12 * scale
    # Same roots as numpy's companion-matrix eigenvalues, within first-order error bounds.
    assert _min_cost_distance(ours[None], ref[None])[0] <= 10 * _tolerance(ref[None])[0]


def test_tracking_is_the_best_matching_at_every_step(bench: WhippleMatrices) -> None:
    speeds = np.linspace(0.0, 10.0, 20001)
    ev = eigenvalues(bench, G, speeds).eigenvalues
    perms = np.array(list(itertools.permutations(range(4))))
    cost = np.abs(ev[1:, perms] - ev[:-1, None, :]).sum(axis=-1)  # (N-1, 24)
    kept = cost[:, 0]  # perms[0] is the identity
    assert np.all(kept <= cost.min(axis=1) + 1e-9)
    # Columns are continuous: small steps except at the weave branch point (0.6843 m/s),
    # where the double real root splits like a square root.
    jump = np.abs(np.diff(ev, axis=0)).max(axis=1)
    branch = np.abs(speeds[1:] - 0.6843) < 0.002
    assert jump[~branch].max() < 0.02
    above = speeds > 0.6845
    assert np.all(ev[above][:, :2].imag != 0)  # weave columns are the complex pair
    assert np.all(ev[above][:, 2:].imag == 0)
    assert np.all(ev[:, 2].real > ev[:, 3].real)  # capsize above caster everywhere


def test_tracking_through_a_capsize_caster_pair() -> None:
    # A steep steer axis (λ = 0.13 rad instead of π/10) makes the capsize and caster roots
    # meet and form a complex pair at low speed (about 0.25 to 1.17 m/s); the tracking must
    # stay the best matching through both branch points, and the pair sits in the capsize
    # and caster columns as conjugates.
    m = canonical_matrices({**BENCHMARK, "lam": 0.13})
    speeds = np.linspace(0.0, 12.0, 12001)
    ev = eigenvalues(m, G, speeds).eigenvalues
    pair = (ev[:, 2].imag != 0) & (ev[:, 3].imag != 0)
    assert pair.any(), "parameters no longer produce a capsize-caster pair"
    assert 0.2 < speeds[pair].min() < speeds[pair].max() < 1.2
    np.testing.assert_allclose(ev[pair, 2], np.conj(ev[pair, 3]), atol=1e-9)
    assert np.all(ev[speeds > 1.2, 2].imag == 0)
    perms = np.array(list(itertools.permutations(range(4))))
    cost = np.abs(ev[1:, perms] - ev[:-1, None, :]).sum(axis=-1)
    assert np.all(cost[:, 0] <= cost.min(axis=1) + 1e-9)
    ref = _eigvals_of_a(m, speeds)
    assert np.all(_min_cost_distance(ev, ref) <= _tolerance(ref))


def test_bicycle_without_weave_speed() -> None:
    # The same steep steer axis never stabilises the weave: no weave speed, no stable range.
    m = canonical_matrices({**BENCHMARK, "lam": 0.13})
    cs = critical_speeds(m, G)
    assert cs.weave is None
    assert cs.capsize is not None
    assert stable_speed_range(m, G) == ()
    weave = eigenvalues(m, G, np.linspace(0.0, 60.0, 6001)).mode("weave")
    assert np.all(weave.real > 0)


def test_speeds_in_any_order(bench: WhippleMatrices) -> None:
    speeds = np.linspace(0.0, 10.0, 501)
    sorted_ev = eigenvalues(bench, G, speeds).eigenvalues
    perm = np.random.default_rng(3).permutation(speeds.size)
    shuffled = eigenvalues(bench, G, speeds[perm])
    np.testing.assert_array_equal(shuffled.speeds, speeds[perm])
    np.testing.assert_array_equal(shuffled.eigenvalues, sorted_ev[perm])


def test_eigenvectors_satisfy_a_x_equals_s_x(bench: WhippleMatrices) -> None:
    speeds = np.linspace(0.0, 10.0, 301)
    sweep = eigenvalues(bench, G, speeds, vectors=True)
    assert sweep.eigenvectors is not None
    x, s = sweep.eigenvectors, sweep.eigenvalues
    assert x.shape == (301, 4, 4)
    a, _ = state_space(bench, speeds, G)
    residual = np.abs(a @ x - x * s[:, None, :]).max(axis=1)
    assert residual.max() < 1e-9 * (1 + np.abs(s).max())
    np.testing.assert_allclose(np.linalg.norm(x, axis=1), 1.0, rtol=1e-13)
    # x = [q, s q]
    np.testing.assert_allclose(x[:, 2:], x[:, :2] * s[:, None, :], atol=1e-13 * np.abs(s).max())
    assert eigenvalues(bench, G, speeds).eigenvectors is None


def test_bad_inputs_raise_model_error(bench: WhippleMatrices) -> None:
    with pytest.raises(ModelError):
        eigenvalues(bench, G, [])
    with pytest.raises(ModelError):
        eigenvalues(bench, G, [1.0, math.nan])
    batch = canonical_matrices({**BENCHMARK, "w": np.array([1.0, 1.1])})
    with pytest.raises(ModelError):
        eigenvalues(batch, G, [1.0])
    singular = WhippleMatrices(M=np.ones((2, 2)), C1=bench.C1, K0=bench.K0, K2=bench.K2)
    with pytest.raises(ModelError, match="singular"):
        critical_speeds(singular, G)
    with pytest.raises(ModelError):
        state_space(singular, 1.0, G)
    with pytest.raises(ModelError):
        quartic_roots([0.0, 1.0, 2.0, 3.0, 4.0])


# --- critical speeds ----------------------------------------------------------------------------


def test_benchmark_critical_speeds(bench: WhippleMatrices) -> None:
    cs = critical_speeds(bench, G)
    assert cs.weave is not None
    assert cs.capsize is not None
    assert abs(cs.weave - WEAVE_SPEED) < 1e-9
    assert abs(cs.capsize - CAPSIZE_SPEED) < 1e-9
    kinds = [(c.kind, c.rate < 0) for c in cs.crossings]
    assert kinds == [("oscillatory", True), ("real", False)]
    # The weave frequency at the crossing is the imaginary part of the weave eigenvalue.
    at_weave = eigenvalues(bench, G, cs.weave).eigenvalues[0]
    assert abs(at_weave[0].real) < 1e-9
    assert at_weave[0].imag == pytest.approx(cs.crossings[0].frequency, rel=1e-10)


def test_critical_speeds_are_where_eigenvalues_change_sign(bench: WhippleMatrices) -> None:
    cs = critical_speeds(bench, G)
    assert cs.weave is not None
    assert cs.capsize is not None
    ev = eigenvalues(bench, G, [cs.weave - 1e-6, cs.weave + 1e-6]).eigenvalues
    assert ev[0, 0].real > 0 > ev[1, 0].real
    ev = eigenvalues(bench, G, [cs.capsize - 1e-6, cs.capsize + 1e-6]).eigenvalues
    assert ev[0, 2].real < 0 < ev[1, 2].real
    assert stable_speed_range(bench, G) == ((cs.weave, cs.capsize),)
    assert stable_speed_range(bench, G, v_max=5.0) == ((cs.weave, 5.0),)
    limited = critical_speeds(bench, G, v_max=4.0)
    assert limited.weave is None
    assert limited.capsize is None


def test_bicycle_without_capsize_crossing() -> None:
    # a0(v) = g² det K0 + g v² D(K0, K2) + v⁴ det K2, with det K2 = 0 (K2's first column is
    # zero) and D(K0, K2) = (cos λ / w)(SA ST + mT zT SF sin λ). A rear wheel with large spin
    # inertia (IRyy 0.12 -> 2.5 kg m², so ST = IRyy/rR + IFyy/rF grows) makes D > 0; with
    # det K0 > 0 as for the benchmark, a0(v) > 0 for every v: no real root crosses zero.
    m = canonical_matrices({**BENCHMARK, "IRyy": 2.5})
    c = characteristic_polynomial(m, G).coefficients
    assert c[0, 4] == 0.0
    assert c[0, 0] > 0.0
    assert c[0, 2] > 0.0
    cs = critical_speeds(m, G)
    assert cs.capsize is None
    assert all(cr.kind == "oscillatory" for cr in cs.crossings)
    speeds = np.linspace(0.0, 100.0, 20001)
    capsize = eigenvalues(m, G, speeds).mode("capsize")[:, 0]
    assert np.all(capsize.real[speeds > 1.0] < 0.0)
    # The benchmark has D < 0, hence its capsize speed.
    assert characteristic_polynomial(canonical_matrices(BENCHMARK), G).coefficients[0, 2] < 0.0


@settings(max_examples=40, deadline=None)
@given(factors=_bicycle_factors())
def test_random_critical_speeds_are_real_crossings(factors: dict[str, float]) -> None:
    m = canonical_matrices(_perturbed(factors))
    cs = critical_speeds(m, G, v_max=50.0)
    for cr in cs.crossings:
        # At each crossing an eigenvalue sits on the imaginary axis at s = iω.
        ev = eigenvalues(m, G, [cr.speed]).eigenvalues[0]
        assert np.min(np.abs(ev - 1j * cr.frequency)) < 1e-7 * (1 + cr.frequency)
    if cs.capsize is not None:
        pair = eigenvalues(m, G, [cs.capsize * (1 - 1e-7), cs.capsize * (1 + 1e-7)]).eigenvalues
        below, above = pair[0], pair[1]
        # one more real root is positive just above the capsize speed than just below it
        assert (above.real[above.imag == 0] > 0).sum() == (below.real[below.imag == 0] > 0).sum() + 1


def test_many_segment_gather_matches_slices(monkeypatch: pytest.MonkeyPatch) -> None:
    # Few permutation segments are copied by slices, many by fancy indexing: same result.
    from bike_rig.core.whipple import modes

    m = canonical_matrices({**BENCHMARK, "lam": 0.13})
    speeds = np.random.default_rng(5).permutation(np.linspace(0.0, 12.0, 3001))
    by_slices = eigenvalues(m, G, speeds).eigenvalues
    monkeypatch.setattr(modes, "_MAX_SEGMENTS", 0)
    by_index = eigenvalues(m, G, speeds).eigenvalues
    np.testing.assert_array_equal(by_index, by_slices)
