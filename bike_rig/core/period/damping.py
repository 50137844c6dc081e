"""Damping models beyond Eq 23: dry (Coulomb) friction, and viscous and dry combined.

The paper's Eq 23 is a linear oscillator with viscous damping: the envelope of the swing decays
exponentially. A pendulum with dry friction at its pivot loses the same amplitude every cycle:
its envelope falls linearly and the swing stops for good; with both kinds of damping the
envelope obeys ``dE/dt = −α E − γ`` (α = ζω the viscous rate [1/s], γ the dry-friction loss
[1/s of the amplitude at the window centre]). With t measured from the window centre and the
envelope 1 there,

``E(τ) = e^(−ατ) + γ φ(α, τ)``, ``φ(α, τ) = (e^(−ατ) − 1)/α`` (``−τ`` when α = 0),

held at 0 once it reaches 0 (the swing has stopped). The fitted signal is
``y = A + E(τ) Re(P e^(iωτ))`` with ω the oscillation's angular frequency [rad/s] (its period
is 2π/ω whatever the damping: dry friction leaves a linear oscillator's period unchanged) and
P = C − iB the complex amplitude at the centre. The three models:

* ``viscous``: γ = 0 (Eq 23; fitted by :mod:`~bike_rig.core.period.fit`),
* ``dry``: α = 0 (a linear envelope),
* ``combined``: both.

**Which model the data support.** After the viscous fit, the combined model is fitted (Gauss–
Newton with Levenberg–Marquardt damping on the same block means, from the viscous solution,
with a piecewise linear offset of knots every ``OFFSET_KNOT_CYCLES`` cycles that takes the
gyro's drifting bias out of the envelope; :func:`offset_hats`).
Its extra parameter γ is tested with a Wald test whose σ is the drift-robust per-cycle sandwich
of :mod:`~bike_rig.core.period.sigma`: |γ/σ_γ| ≥ ``Z_LIMIT`` means the envelope is not
exponential. Then α is tested the same way in the combined fit: |α/σ_α| < ``Z_LIMIT``
selects ``dry`` (refitted with α = 0), else ``combined``. Otherwise Eq 23 stays: ``viscous``.

**A finite swing.** A compound pendulum's restoring torque is ∝ sin θ: the period lengthens
with the swing, T ≈ T₀ (1 + θ²/16), and shortens along the record as the swing decays. To first
order in θ² the frequency follows the envelope's square, ``ω(τ) = ω (1 + κ (E(τ)² − 1))``
(κ ≈ −θ_c²/16 for the swing θ_c at the window centre), so the phase is ``ωτ + ωκ I(τ)`` with
``I(τ) = ∫₀^τ (E² − 1)`` (:func:`swing_integral`). κ is fitted with the combined model and kept
when ``κ/σ_κ ≤ −Z_LIMIT`` (only a softening restoring torque, as a pendulum's). Then 2π/ω is
the period at the centre's swing, 2π/(ω(1 − κ)) that of a vanishing swing, and ``period`` stays
the paper's, the mean over the window: the window's length over its cycles, 2π/ω̄ with
``ω̄ = ω (1 + κ (⟨E²⟩ − 1))`` (:func:`mean_period`), each with σ (no gyro calibration
needed). The θ⁴ term is left out (about 5e-5 of T₀ at a 20° swing).

**When they are tried.** Only when Eq 23's per-cycle envelope/phase deviations reach
``TRY_FROM`` of the beating test's significance limit. A model whose swing stops inside the
window while the record oscillates on (residual RMS after the stop above ``STOP_RATIO`` times
that before) is refused: that is not dry friction. The block means are modelled as
``E(τ_b) g_k(iω) e^(iωτ_b)`` (g_k the exact block gain of
:func:`~bike_rig.core.period.oscillation.block_gain`; the envelope's change inside a block is
left out, a relative error of about ``0.013 |E'/E| / ω``).
"""

from __future__ import annotations

import cmath
import math
from collections.abc import Callable
from dataclasses import dataclass
from enum import Enum

