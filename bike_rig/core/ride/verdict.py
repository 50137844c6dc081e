"""A measured weave eigenvalue against the model's, in words: agrees, in tension, or disagrees and how.

Each part's normalised deviation ``z = (measured − model) / sqrt(σ_m² + σ_model²)`` decides:
the largest ``|z|`` up to :data:`AGREE_SIGMA` agrees, up to :data:`DISAGREE_SIGMA` is in tension,
beyond it disagrees. A part beyond :data:`AGREE_SIGMA` is described: the frequency (Im λ) as a
percentage of the model's, the decay (−Re λ) as a rate against the model's. Over several
speeds the verdict is the worst speed's, with the counts. Units: eigenvalues 1/s, speeds m/s.
"""

from __future__ import annotations

import math
from collections.abc import Sequence
from dataclasses import dataclass

__all__ = ["AGREE_SIGMA", "CODES", "DISAGREE_SIGMA", "Verdict", "overall_verdict", "pair_verdict"]

#: The largest |z| [σ] that agrees.
AGREE_SIGMA = 2.0
#: Beyond this |z| [σ] the model disagrees; between the two it is in tension.
DISAGREE_SIGMA = 3.0
#: Verdict codes, from best to worst; then the ones without a comparison.
CODES = ("agrees", "tension", "disagrees", "no_sigma", "no_eigenvalue", "no_clean_segment", "no_segment")


@dataclass(frozen=True)
class Verdict:
    """A comparison's verdict.

    Attributes:
        code: One of :data:`CODES`.
        text: The verdict in words (no NaN in it).
        sigma: The largest |z| of the parts [σ] (NaN: no comparison).
    """

    code: str
    text: str
    sigma: float


def _percent(x: float) -> str:
    return f"{abs(x):.0f}" if abs(x) >= 10 else f"{abs(x):.1f}"


def _frequency(measured: float, model: float, z: float) -> str:
    if not model > 0:
        return (
            f"the ride oscillates at {measured:.2f} rad/s where the model's nearest mode does not oscillate: "
            f"{abs(z):.1f} σ"
        )
    pct = 100.0 * (measured / model - 1.0)
    if pct > 100.0:
        return f"the measured weave frequency is {measured / model:.3g} times the model's: {abs(z):.1f} σ"
    side = "above" if pct >= 0 else "below"
    return f"the measured weave frequency is {_percent(pct)} % {side} the model's: {abs(z):.1f} σ"


def _decay(measured: float, model: float, z: float) -> str:
    rates = f"Re λ {measured:+.2f} against {model:+.2f} 1/s"
    if measured * model > 0:
        how = "decays" if model < 0 else "grows"
        pct = 100.0 * (abs(measured) / abs(model) - 1.0)
        word = "faster" if pct >= 0 else "slower"
        return f"the measured weave {how} {_percent(pct)} % {word} than the model's ({rates}): {abs(z):.1f} σ"
    measured_how = "decays" if measured < 0 else "grows" if measured > 0 else "neither decays nor grows"
    model_how = "decays" if model < 0 else "grows" if model > 0 else "neither decays nor grows"
    return f"the measured weave {measured_how} where the model's {model_how} ({rates}): {abs(z):.1f} σ"


def pair_verdict(measured: complex, predicted: complex, z_real: float, z_imag: float, sigma_note: str = "") -> Verdict:
    """The verdict on one measured eigenvalue (or one speed's combined) against the model's.

    Args:
        measured: The measured eigenvalue [1/s] (NaN parts: none).
        predicted: The model's [1/s].
        z_real: Normalised deviation of the real parts [-].
        z_imag: Of the imaginary parts [-].
        sigma_note: Said after the verdict (e.g. that the model's σ is a Monte Carlo σ).
    """
    tail = f" ({sigma_note})" if sigma_note else ""
    if not (math.isfinite(measured.real) and math.isfinite(measured.imag)):
        return Verdict("no_eigenvalue", "no verdict: no measured eigenvalue", math.nan)
    if not (math.isfinite(z_real) and math.isfinite(z_imag)):
        return Verdict("no_sigma", f"no verdict: the comparison has no σ{tail}", math.nan)
    worst = max(abs(z_real), abs(z_imag))
    if worst <= AGREE_SIGMA:
        return Verdict("agrees", f"agrees within {worst:.1f} σ{tail}", worst)
    parts = []
    if abs(z_imag) > AGREE_SIGMA:
        parts.append(_frequency(measured.imag, predicted.imag, z_imag))
    if abs(z_real) > AGREE_SIGMA:
        parts.append(_decay(measured.real, predicted.real, z_real))
    code, word = ("disagrees", "disagrees") if worst > DISAGREE_SIGMA else ("tension", "in tension")
    return Verdict(code, f"{word}: {'; '.join(parts)}{tail}", worst)


def _speeds(values: Sequence[float]) -> str:
    return ", ".join(f"{v:.2f}" for v in values) + " m/s"


def overall_verdict(
    speeds: Sequence[tuple[float, Verdict]], unmeasured: Sequence[float] = (), n_segments: int = 0
) -> Verdict:
    """The verdict over every speed: the worst speed's, with counts.

    Args:
        speeds: (speed [m/s], its verdict) for each speed with clean segments.
        unmeasured: Speeds [m/s] where no segment is clean.
        n_segments: All segments, for the words when none is clean (0: none was found).
    """
    missing = f"; no clean segment at {_speeds(unmeasured)}" if unmeasured else ""
    compared = [(v, x) for v, x in speeds if x.code in ("agrees", "tension", "disagrees")]
    if not compared:
        if speeds:
            return Verdict("no_sigma", f"no verdict: no speed's comparison has a σ{missing}", math.nan)
        if not n_segments:
            return Verdict("no_segment", "no verdict: no segment found in the records", math.nan)
        return Verdict(
            "no_clean_segment",
            f"no verdict: no clean segment (of {n_segments}: each flagged or without an eigenvalue)",
            math.nan,
        )
    worst_v, worst = max(compared, key=lambda p: p[1].sigma)
    n = len(compared)
    if worst.code == "agrees":
        where = "at the one speed" if n == 1 else f"at all {n} speeds"
        return Verdict(
            "agrees",
            f"the model agrees with the ride {where}: largest deviation {worst.sigma:.1f} σ "
            f"(at {worst_v:.2f} m/s){missing}",
            worst.sigma,
        )
    bad = [v for v, x in compared if x.code == "disagrees"]
    tense = [v for v, x in compared if x.code == "tension"]
    counts = []
    if bad:
        counts.append(f"disagrees with the ride at {len(bad)} of {n} speeds ({_speeds(bad)})")
    if tense:
        counts.append(f"is in tension with it at {len(tense)} of {n} ({_speeds(tense)})")
    code = "disagrees" if bad else "tension"
    text = f"the model {' and '.join(counts)}; worst at {worst_v:.2f} m/s, {worst.text}{missing}"
    return Verdict(code, text, worst.sigma)
