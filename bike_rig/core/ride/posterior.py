"""The parameters' posterior given ride eigenvalues: a Gauss–Newton / Laplace step from the rig's prior.

The prior is a parameter set's 26 values with their covariance ``Σ0`` (the measured bicycle, or
bicycle and rider combined); the data are the measured weave eigenvalues per speed (Re λ and
Im λ with their σ, :class:`RideData`). The model value at speed ``v`` is the eigenvalue of
``A(θ, v) − B(θ) s K(v)`` (``K``: the feedback's gains, ``s`` a scale on them; open loop
without feedback; a digital assist's sample-and-hold where its rate is given) that is
oscillatory and nearest the measured one (:func:`.weave_model.model_weave`).

The unknowns are whitened: ``θ = θ0 + T u + E t`` with ``Σ0 = T Tᵀ`` (``u`` has a unit normal
prior, one entry per direction of ``Σ0`` with a non-zero variance), ``E t`` offsets on
parameters the user frees (flat prior, ``t`` in units of the parameter's prior σ) and the gain
scale ``s = 1 + t_s`` (flat prior). The objective is
``χ² = Σ ((d − m(θ, s)) / σ_d)² + |u|²``; Gauss–Newton steps (the Jacobian analytic: the
implicit function theorem of :func:`bike_rig.core.uncertainty.eigen_sigma.eigenvalue_gradient`
in the parameters, the complex step in the gain scale; forward differences for a sampled assist)
minimise it, halving a step that raises it.
The posterior covariance is ``(Jᵀ J)⁻¹`` at the minimum (Laplace); a direction the data and the
prior leave undetermined (a flat unknown the rides do not see) is reported as such, never given
a σ.

The gain scale's σ is marginal: it holds every prior parameter's uncertainty through their
posterior correlation. Which parameters' priors its estimate leans on, and by how much a truth
one prior σ away would move it, is :meth:`Posterior.gain_scale_confounders`.

Where the linearisation holds is checked, not assumed: the χ² the last full step predicted
against the recomputed one, and :data:`CHECK_DRAWS` draws of the posterior whose exact
eigenvalues are set against the linear prediction (RMS in data σ, :data:`NONLINEAR_LIMIT`), and
the share of draws where the weave is not oscillatory (a branch point within the posterior).
Units: SI; eigenvalues 1/s; speeds m/s; gain scale dimensionless.
"""

from __future__ import annotations

import math
from collections.abc import Sequence
from dataclasses import dataclass

import numpy as np
from numpy.typing import NDArray

from ..benchmark import ParameterSet
from ..errors import ModelError
from ..feedback import Feedback
from ..symbols import PARAMETER_NAMES
from ..uncertainty.eigen_sigma import eigenvalue_gradient
from .eigen import CombinedEigenvalue
from .weave_model import MIN_IMAG, model_weave, scale_gradient

__all__ = [
    "CHECK_DRAWS",
    "CONFOUNDER_SHARE",
    "Confounder",
    "NONLINEAR_LIMIT",
    "CalibrationDataError",
    "Linearity",
    "Posterior",
    "RideData",
    "Unknowns",
    "WeaveBand",
    "posterior",
    "weave_band",
]

FloatArray = NDArray[np.float64]
ComplexArray = NDArray[np.complex128]

#: Gauss–Newton iterations at most.
MAX_ITERATIONS = 12
#: Converged when the step's χ² decrease is below this [-].
CONVERGED_CHI2 = 1e-6
#: Posterior draws of the linearity check.
CHECK_DRAWS = 200
#: RMS (exact − linear) eigenvalue over the draws, in data σ, above which the linearisation is not valid.
NONLINEAR_LIMIT = 0.3
#: A direction whose curvature is below this (relative to the largest) is undetermined.
RANK_TOLERANCE = 1e-10
#: A speed whose combined σ [1/s] is below this is not credible (a degenerate fit) and is left out.
MIN_DATA_SIGMA = 1e-6
#: A parameter one prior σ off that moves the gain scale's estimate by this share of its σ confounds it [-].
CONFOUNDER_SHARE = 0.3
#: Step in the whitened unknowns of the forward differences for a sampled assist [-].
FD_STEP = 1e-6
#: A prior direction of Σ0 with a smaller variance (relative to the largest) is exact.
PRIOR_TOLERANCE = 1e-14