import numpy as np
from numpy.typing import NDArray

from .lm import SingularError, minimise
from .oscillation import TWO_PI, block_phasors
from .sigma import BlockDesign, cycle_starts, sandwich, student_factor, window_sandwich
from .solver import FitFailed, Solution

__all__ = [
    "TRY_FROM",
    "Z_LIMIT",
    "DampingChoice",
    "DampingModel",
    "EnvelopeFit",
    "envelope",
    "fit_envelope",
    "half_cycle_times",
    "mean_period",
    "mean_swing_square",
    "select_damping",
    "swing_integral",
    "swing_stop",
]

FloatArray = NDArray[np.float64]
ComplexArray = NDArray[np.complex128]

#: |estimate / σ| at which an extra envelope parameter (γ, then α) is taken as supported.
Z_LIMIT = 3.0
#: The other models are tried when Eq 23's per-cycle envelope/phase deviations reach this
#: fraction of the beating test's significance limit (noise alone: median 0.31, 95 % below 0.46).
TRY_FROM = 0.5
#: A model whose swing stops inside the window is refused when the residual RMS after the stop
#: exceeds this multiple of that before it (the record still oscillates: not dry friction).
STOP_RATIO = 2.0
#: Knot spacing of the drift model's piecewise linear offset, cycles...
OFFSET_KNOT_CYCLES = 2
#: ...or as many more whole cycles as keep the intervals this many at most: each knot is a
#: parameter of the fit, whose cost grows with their square (a 29 s window keeps 2 cycles for
#: periods from 0.113 s; a 5-minute record of a 0.3 s pendulum would have needed 500 knots).
MAX_OFFSET_INTERVALS = 128
#: Gauss–Newton iterations at most.
_MAX_ITER = 40
#: Converged when the weighted sum of squares falls by less than this fraction, or when no
#: parameter moves by more than ``_STEP_SIGMA`` of its σ (white-residual σ from the Hessian).
_TOL = 1e-10
_STEP_SIGMA = 1e-3
#: Grid points of :func:`swing_integral`.
_SWING_GRID = 513
#: |α τ| below which φ and its derivative come from their series.
_SERIES = 1e-4


class DampingModel(str, Enum):
    """How a trial's swing decays."""

    #: Eq 23: the envelope decays exponentially (viscous damping).
    VISCOUS = "viscous"
    #: The envelope falls linearly (dry friction at the pivot).
    DRY = "dry"
    #: Both.
    COMBINED = "combined"


def half_cycle_times(tau: FloatArray, omega: float, phase: FloatArray | float) -> FloatArray:
    """Each time moved to the peak of its half cycle of ``cos(ωτ + phase)``, s.

    Dry friction takes its amplitude from the swing half a cycle at a time: the rate's
    amplitude is constant over each half cycle of the rate and steps down where the rate is 0.

    Args:
        tau: Times from the window centre, s.
        omega: Angular frequency, rad/s.
        phase: Phase of the oscillation beyond ωτ, rad (at τ = 0, or one per τ when the
            frequency moves).
    """
    psi = omega * tau + phase
    return np.asarray(tau - (psi - np.rint(psi / math.pi) * math.pi) / omega, dtype=np.float64)


