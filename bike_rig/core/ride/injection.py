"""A found segment's bias and σ from its own record's riding injected into its fitted decay.

The riding is coloured (the weave driven by the rider's steering, at the decay's own
frequency), and a decaying sinusoid fitted through it is biased: the rider's steering keeps
the weave going and the fit sees a slower decay. Where the record holds riding outside its
segments, each segment's estimator is measured on that riding (a parametric bootstrap with the
record's own noise): the fitted model's response m(t) (the chosen model, :mod:`.choice`) plus
``injections`` stretches of the riding of the segment's length (the signal as the segmenter
detrended it, :class:`.segment.Segmentation`), each refitted as the segment was
(:func:`.eigen.fit_segment`). From the refits' (Re λ, Im λ): the bias ``b`` (their mean less
the model's) with its standard error ``s_b`` (their scatter over √ of the independent stretches
the riding holds, at most the refits), and their scatter ``s``. The eigenvalue is corrected by
−b where ``|b| > s_b``; its σ² becomes ``max(σ², s²) + s_b²``. A correction that would make a
decaying segment grow (Re λ across 0) is not made: the segment is flagged ``bias_unstable``
instead.

The riding: samples outside every kick the segmenter found, with a segment or without (from
``lead_s`` before its onset), and its segment, up to ``guard_s`` past the segment's end (its
response fading) or the kick's end, at a speed within ``speed_share`` of the segment's (a record
without a speed: all of them). A segment is left as it
is where the riding holds fewer than ``min_stretches`` independent stretches of its length, or fewer than
half the refits give an eigenvalue (hand-cut records, whole records, short logs: no riding).

The refits keep the segment's length: what they do not see is the segmenter's choice of that
length (a draw that decays slowly lasts longer, has more cycles and is kept clean), a
selection that leaves the clean segments' Re λ biased towards slow decay.
Units: times s, eigenvalues 1/s, speeds m/s.
"""

from __future__ import annotations

import math
from collections.abc import Callable, Sequence
from dataclasses import dataclass, replace

import numpy as np
from numpy.typing import NDArray

from .choice import choose_model
from .eigen import MeasuredEigenvalue, fit_segment
from .realmode import RealModeFitFailed, real_mode_basis
from .record import RideRecord
from .segment import Segmentation, noise_sigma

__all__ = ["BIAS_UNSTABLE", "Injection", "InjectionOptions", "inject_segments", "injected", "riding_mask"]

FloatArray = NDArray[np.float64]

#: The flag of a segment whose bias correction would make its decaying weave grow.
BIAS_UNSTABLE = "bias_unstable"


@dataclass(frozen=True)
class InjectionOptions:
    """How the riding is injected (module docstring).

    Attributes:
        injections: Refits per segment [-].
        lead_s: The riding ends this long before a kick's onset [s].
        guard_s: ... and starts this long after a segment's or kick's end [s].
        speed_share: A stretch's mean speed lies within this share of the segment's [-].
        min_stretches: The fewest independent stretches of the segment's length in the riding [-].
        seed: The stretches' random seed (with the segment's number and length).
    """

    injections: int = 30
    lead_s: float = 0.5
    guard_s: float = 4.0
    speed_share: float = 0.1
    min_stretches: float = 4.0
    seed: int = 0


@dataclass(frozen=True)
class Injection:
    """The refits of one segment with the riding injected.

    Attributes:
        refits: Refits that gave an eigenvalue [-].
        independent: Independent stretches of the segment's length the riding holds [-].
        bias_real: Mean refit Re λ less the model's [1/s].
        bias_imag: Mean refit Im λ less the model's [rad/s].
        se_real: The standard error of ``bias_real`` [1/s].
        se_imag: The standard error of ``bias_imag`` [rad/s].
        scatter_real: The refits' σ of Re λ [1/s].
        scatter_imag: The refits' σ of Im λ [rad/s].
    """

    refits: int
    independent: float
    bias_real: float
    bias_imag: float
    se_real: float
    se_imag: float
    scatter_real: float
    scatter_imag: float


def riding_mask(record: RideRecord, found: Segmentation, options: InjectionOptions) -> NDArray[np.bool_]:
    """The samples of riding: outside every kick and segment ``found`` and their guards (module docstring)."""
    t = record.times
    keep = np.ones(t.size, dtype=bool)
    spans = [(k.onset, k.end) for k in found.kicks]
    spans += [(s.kick.onset, s.stop) for s in found.segments]
    for a, b in spans:
        keep &= ~((t >= a - options.lead_s) & (t <= b + options.guard_s))
    return keep


def _model_response(t: FloatArray, y: FloatArray, m: MeasuredEigenvalue) -> Callable[[float, float], FloatArray] | None:
    """The segment's chosen model at ``t`` with a given (Re λ, Im λ), its other parameters fitted to ``y``, or None."""
    if not (math.isfinite(m.real) and math.isfinite(m.imag)):
        return None
    try:
        fit = choose_model(t, y, -m.real, m.imag, m.model, noise_sigma(y)).fit
    except (RealModeFitFailed, ValueError):
        return None
    tau = t - fit.t_mid
    cols = 3 if fit.model == "eq23" else 4

    def response(real: float, imag: float) -> FloatArray:
        phi = real_mode_basis(tau, -real, imag, fit.mu)[0][:, :cols]
        coef = np.linalg.lstsq(phi, y, rcond=None)[0]
        return np.asarray(phi @ coef, dtype=float)

    return response