class CalibrationDataError(ModelError):
    """No usable ride data (no clean segment with σ at a known speed), or a bad unknown's name."""


@dataclass(frozen=True)
class RideData:
    """Measured weave eigenvalues, one per speed.

    Attributes:
        speeds: m/s.
        real: Re λ [1/s].
        real_sigma: Its σ [1/s].
        imag: Im λ > 0 [rad/s].
        imag_sigma: Its σ [rad/s].
        notes: Speeds left out, and why.
    """

    speeds: FloatArray
    real: FloatArray
    real_sigma: FloatArray
    imag: FloatArray
    imag_sigma: FloatArray
    notes: tuple[str, ...] = ()

    @classmethod
    def from_combined(cls, combined: Sequence[CombinedEigenvalue]) -> RideData:
        """The speeds with clean segments (:func:`bike_rig.core.ride.eigen.combine_eigenvalues`).

        Raises:
            CalibrationDataError: No speed with a clean segment and finite σ.
        """
        rows, notes = [], []
        for c in combined:
            if not (c.n_used and math.isfinite(c.speed)):
                continue
            if not (c.real_sigma >= MIN_DATA_SIGMA and c.imag_sigma >= MIN_DATA_SIGMA):
                notes.append(
                    f"{c.speed:.2f} m/s left out: its σ ({c.real_sigma:.2g}, {c.imag_sigma:.2g} 1/s) is not "
                    f"credible (below {MIN_DATA_SIGMA:g}): a degenerate segment fit"
                )
                continue
            rows.append(c)
        if not rows:
            raise CalibrationDataError("no speed has a clean segment with a credible σ: nothing to calibrate against")

        def col(k: str) -> FloatArray:
            return np.array([getattr(c, k) for c in rows], dtype=float)

        return cls(col("speed"), col("real"), col("real_sigma"), col("imag"), col("imag_sigma"), tuple(notes))

    @property
    def size(self) -> int:
        """Data values: two per speed."""
        return 2 * int(self.speeds.size)

    @property
    def vector(self) -> FloatArray:
        """``[Re λ…, Im λ…]`` [1/s]."""
        return np.concatenate([self.real, self.imag])

    @property
    def sigma(self) -> FloatArray:
        """Their σ [1/s]."""
        return np.concatenate([self.real_sigma, self.imag_sigma])

    @property
    def near(self) -> ComplexArray:
        """The measured eigenvalues [1/s], complex."""
        return np.asarray(self.real + 1j * self.imag, dtype=complex)


@dataclass(frozen=True)
class Unknowns:
    """What a model variant estimates beyond the prior.

    Attributes:
        free: Parameters offset with a flat prior (``--free``), PARAMETER_NAMES spelling.
        gain_scale: Whether the feedback's gains carry a free scale (else it is 1).
    """

    free: tuple[str, ...] = ()
    gain_scale: bool = False

    @property
    def count(self) -> int:
        """Unknowns without a prior."""
        return len(self.free) + int(self.gain_scale)


@dataclass(frozen=True)
class Linearity:
    """Where the linearised posterior holds.

    Attributes:
        predicted_chi2: The χ² the last full Gauss–Newton step predicted [-].
        recomputed_chi2: The χ² recomputed there [-].
        draws_rms: RMS over posterior draws and data of (exact − linear) / σ_d [-].
        not_oscillatory: Per speed, the share of posterior draws where the model has no oscillatory mode [-].
        valid: Whether the linearisation holds (draws_rms ≤ :data:`NONLINEAR_LIMIT`, every speed oscillatory).
        notes: Where it does not, in words.
    """

    predicted_chi2: float
    recomputed_chi2: float
    draws_rms: float
    not_oscillatory: FloatArray
    valid: bool
    notes: tuple[str, ...]