def envelope(
    tau: FloatArray, alpha: float, gamma: float, steps: tuple[float, FloatArray | float] | None = None
) -> tuple[FloatArray, FloatArray, FloatArray]:
    """The envelope E(τ), ∂E/∂α and ∂E/∂γ (module docstring), held at 0 where E ≤ 0.

    Args:
        tau: Times from the window centre, s.
        alpha: Viscous decay rate α = ζω, 1/s.
        gamma: Dry-friction decay rate γ, 1/s (of the envelope at the centre).
        steps: (ω [rad/s], phase [rad], at τ = 0 or one per τ beyond ωτ) of the oscillation:
            the dry-friction part then steps at the rate's zeros (:func:`half_cycle_times`);
            None: it falls smoothly.

    Returns:
        E [-], ∂E/∂α [s], ∂E/∂γ = φ [s]; all 0 where the swing has stopped.
    """
    x = alpha * tau
    ex = np.exp(-x)
    held = tau if steps is None or gamma == 0.0 else half_cycle_times(tau, *steps)
    xh = alpha * held
    if abs(alpha) * float(np.max(np.abs(held), initial=0.0)) < _SERIES:
        phi = -held * (1.0 - 0.5 * xh + xh * xh / 6.0)
        dphi = held * held * (0.5 - xh / 3.0)
    else:
        exh = np.exp(-xh)
        phi = np.expm1(-xh) / alpha
        dphi = (-held * exh - phi) / alpha
    e = ex + gamma * phi
    de_da = -tau * ex + gamma * dphi
    stopped = e <= 0.0
    if np.any(stopped):
        e[stopped] = 0.0
        de_da[stopped] = 0.0
        phi = phi.copy()
        phi[stopped] = 0.0
    return e, de_da, phi


def swing_integral(tau: FloatArray, alpha: float, gamma: float) -> FloatArray:
    """``I(τ) = ∫₀^τ (E(s)² − 1) ds`` of the smooth envelope (held at 0 once stopped), s.

    A finite swing's frequency follows the swing's square: ω(τ) = ω (1 + κ (E(τ)² − 1)), so
    its phase is ω τ + ω κ I(τ). Integrated by the trapezoid rule on ``_SWING_GRID`` points
    over the span of ``tau`` and 0, interpolated linearly: for a 30 s record an error of a few
    1e-5 s (1e-3 s where the swing stops inside the record), i.e. ω κ I below 1e-5 rad of
    phase for any pendulum's κ, far below the phase noise.

    Args:
        tau: Times from the window centre, s.
        alpha: Viscous decay rate, 1/s.
        gamma: Dry-friction decay rate, 1/s.
    """
    lo = min(float(np.min(tau)), 0.0)
    hi = max(float(np.max(tau)), 0.0)
    if hi <= lo:
        return np.zeros_like(tau)
    grid = np.linspace(lo, hi, _SWING_GRID)
    x = alpha * grid
    if abs(alpha) * max(-lo, hi) < _SERIES:
        e = 1.0 - gamma * grid * (1.0 - 0.5 * x) - x * (1.0 - 0.5 * x)
    else:
        ex = np.exp(-x)
        e = ex + (gamma / alpha) * (ex - 1.0)
    np.maximum(e, 0.0, out=e)
    integrand = e * e - 1.0
    cumulative = np.concatenate(([0.0], np.cumsum(0.5 * (integrand[1:] + integrand[:-1]) * np.diff(grid))))
    return np.asarray(np.interp(tau, grid, cumulative) - np.interp(0.0, grid, cumulative), dtype=np.float64)


def swing_stop(alpha: float, gamma: float) -> float:
    """When the smooth envelope ``E(τ)`` reaches 0 (the swing stops), s from the centre; inf if never."""
    if not gamma > 0.0:
        return math.inf
    if alpha == 0.0:
        return 1.0 / gamma
    ratio = alpha / gamma
    return math.log1p(ratio) / alpha if ratio > -1.0 else math.inf


def mean_swing_square(alpha: float, gamma: float, start: float, stop: float) -> float:
    """``⟨E²⟩ − 1`` over the swinging part of ``[start, stop]`` (τ from the centre, s): 1.

    The mean frequency of a finite swing over a window is ``ω (1 + κ (⟨E²⟩ − 1))``
    (:func:`swing_integral`); once the swing has stopped there is no frequency to average.

    Args:
        alpha: Viscous decay rate, 1/s.
        gamma: Dry-friction decay rate, 1/s.
        start: The window's start, s from the centre.
        stop: Its end, s from the centre (> ``start``).
    """
    stop = min(stop, swing_stop(alpha, gamma))
    if not stop > start:
        return 0.0
    ends = swing_integral(np.array([start, stop]), alpha, gamma)
    return float(ends[1] - ends[0]) / (stop - start)