def _starts(record: RideRecord, riding: NDArray[np.bool_], n: int, speed: float, share: float) -> NDArray[np.intp]:
    """First samples of the stretches of ``n`` riding samples at a mean speed within ``share`` of ``speed``."""
    if riding.size < n or n < 1:
        return np.empty(0, dtype=np.intp)
    bad = np.r_[0, np.cumsum(~riding)]
    ok = bad[n:] - bad[:-n] == 0  # stretch [i, i + n) all riding
    if record.speed is not None and math.isfinite(speed):
        v = np.nan_to_num(record.speed, nan=-math.inf)
        mean = np.convolve(v, np.ones(n) / n, mode="valid")
        ok &= np.abs(mean - speed) <= share * max(speed, 0.0)
    return np.flatnonzero(ok).astype(np.intp)


def inject(
    t: FloatArray,
    y: FloatArray,
    m: MeasuredEigenvalue,
    noise: FloatArray,
    starts: NDArray[np.intp],
    options: InjectionOptions,
    model: str,
) -> Injection | None:
    """The refits of segment ``m`` (samples ``t``, ``y``) with stretches of ``noise`` from ``starts`` added.

    None where the riding holds fewer than ``min_stretches`` independent stretches or fewer than
    half the refits give an eigenvalue.
    """
    n = t.size
    independent = _independent(starts, n)
    if not m.valid or independent < options.min_stretches:
        return None
    response = _model_response(t, y, m)
    if response is None:
        return None
    rng = np.random.default_rng([options.seed, m.index, n])
    picks = rng.choice(starts, size=options.injections, replace=starts.size < options.injections)
    curve = response(m.real, m.imag)
    refits = []
    for i in picks:
        r = fit_segment(t, curve + noise[i : i + n], speed=m.speed, model=model)
        if r.valid and math.isfinite(r.real) and math.isfinite(r.imag):
            refits.append((r.real, r.imag))
    if len(refits) < max(2, options.injections // 2):
        return None
    x = np.array(refits)
    spread = np.std(x, axis=0, ddof=1)
    se = spread / math.sqrt(min(len(refits), independent))
    bias = x.mean(axis=0) - np.array([m.real, m.imag])
    return Injection(
        len(refits), independent, float(bias[0]), float(bias[1]), float(se[0]), float(se[1]), *map(float, spread)
    )


def _independent(starts: NDArray[np.intp], n: int) -> float:
    """How many stretches of ``n`` samples without overlap the runs of ``starts`` hold [-]."""
    if not starts.size:
        return 0.0
    breaks = np.flatnonzero(np.diff(starts) > 1)
    firsts = np.r_[starts[0], starts[breaks + 1]]
    lasts = np.r_[starts[breaks], starts[-1]]
    return float(np.sum((lasts - firsts + n) / n))


def injected(m: MeasuredEigenvalue, inj: Injection) -> MeasuredEigenvalue:
    """``m`` corrected by its bias and with its σ widened (module docstring), with a note of it."""
    real, imag = m.real, m.imag
    if abs(inj.bias_real) > inj.se_real:
        real -= inj.bias_real
    if abs(inj.bias_imag) > inj.se_imag:
        imag -= inj.bias_imag
    flags = m.flags
    what = (
        f"σ and bias from {inj.refits} refits with this record's own riding injected "
        f"({inj.independent:.0f} independent stretches): bias Re {inj.bias_real:+.3f} ± {inj.se_real:.3f} 1/s, "
        f"Im {inj.bias_imag:+.3f} ± {inj.se_imag:.3f} rad/s"
    )
    if m.real < 0 <= real:
        flags = (
            *flags,
            f"{BIAS_UNSTABLE}: the riding's bias {inj.bias_real:+.3f} 1/s would make the decaying "
            f"Re λ {m.real:+.3f} grow",
        )
        real = m.real
    if imag <= 0:
        imag = m.imag
    real_sigma = math.sqrt(max(m.real_sigma, inj.scatter_real) ** 2 + inj.se_real**2)
    imag_sigma = math.sqrt(max(m.imag_sigma, inj.scatter_imag) ** 2 + inj.se_imag**2)
    note = f"{what}: Re {m.real:+.3f} → {real:+.3f} ± {real_sigma:.3f}, Im {m.imag:.3f} → {imag:.3f} ± {imag_sigma:.3f}"
    return replace(
        m,
        real=real,
        imag=imag,
        real_sigma=real_sigma,
        imag_sigma=imag_sigma,
        flags=flags,
        notes=(*m.notes, note),
        variance=(),  # the σ no longer follow the drive alone
    )


def inject_segments(
    record: RideRecord,
    found: Segmentation,
    measured: Sequence[MeasuredEigenvalue],
    model: str = "auto",
    options: InjectionOptions | None = None,
) -> list[MeasuredEigenvalue]:
    """The record's found segments (``measured``, fitted from ``found.segments``) with their riding injected.

    A segment keeps its eigenvalue and σ where the record's riding does not suffice (module docstring),
    and where it is flagged already: it enters no mean, so its refits would change nothing used.
    """
    opt = options or InjectionOptions()
    t, y = record.times, record.signal
    if t.size < 2:
        return list(measured)
    riding = riding_mask(record, found, opt)
    out = []
    for seg, m in zip(found.segments, measured, strict=True):
        if not m.clean:
            out.append(m)
            continue
        inside = (t >= seg.start) & (t <= seg.stop)
        ts, ys = t[inside], y[inside]
        starts = _starts(record, riding, ts.size, m.speed, opt.speed_share)
        inj = inject(ts, ys, m, found.detrended, starts, opt, model)
        out.append(m if inj is None else injected(m, inj))
    return out