@dataclass(frozen=True)
class Confounder:
    """A parameter whose prior the gain scale's estimate leans on (:meth:`Posterior.gain_scale_confounders`).

    Attributes:
        name: The parameter (PARAMETER_NAMES spelling).
        per_prior_sigma: The gain scale's shift if the true parameter were one prior σ above
            its prior value [-].
        in_sigma: That shift in the gain scale's posterior σ [-].
        sigma_ratio: The parameter's posterior / prior σ (near 1: the rides do not constrain it).
    """

    name: str
    per_prior_sigma: float
    in_sigma: float
    sigma_ratio: float


@dataclass(frozen=True)
class Posterior:
    """One variant's posterior (module docstring).

    Attributes:
        prior: The prior parameter set (values, covariance).
        unknowns: The variant's unknowns without a prior.
        values: Posterior mean of the 26 parameters (PARAMETER_NAMES order).
        covariance: Their posterior covariance (26 × 26).
        gain_scale: Posterior gain scale (1 when not free).
        gain_scale_sigma: Its σ (0 when not free, inf when undetermined).
        chi2: Minimum of the objective: data χ² + prior term [-].
        chi2_data: The data part [-].
        dof: Data values − unknowns without a prior.
        log_det_hessian: ln det of the whitened Hessian ``Jᵀ J`` (the Laplace Occam factor).
        constrained_directions: Directions of the prior that the rides inform more than the prior does.
        undetermined: The unknowns without a prior that the rides do not determine.
        model: The model's eigenvalue at each data speed, at the posterior [1/s].
        iterations: Gauss–Newton steps taken.
        linearity: The check of the linearisation.
        jacobian_unknowns: ``∂θ/∂z`` (26 × n) and the gain scale's row, for propagating ``z``'s covariance.
        z_mean: The whitened unknowns ``z`` at the posterior mean (n).
        z_covariance: Their covariance (n × n).
        rate_hz: The assist's sample rate [Hz] the model used (None: continuous).
    """

    prior: ParameterSet
    unknowns: Unknowns
    values: FloatArray
    covariance: FloatArray
    gain_scale: float
    gain_scale_sigma: float
    chi2: float
    chi2_data: float
    dof: int
    log_det_hessian: float
    constrained_directions: int
    undetermined: tuple[str, ...]
    model: ComplexArray
    iterations: int
    linearity: Linearity
    jacobian_unknowns: FloatArray
    z_mean: FloatArray
    z_covariance: FloatArray
    rate_hz: float | None = None

    @property
    def sigmas(self) -> FloatArray:
        """Posterior σ of the 26 parameters."""
        return np.sqrt(np.clip(np.diag(self.covariance), 0.0, None))

    @property
    def shifts(self) -> FloatArray:
        """(posterior − prior) / prior σ for each parameter (0 where the prior is exact)."""
        s0 = self.prior.parameters.sigmas
        with np.errstate(divide="ignore", invalid="ignore"):
            out = (self.values - self.prior.parameters.values) / s0
        return np.where(s0 > 0, out, 0.0)

    def gain_scale_confounders(self, share: float = CONFOUNDER_SHARE) -> list[Confounder]:
        """The parameters whose prior the gain scale's estimate leans on, largest lean first.

        In the linearised posterior, a true parameter ``θ_j`` one prior σ from its prior value
        (the parameters the rig's covariance correlates with it at their mean given it), which
        the rides cannot tell from the prior, moves the estimated gain scale by
        ``−Cov(s, θ_j) / σ0_j`` (the posterior mean is ``x̂ = x* − P Π x*`` with ``Π`` the prior's
        precision). Listed: those moving it by at least ``share`` of its σ. Its σ already holds
        their prior's uncertainty (marginalised, never conditioned on the prior's value); a truth
        several prior σ away biases it nonetheless, and this says by how much and through which.
        Empty without a free, determined gain scale.
        """
        if not (self.unknowns.gain_scale and math.isfinite(self.gain_scale_sigma) and self.gain_scale_sigma > 0):
            return []
        cov_z = np.where(np.isfinite(self.z_covariance), self.z_covariance, 0.0)
        cov_theta_s = self.jacobian_unknowns @ cov_z[:, -1]
        s0 = self.prior.parameters.sigmas
        ratio = self.sigma_ratio
        out = []
        for i, name in enumerate(PARAMETER_NAMES):
            if not s0[i] > 0 or name in self.unknowns.free:
                continue
            lean = -float(cov_theta_s[i]) / float(s0[i])
            if abs(lean) >= share * self.gain_scale_sigma:
                out.append(Confounder(name, lean, lean / self.gain_scale_sigma, float(ratio[i])))
        return sorted(out, key=lambda c: -abs(c.in_sigma))

    @property
    def sigma_ratio(self) -> FloatArray:
        """Posterior σ / prior σ (1 where the prior is exact; a freed parameter's may exceed 1)."""
        s0 = self.prior.parameters.sigmas
        with np.errstate(divide="ignore", invalid="ignore"):
            out = self.sigmas / s0
        return np.where(s0 > 0, out, 1.0)