def mean_period(omega: float, kappa: float, alpha: float, gamma: float, span: tuple[float, float]) -> float:
    """Eq 25 over a window: ``T̄ = 2π / ω̄``, ``ω̄ = ω (1 + κ (⟨E²⟩ − 1))`` its mean frequency, s.

    The paper's period of a record whose period follows its swing: the window's length over
    the cycles in it (Eq 23 fitted to the window approximates it, weighting the larger swings
    more).

    Args:
        omega: The frequency at the centre's swing, rad/s.
        kappa: The finite swing's frequency change κ (0: none), 1.
        alpha: Viscous decay rate, 1/s.
        gamma: Dry-friction decay rate, 1/s.
        span: The window's (start, end), s from the centre.
    """
    if kappa == 0.0:
        return TWO_PI / omega
    return TWO_PI / (omega * (1.0 + kappa * mean_swing_square(alpha, gamma, *span)))


@dataclass(frozen=True)
class EnvelopeFit:
    """The fit of one damping model to a trial's block means (scaled units, τ from the centre).

    Attributes:
        model: The damping model.
        omega: Angular frequency of the oscillation ω, rad/s.
        alpha: Viscous decay rate α = ζω, 1/s (0 for ``dry``).
        gamma: Dry-friction decay rate γ, 1/s of the centre amplitude (0 for ``viscous``).
        P: Complex amplitude C − iB at the centre, scaled units.
        sigma_omega: σ of ω, rad/s (drift-robust sandwich, Student-t widened).
        sigma_alpha: σ of α, 1/s (NaN when not fitted).
        sigma_gamma: σ of γ, 1/s (NaN when not fitted).
        kappa: The finite swing's frequency change κ: ω(τ) = ω (1 + κ (E(τ)² − 1)), so the
            small-swing frequency is ω (1 − κ) (0 when not fitted) [-].
        sigma_kappa: σ of κ (NaN when not fitted) [-].
        sigma_small_swing_period: σ of 2π / (ω (1 − κ)) (NaN when κ is not fitted), s.
        mean_period: The mean period over the window (:func:`mean_period`; 2π/ω without κ), s.
        sigma_mean_period: Its σ, s.
        span: The window's (start, end), s from the centre.
        stop_ratio: When the envelope reaches 0 inside the window (the swing stopped): the
            residual RMS after the stop over that before it (≈ 1 when only noise is left,
            large when the record still oscillates); 0 when it does not stop.
        dof: Effective degrees of freedom of the σ.
        white_fallback: Too few cycles for the sandwich: σ from the Hessian and Eq 26's
            residual variance.
        deviation: Per whole cycle, the residual's complex amplitude at ω relative to the
            fitted oscillation, in the scaled units (the beating statistic's input).
        amplitude: Per whole cycle, the fitted oscillation's amplitude, scaled units.
    """

    model: DampingModel
    omega: float
    alpha: float
    gamma: float
    P: complex
    sigma_omega: float
    sigma_alpha: float
    sigma_gamma: float
    kappa: float
    sigma_kappa: float
    sigma_small_swing_period: float
    mean_period: float
    sigma_mean_period: float
    span: tuple[float, float]
    stop_ratio: float
    dof: float
    white_fallback: bool
    deviation: ComplexArray
    amplitude: FloatArray

    @property
    def period(self) -> float:
        """2π/ω, s."""
        return TWO_PI / self.omega

    @property
    def swing(self) -> bool:
        """Whether the finite swing's frequency change κ was fitted."""
        return math.isfinite(self.sigma_kappa)

    @property
    def small_swing_period(self) -> float:
        """The period of a vanishing swing, 2π / (ω (1 − κ)), s (the period when κ is not fitted)."""
        return TWO_PI / (self.omega * (1.0 - self.kappa))


def offset_hats(tb: FloatArray, first: float, last: float, period: float) -> FloatArray:
    """The drift model's basis: hat functions with knots every ``OFFSET_KNOT_CYCLES`` cycles (or more).

    A piecewise linear offset with knots a whole number of cycles apart is orthogonal to a
    steady oscillation of that period (each hat's integral against it vanishes), so it takes
    the gyro's slow bias drift out of the envelope parameters without touching the oscillation.
    The last knot is at the window's end (the last interval is between half and 1.5 spacings).

    Returns:
        The hats (knots × blocks; the columns sum to 1).
    """
    cycles = max(OFFSET_KNOT_CYCLES, math.ceil((last - first) / (MAX_OFFSET_INTERVALS * period)))
    spacing = cycles * period
    knots: FloatArray = first + spacing * np.arange(max(1, int((last - first) / spacing + 0.5)) + 1, dtype=np.float64)
    knots[-1] = last
    eye = np.eye(knots.size)
    return np.stack([np.interp(tb, knots, row) for row in eye]).astype(np.float64)


class _Design:
    """The block-mean model of one damping model (with or without a finite swing) and its Jacobian."""

    def __init__(self, blocks: BlockDesign, model: DampingModel, swing: bool, period: float):
        self.blocks = blocks
        self.model = model
        self.swing = swing
        self.tau = blocks.tb - blocks.center
        self.k_last = int(blocks.counts[-1])
        self.w = blocks.counts
        last = float(blocks.tb[-1]) + 0.5 * blocks.step * float(blocks.counts[-1])
        self.hats = offset_hats(blocks.tb, blocks.first, last, period)
        self.span = (blocks.first - 0.5 * blocks.step - blocks.center, last - blocks.center)
        self.n_offsets = self.hats.shape[0]

    def names(self) -> tuple[str, ...]:
        """The parameters, ω last (the sandwich's influence is ω's)."""
        extra = {DampingModel.VISCOUS: ("alpha",), DampingModel.DRY: ("gamma",)}
        offsets = tuple(f"D{j}" for j in range(self.n_offsets))
        swing = ("kappa",) if self.swing else ()
        return (*offsets, "Pr", "Pi", *extra.get(self.model, ("alpha", "gamma")), *swing, "omega")

    def evaluate(self, x: dict[str, float]) -> tuple[FloatArray, FloatArray, ComplexArray, FloatArray]:
        """The model's block means, its Jacobian (parameters × blocks), the oscillation's block means, E."""
        b = self.blocks
        omega, alpha, gamma = x["omega"], x.get("alpha", 0.0), x.get("gamma", 0.0)
        z = block_phasors(1j * omega, self.tau, b.step, b.k, self.k_last, b.uniform)
        P = complex(x["Pr"], x["Pi"])
        phase: FloatArray | float = cmath.phase(P)
        integral = None
        if self.swing:
            integral = swing_integral(self.tau, alpha, gamma)
            extra = (omega * x["kappa"]) * integral
            z = z * np.exp(1j * extra)
            phase = extra + cmath.phase(P)
        e, de_da, phi = envelope(self.tau, alpha, gamma, (omega, phase))
        pz = P * z
        osc = pz.real
        slope = self.tau if integral is None else self.tau + x["kappa"] * integral
        columns = {
            **{f"D{j}": self.hats[j] for j in range(self.n_offsets)},
            "Pr": e * z.real,
            "Pi": -e * z.imag,
            "alpha": de_da * osc,
            "gamma": phi * osc,
            "omega": -e * slope * pz.imag,
        }
        if integral is not None:
            columns["kappa"] = -e * (omega * integral) * pz.imag
        jac = np.stack([columns[name] for name in self.names()])
        offset = np.array([x[f"D{j}"] for j in range(self.n_offsets)]) @ self.hats
        return offset + e * osc, jac, z, e