class _Problem:
    """The whitened least-squares problem of one variant."""

    def __init__(
        self,
        prior: ParameterSet,
        data: RideData,
        feedback: Feedback | None,
        unknowns: Unknowns,
        rate_hz: float | None = None,
    ):
        pv = prior.parameters
        self.rate_hz = rate_hz if feedback is not None else None
        w, vecs = np.linalg.eigh(0.5 * (pv.covariance + pv.covariance.T))
        keep = w > PRIOR_TOLERANCE * max(float(w.max()), 0.0) if w.size and w.max() > 0 else np.zeros(w.size, bool)
        self.t_prior = vecs[:, keep] * np.sqrt(w[keep])  # (26, n_u)
        cols = []
        for name in unknowns.free:
            if name not in PARAMETER_NAMES:
                raise CalibrationDataError(
                    f"--free {name}: not a benchmark parameter (one of {', '.join(PARAMETER_NAMES)})"
                )
            j = PARAMETER_NAMES.index(name)
            unit = pv.sigmas[j] if pv.sigmas[j] > 0 else max(abs(pv.values[j]) * 0.01, 1e-6)
            col = np.zeros(len(PARAMETER_NAMES))
            col[j] = unit
            cols.append(col)
        self.t_free = np.array(cols).T if cols else np.zeros((len(PARAMETER_NAMES), 0))
        self.n_u, self.n_f = self.t_prior.shape[1], self.t_free.shape[1]
        self.scaled = unknowns.gain_scale and feedback is not None
        self.n = self.n_u + self.n_f + int(self.scaled)
        self.theta0 = np.asarray(pv.values, dtype=float)
        self.data, self.feedback, self.unknowns = data, feedback, unknowns
        self.d, self.s = data.vector, data.sigma

    def theta(self, z: FloatArray) -> tuple[FloatArray, float]:
        """The 26 parameters and the gain scale at ``z``."""
        th = self.theta0 + self.t_prior @ z[: self.n_u] + self.t_free @ z[self.n_u : self.n_u + self.n_f]
        return th, 1.0 + (float(z[-1]) if self.scaled else 0.0)

    def dtheta(self) -> FloatArray:
        """``∂θ/∂z`` (26 × n; zero column for the gain scale)."""
        out = np.zeros((len(PARAMETER_NAMES), self.n))
        out[:, : self.n_u] = self.t_prior
        out[:, self.n_u : self.n_u + self.n_f] = self.t_free
        return out

    def model(self, z: FloatArray) -> tuple[ComplexArray, NDArray[np.bool_], FloatArray]:
        th, s = self.theta(z)
        values = dict(zip(PARAMETER_NAMES, th.tolist(), strict=True))
        return model_weave(values, self.data.speeds, self.feedback, s, self.data.near, self.rate_hz)

    def draws(self, zs: FloatArray, near: ComplexArray) -> tuple[ComplexArray, NDArray[np.bool_], FloatArray]:
        """The model at many ``z`` at once (rows of ``zs``), eigenvalues nearest ``near``."""
        th = self.theta0[None, :] + zs @ self.dtheta().T
        scales = 1.0 + (zs[:, -1] if self.scaled else np.zeros(zs.shape[0]))
        values = {n: th[:, i] for i, n in enumerate(PARAMETER_NAMES)}
        return model_weave(values, self.data.speeds, self.feedback, scales, near, self.rate_hz)

    def dlam(self, z: FloatArray, lam: ComplexArray) -> ComplexArray:
        """``∂λ/∂z`` (N, n): analytic for a continuous assist; forward differences for a sampled one."""
        if self.rate_hz is not None:
            stepped, _, _ = self.draws(z[None, :] + FD_STEP * np.eye(self.n), lam)
            return np.asarray((stepped - lam[None, :]).T / FD_STEP)
        th, s = self.theta(z)
        values = dict(zip(PARAMETER_NAMES, th.tolist(), strict=True))
        v = self.data.speeds
        gains = None if self.feedback is None else s * self.feedback.gains(v)
        grad = eigenvalue_gradient(values, v, lam[:, None], gains)[:, 0, :]  # (N, 26)
        out = np.asarray(grad @ self.dtheta(), dtype=complex)  # (N, n)
        if self.scaled:
            assert self.feedback is not None
            out[:, -1] = scale_gradient(values, v, lam, self.feedback, s)
        return out

    def residual(self, z: FloatArray) -> tuple[FloatArray, ComplexArray, NDArray[np.bool_]]:
        lam, osc, _ = self.model(z)
        m = np.concatenate([lam.real, np.abs(lam.imag)])
        return np.concatenate([(self.d - m) / self.s, z[: self.n_u]]), lam, osc

    def jacobian(self, z: FloatArray, lam: ComplexArray) -> FloatArray:
        """∂(residual)/∂z, shape (2N + n_u, n)."""
        dlam = self.dlam(z, lam)
        sign = np.where(lam.imag >= 0, 1.0, -1.0)[:, None]
        dm = np.concatenate([dlam.real, sign * dlam.imag])
        dm = np.where(np.isfinite(dm), dm, 0.0)
        prior = np.zeros((self.n_u, self.n))
        prior[:, : self.n_u] = np.eye(self.n_u)
        return np.vstack([-dm / self.s[:, None], prior])