def fit_envelope(
    blocks: BlockDesign,
    start: Solution,
    model: DampingModel,
    n_cycles: float,
    swing: bool = False,
    guess: dict[str, float] | None = None,
) -> EnvelopeFit:
    """Fit ``model`` to the block means from the viscous fit ``start``.

    Args:
        blocks: The block means of the viscous fit (scaled units).
        start: The viscous fit.
        model: The damping model to fit.
        n_cycles: Cycles in the window.
        swing: Fit the finite swing's frequency change κ too.
        guess: Starting values of the nonlinear parameters (``alpha``, ``gamma``, ``kappa``)
            instead of the viscous fit's.

    Raises:
        FitFailed: The fit diverges or its Hessian is singular.
    """
    design = _Design(blocks, model, swing, TWO_PI / start.omega_d)
    x = {"Pr": start.K.real, "Pi": start.K.imag, "omega": start.omega_d}
    x.update({f"D{j}": start.A for j in range(design.n_offsets)})
    if model is not DampingModel.DRY:
        x["alpha"] = start.alpha
    if model is not DampingModel.VISCOUS:
        x["gamma"] = start.alpha if model is DampingModel.DRY else 0.0  # (e^(−ατ) ≈ 1 − ατ)
    if swing:
        x["kappa"] = 0.0
    for name, value in (guess or {}).items():
        if name in x:
            x[name] = value
    x, r = _minimise(design, x)
    return _statistics(design, x, r, n_cycles)


def _minimise(design: _Design, x: dict[str, float]) -> tuple[dict[str, float], FloatArray]:
    """Levenberg–Marquardt (:mod:`.lm`) from ``x``: the parameters and the block residuals.

    Raises:
        FitFailed: The Hessian is singular.
    """
    names = design.names()
    root_w = np.sqrt(design.w)
    yb = design.blocks.yb
    omega, kappa = names.index("omega"), names.index("kappa") if design.swing else None

    def model(v: FloatArray) -> tuple[FloatArray, Callable[[], FloatArray]]:
        f, jac, _, _ = design.evaluate(dict(zip(names, v.tolist(), strict=True)))
        return root_w * (yb - f), lambda: -(jac * root_w)

    def feasible(v: FloatArray) -> bool:
        return bool(v[omega] > 0 and (kappa is None or abs(v[kappa]) < 0.5))

    try:
        found = minimise(
            model,
            np.array([x[n] for n in names]),
            rel_tol=_TOL,
            step_sigma=_STEP_SIGMA,
            max_iter=_MAX_ITER,
            feasible=feasible,
        )
    except SingularError:
        raise FitFailed(f"the {design.model.value}-damping fit's Hessian is singular") from None
    return dict(zip(names, found.x.tolist(), strict=True)), found.r / root_w


def _statistics(design: _Design, x: dict[str, float], r: FloatArray, n_cycles: float) -> EnvelopeFit:
    """σ of the fit's parameters (drift-robust per-cycle sandwich) and the per-cycle deviations."""
    blocks, names = design.blocks, design.names()
    f, jb, z, e = design.evaluate(x)
    counts = blocks.counts
    rb = counts * r
    jc = jb * counts
    hess = jc @ jb.T
    try:
        G = np.asarray(np.linalg.inv(hess), dtype=float)
    except np.linalg.LinAlgError:
        raise FitFailed(f"the {design.model.value}-damping fit's Hessian is singular") from None
    omega = x["omega"]
    starts = cycle_starts(blocks.tb, blocks.first, omega, n_cycles)
    h = G[-1] @ jb  # each block's influence on ω
    p = len(names)
    score = np.add.reduceat(jb * rb, starts, axis=1)
    v = np.add.reduceat(jc * h, starts, axis=1)
    e2 = np.add.reduceat(counts * h * h, starts)
    first = design.n_offsets + 2
    cov, dof = sandwich(G, score, v, e2, first=first)
    n = float(np.sum(counts))
    white = float(np.dot(rb, r)) / max(1.0, n - p) * G[first:, first:]  # Eq 26-27's covariance
    fallback = cov is None
    if cov is None:
        cov, dof = white, n - p
    factor = student_factor(dof)
    sig = {name: factor * math.sqrt(max(0.0, float(cov[i, i]))) for i, name in enumerate(names[first:])}
    # the period's σ at least the window jackknife's and Eq 27's (widening only)
    floors = [c for c in (white, window_sandwich(G, score, v, e2, first=first)) if c is not None]
    for c in floors:
        sig["omega"] = max(sig["omega"], math.sqrt(max(0.0, float(c[-1, -1]))))
    sigma_t0 = math.nan
    t_mean, sigma_mean = TWO_PI / omega, sig["omega"] * TWO_PI / omega**2
    if design.swing:
        sigma_t0, t_mean, sigma_mean = _swing_periods(x, cov * factor**2, design.span, names[first:])
        for c in floors:
            floor_t0, _, floor_mean = _swing_periods(x, c, design.span, names[first:])
            sigma_t0, sigma_mean = max(sigma_t0, floor_t0), max(sigma_mean, floor_mean)
    stop_ratio = 0.0
    stopped = e <= 0.0
    if np.any(stopped) and not np.all(stopped):
        before = float(np.dot(rb[~stopped], r[~stopped])) / float(np.sum(counts[~stopped]))
        after = float(np.dot(rb[stopped], r[stopped])) / float(np.sum(counts[stopped]))
        stop_ratio = math.sqrt(after / before) if before > 0 else math.inf
    # per cycle: the residual's complex amplitude at ω relative to the oscillation (beating)
    P = complex(x["Pr"], x["Pi"])
    ez = e * z
    power = np.add.reduceat(counts * (ez.real**2 + ez.imag**2), starts)
    per_cycle = np.add.reduceat(counts, starts)
    projection = np.add.reduceat(rb * np.conj(ez), starts)  # Σ r E conj(z)
    safe = np.where(power > 0, power, 1.0)
    deviation = (2.0 * projection / safe) * np.sqrt(power / per_cycle) * (abs(P) / P if P != 0 else 1.0)
    amplitude = abs(P) * np.sqrt(power / per_cycle)
    return EnvelopeFit(
        model=design.model,
        omega=omega,
        alpha=x.get("alpha", 0.0),
        gamma=x.get("gamma", 0.0),
        P=P,
        sigma_omega=sig["omega"],
        sigma_alpha=sig.get("alpha", math.nan),
        sigma_gamma=sig.get("gamma", math.nan),
        kappa=x.get("kappa", 0.0),
        sigma_kappa=sig.get("kappa", math.nan),
        sigma_small_swing_period=sigma_t0,
        mean_period=t_mean,
        sigma_mean_period=sigma_mean,
        span=design.span,
        stop_ratio=stop_ratio,
        dof=dof,
        white_fallback=fallback,
        deviation=np.asarray(deviation, dtype=np.complex128),
        amplitude=np.asarray(amplitude, dtype=float),
    )


def _swing_periods(
    x: dict[str, float], cov: FloatArray, span: tuple[float, float], names: tuple[str, ...]
) -> tuple[float, float, float]:
    """σ of the small-swing period, and the mean period over ``span`` with its σ, s.

    Args:
        x: The fit's parameters (with κ).
        cov: The covariance of the parameters ``names`` (widened).
        span: The window's (start, end), s from the centre.
        names: The parameters of ``cov``.
    """
    omega, kappa = x["omega"], x["kappa"]
    t0 = TWO_PI / (omega * (1.0 - kappa))
    grad = np.zeros(len(names))
    grad[names.index("omega")], grad[names.index("kappa")] = -t0 / omega, t0 / (1.0 - kappa)
    sigma_t0 = math.sqrt(max(0.0, float(grad @ cov @ grad)))
    t_mean, grad = _mean_period_gradient(x, span, names)
    return sigma_t0, t_mean, math.sqrt(max(0.0, float(grad @ cov @ grad)))