def posterior(
    prior: ParameterSet,
    data: RideData,
    feedback: Feedback | None = None,
    unknowns: Unknowns = Unknowns(),
    rate_hz: float | None = None,
) -> Posterior:
    """The Laplace posterior of ``prior``'s parameters (and the variant's unknowns) given ``data``.

    Args:
        prior: The parameter set whose values and covariance are the prior (rider already added).
        data: The measured weave eigenvalues per speed.
        feedback: The closed loop's feedback, or None (open loop; no gain scale).
        unknowns: Parameters freed from their prior, and whether the gain scale is free.
        rate_hz: The assist's sample rate [Hz] (None: continuous; :func:`model_weave`).

    Raises:
        CalibrationDataError: An unknown parameter name.
        ModelError: A singular mass matrix.
    """
    p = _Problem(prior, data, feedback, unknowns, rate_hz)
    z = np.zeros(p.n)
    r, lam, _ = p.residual(z)
    chi2 = float(r @ r)
    predicted = recomputed = chi2
    it = 0
    while it < MAX_ITERATIONS:
        it += 1
        jac = p.jacobian(z, lam)
        step, *_ = np.linalg.lstsq(jac, -r, rcond=None)
        lin = r + jac @ step
        alpha, accepted = 1.0, False
        for _ in range(8):
            z_new = z + alpha * step
            r_new, lam_new, _ = p.residual(z_new)
            chi2_new = float(r_new @ r_new)
            if alpha == 1.0:
                predicted, recomputed = float(lin @ lin), chi2_new
            if np.isfinite(chi2_new) and chi2_new <= chi2 + 1e-12:
                accepted = True
                break
            alpha *= 0.5
        if not accepted:
            break
        decrease = chi2 - chi2_new
        z, r, lam, chi2 = z_new, r_new, lam_new, chi2_new
        if decrease < CONVERGED_CHI2:
            break
    jac = p.jacobian(z, lam)
    hess = jac.T @ jac
    return _laplace(p, z, r, lam, chi2, hess, jac, it, predicted, recomputed)