def _mean_period_gradient(
    x: dict[str, float], span: tuple[float, float], names: tuple[str, ...]
) -> tuple[float, FloatArray]:
    """:func:`mean_period` of the fit ``x`` over ``span`` and its gradient by the parameters ``names``."""
    omega, kappa = x["omega"], x["kappa"]
    alpha, gamma = x.get("alpha", 0.0), x.get("gamma", 0.0)
    c = mean_swing_square(alpha, gamma, *span)
    t_mean = TWO_PI / (omega * (1.0 + kappa * c))
    grad = np.zeros(len(names))
    grad[names.index("omega")] = -t_mean / omega
    grad[names.index("kappa")] = -t_mean * c / (1.0 + kappa * c)
    # (central differences: the envelope's mean square is smooth in α and γ)
    for name, (da, dg) in (("alpha", (1.0, 0.0)), ("gamma", (0.0, 1.0))):
        if name in names:
            h = 1e-6 * max(abs(x[name]), 1.0 / (span[1] - span[0]))
            up = mean_swing_square(alpha + h * da, gamma + h * dg, *span)
            down = mean_swing_square(alpha - h * da, gamma - h * dg, *span)
            grad[names.index(name)] = -t_mean * kappa * (up - down) / (2.0 * h) / (1.0 + kappa * c)
    return t_mean, grad


@dataclass(frozen=True)
class DampingChoice:
    """The damping model the data support, and the fit that decided it.

    Attributes:
        model: The chosen damping model.
        swing: Whether the period follows the swing (a finite swing's κ is kept).
        fit: The chosen model's fit (None when Eq 23's own fit stands: viscous, no swing).
        z_gamma: γ/σ_γ of the combined fit (the test of a non-exponential envelope).
        z_alpha: α/σ_α of the combined fit.
        z_kappa: κ/σ_κ of the combined fit with a finite swing.
    """

    model: DampingModel
    swing: bool
    fit: EnvelopeFit | None
    z_gamma: float
    z_alpha: float
    z_kappa: float

    def describe(self) -> str:
        """One line: the model and the statistics that chose it."""
        swing = ""
        if self.fit is not None and self.fit.swing:
            swing = (
                f", the period follows the swing (κ = {self.fit.kappa:.3g}: small-swing period "
                f"{self.fit.small_swing_period:.6g} s, fit σ {self.fit.sigma_small_swing_period:.2g} s before checks)"
            )
        return (
            f"damping {self.model.value}{swing} (γ/σ = {self.z_gamma:.1f}, α/σ = {self.z_alpha:.1f}, "
            f"κ/σ = {self.z_kappa:.1f}; a term is kept at |z| ≥ {Z_LIMIT:g})"
        )


def _z(value: float, sigma: float) -> float:
    return value / sigma if sigma > 0 else math.nan


def select_damping(blocks: BlockDesign, viscous: Solution, n_cycles: float) -> DampingChoice:
    """The damping model the trial's block means support (module docstring).

    Raises:
        FitFailed: A fit failed.
    """
    full = fit_envelope(blocks, viscous, DampingModel.COMBINED, n_cycles, swing=True)
    z_kappa = _z(full.kappa, full.sigma_kappa)
    swing = z_kappa <= -Z_LIMIT  # (a pendulum's sin θ: a larger swing, a longer period)
    z_gamma, z_alpha = _z(full.gamma, full.sigma_gamma), _z(full.alpha, full.sigma_alpha)
    if not abs(z_gamma) >= Z_LIMIT:
        model = DampingModel.VISCOUS
    elif abs(z_alpha) >= Z_LIMIT:
        model = DampingModel.COMBINED
    else:
        model = DampingModel.DRY
    if model is DampingModel.VISCOUS and not swing:
        return DampingChoice(model, False, None, z_gamma, z_alpha, z_kappa)
    guess = {"alpha": full.alpha, "gamma": full.gamma, "kappa": full.kappa}
    chosen = full if model is DampingModel.COMBINED and swing else None
    if chosen is None:
        chosen = fit_envelope(blocks, viscous, model, n_cycles, swing=swing, guess=guess)
    if chosen.stop_ratio > STOP_RATIO:  # the swing "stopped", yet the record oscillates on
        return DampingChoice(DampingModel.VISCOUS, False, None, z_gamma, z_alpha, z_kappa)
    return DampingChoice(model, swing, chosen, z_gamma, z_alpha, z_kappa)