def _laplace(
    p: _Problem,
    z: FloatArray,
    r: FloatArray,
    lam: ComplexArray,
    chi2: float,
    hess: FloatArray,
    jac: FloatArray,
    iterations: int,
    predicted: float,
    recomputed: float,
) -> Posterior:
    """The posterior's moments and the checks at the minimum ``z``."""
    w, vecs = np.linalg.eigh(hess)
    top = float(w.max()) if w.size else 1.0
    ok = w > RANK_TOLERANCE * top
    inv_w = np.where(ok, 1.0 / np.where(ok, w, 1.0), 0.0)
    cov_z = (vecs * inv_w) @ vecs.T
    log_det = float(np.sum(np.log(w[ok])))
    names = [*p.unknowns.free, *(["gain scale"] if p.scaled else [])]
    undetermined: list[str] = []
    for k, name in enumerate(names):
        col = p.n_u + k
        if np.any(~ok & (np.abs(vecs[col]) > 1e-3)):
            undetermined.append(name)
            cov_z[col, col] = math.inf
    n_data = p.data.size
    data_part = jac[:n_data, : p.n_u]
    info = np.linalg.eigvalsh(data_part.T @ data_part) if p.n_u else np.zeros(0)
    dth = p.dtheta()
    finite_cov = np.where(np.isfinite(cov_z), cov_z, 0.0)
    cov_theta = dth @ finite_cov @ dth.T
    th, s = p.theta(z)
    s_sigma = (math.sqrt(cov_z[-1, -1]) if math.isfinite(cov_z[-1, -1]) else math.inf) if p.scaled else 0.0
    linearity = _check(p, z, finite_cov, lam, jac, predicted, recomputed)
    return Posterior(
        prior=_prior_of(p),
        unknowns=p.unknowns,
        values=th,
        covariance=cov_theta,
        gain_scale=s,
        gain_scale_sigma=s_sigma,
        chi2=chi2,
        chi2_data=float(r[:n_data] @ r[:n_data]),
        dof=n_data - p.n_f - int(p.scaled),
        log_det_hessian=log_det,
        constrained_directions=int(np.sum(info > 1.0)),
        undetermined=tuple(undetermined),
        model=lam,
        iterations=iterations,
        linearity=linearity,
        jacobian_unknowns=dth,
        z_mean=z,
        z_covariance=cov_z,
        rate_hz=p.rate_hz,
    )


def _prior_of(p: _Problem) -> ParameterSet:
    from ..uncertainty.uncertain import UncertainVector

    cov = p.t_prior @ p.t_prior.T
    return ParameterSet("prior", UncertainVector(PARAMETER_NAMES, p.theta0.copy(), cov), "")


def _check(
    p: _Problem,
    z: FloatArray,
    cov_z: FloatArray,
    lam: ComplexArray,
    jac: FloatArray,
    predicted: float,
    recomputed: float,
    seed: int = 0,
) -> Linearity:
    """Exact against linear model eigenvalues over posterior draws (module docstring)."""
    n_data = p.data.size
    n_speeds = n_data // 2
    real = [
        f"{p.data.speeds[i]:.2f} m/s: the model has no oscillatory mode at the posterior; its nearest real "
        "eigenvalue is compared"
        for i in np.flatnonzero(np.abs(lam.imag) <= MIN_IMAG).tolist()
    ]
    if p.n == 0:  # nothing uncertain: the model is exact, the posterior the prior
        return Linearity(predicted, recomputed, 0.0, np.zeros(n_speeds), not real, tuple(real))
    rng = np.random.default_rng(seed)
    dz = rng.multivariate_normal(np.zeros(p.n), cov_z, size=CHECK_DRAWS, method="eigh", check_valid="ignore")
    try:
        exact, osc, _ = p.draws(z[None, :] + dz, lam)
    except ModelError:
        why = "some posterior draws have a singular mass matrix: the posterior is far too wide"
        return Linearity(predicted, recomputed, math.inf, np.ones(n_speeds), False, (why,))
    m0 = np.concatenate([lam.real, np.abs(lam.imag)])
    linear = m0[None, :] - (dz @ jac[:n_data].T) * p.s[None, :]  # residual = (d − m)/σ, so dm = −σ J dz
    m = np.concatenate([exact.real, np.abs(exact.imag)], axis=1)
    err = (m - linear) / p.s[None, :]
    rms = float(np.sqrt(np.mean(err**2)))
    not_osc = 1.0 - np.mean(osc, axis=0)
    notes = []
    if rms > NONLINEAR_LIMIT:
        notes.append(
            f"the model is not linear over the posterior: exact and linearised eigenvalues of posterior "
            f"draws differ by {rms:.2f} data σ (RMS; limit {NONLINEAR_LIMIT:g}): the σ are "
            "approximate"
        )
    bad = np.flatnonzero(not_osc > 0.0) if p.data.speeds.size else np.zeros(0, int)
    for i in bad.tolist():
        notes.append(
            f"{p.data.speeds[i]:.2f} m/s: the weave is not oscillatory in {100 * not_osc[i]:.0f} % of "
            "the posterior draws (a branch point within the posterior): linearisation not valid "
            "there"
        )
    notes += real
    if abs(recomputed - predicted) > max(1.0, 0.1 * predicted) and predicted < recomputed:
        notes.append(f"the last Gauss–Newton step predicted χ² = {predicted:.1f}, recomputed {recomputed:.1f}")
    valid = rms <= NONLINEAR_LIMIT and not bad.size and not real
    return Linearity(predicted, recomputed, rms, not_osc, valid, tuple(notes))


@dataclass(frozen=True)
class WeaveBand:
    """The model's weave eigenvalue over speed with its ±σ band.

    Attributes:
        speeds: m/s.
        real: Re λ [1/s].
        real_sigma: Its σ [1/s] (first order).
        imag: |Im λ| [rad/s].
        imag_sigma: Its σ [rad/s].
    """

    speeds: FloatArray
    real: FloatArray
    real_sigma: FloatArray
    imag: FloatArray
    imag_sigma: FloatArray


def weave_band(
    post: Posterior, feedback: Feedback | None, speeds: FloatArray, near: ComplexArray, prior: bool = False
) -> WeaveBand:
    """The weave eigenvalue nearest ``near`` at ``speeds`` [m/s] with σ: at the posterior, or at the prior.

    The prior band is the prior's values and covariance at the nominal gain scale (freed
    parameters at their prior value); the posterior band the posterior's mean and covariance
    (the gain scale's σ included). σ is first order; NaN where the eigenvalue is not differentiable.

    Raises:
        ModelError: A singular mass matrix.
    """
    v = np.asarray(speeds, dtype=float)
    nan = np.full(v.size, math.nan)
    data = RideData(v, near.real, nan, np.abs(near.imag), nan)
    p = _Problem(post.prior, data, feedback, post.unknowns, post.rate_hz)
    if prior:
        z = np.zeros(p.n)
        cov = np.zeros((p.n, p.n))
        cov[: p.n_u, : p.n_u] = np.eye(p.n_u)
    else:
        z = post.z_mean
        cov = np.where(np.isfinite(post.z_covariance), post.z_covariance, 0.0)
    lam, _, _ = p.model(z)
    grad = p.dlam(z, lam)
    with np.errstate(invalid="ignore", over="ignore"):
        s_re = np.sqrt(np.einsum("ni,ij,nj->n", grad.real, cov, grad.real))
        s_im = np.sqrt(np.einsum("ni,ij,nj->n", grad.imag, cov, grad.imag))
    return WeaveBand(v, lam.real, s_re, np.abs(lam.imag), s_im)
