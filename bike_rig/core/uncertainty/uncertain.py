"""Linear propagation of uncertainty with correlations (paper Eq 2–3), by exact Jacobians.

Eq 3, ``s_x² = Σ_ij (∂x/∂u_i) s_{u_i u_j} (∂x/∂u_j)``, in matrix form ``J Σ Jᵀ``. ``J`` comes
from one complex-step evaluation: every core formula is analytic numpy arithmetic that
broadcasts, so evaluating it on ``x_k + i h e_k`` (h = 1e-30) gives ``Im f / h = ∂f/∂x_k`` to
machine precision, with no cancellation. Checked against the ``uncertainties`` package in
``test/core/test_uncertain.py``. The same formulas on real sample arrays give a Monte Carlo.
"""

from __future__ import annotations

from collections.abc import Callable, Mapping, Sequence
from dataclasses import dataclass

import numpy as np
from numpy.typing import NDArray

__all__ = [
    "COMPLEX_STEP",
    "Evaluator",
    "Propagated",
    "UncertainVector",
    "complex_step_jacobian",
    "monte_carlo",
]

#: Imaginary step of the complex-step derivative; any value far below the inputs' scale works.
COMPLEX_STEP = 1e-30

FloatArray = NDArray[np.float64]
#: A function of named inputs (floats or arrays that broadcast) returning named outputs.
Evaluator = Callable[[Mapping[str, object]], Mapping[str, object]]


@dataclass(frozen=True)
class UncertainVector:
    """Named values with their covariance matrix.

    Attributes:
        names: Name of each entry.
        values: The values, in the units of each entry.
        covariance: Their covariance matrix, shape (n, n).
    """

    names: tuple[str, ...]
    values: FloatArray
    covariance: FloatArray

    @property
    def sigmas(self) -> FloatArray:
        """Standard deviation of each entry (square root of the covariance diagonal)."""
        return np.sqrt(np.clip(np.diag(self.covariance), 0.0, None))

    def index(self, name: str) -> int:
        """Position of ``name`` in :attr:`names`."""
        return self.names.index(name)

    def value(self, name: str) -> float:
        """The value of entry ``name``."""
        return float(self.values[self.index(name)])

    def sigma(self, name: str) -> float:
        """The standard deviation of entry ``name``."""
        return float(self.sigmas[self.index(name)])

    def as_dict(self) -> dict[str, float]:
        """The values as a plain ``{name: value}`` mapping."""
        return {n: float(v) for n, v in zip(self.names, self.values)}

    def correlation(self) -> FloatArray:
        """The correlation matrix (zero rows/columns where σ = 0)."""
        s = self.sigmas
        with np.errstate(divide="ignore", invalid="ignore"):
            r = self.covariance / np.outer(s, s)
        r[~np.isfinite(r)] = 0.0
        return r

    def independent(self) -> UncertainVector:
        """The same values and σ with all correlations dropped (the paper's Table 3 convention)."""
        return UncertainVector(self.names, self.values, np.diag(np.diag(self.covariance)))


@dataclass(frozen=True)
class Propagated:
    """Result of evaluating a function with its exact Jacobian.

    Attributes:
        names: Output names, in order.
        values: Output values.
        jacobian: d output / d input, shape (n_out, n_in), columns in ``input_names`` order.
        input_names: The inputs the Jacobian columns refer to.
    """

    names: tuple[str, ...]
    values: FloatArray
    jacobian: FloatArray
    input_names: tuple[str, ...]

    def covariance(self, input_covariance: FloatArray) -> FloatArray:
        """Output covariance ``J Σ Jᵀ`` (paper Eq 3) for the inputs' covariance ``Σ``."""
        return self.jacobian @ input_covariance @ self.jacobian.T

    def with_covariance(self, input_covariance: FloatArray) -> UncertainVector:
        """The outputs as an :class:`UncertainVector`."""
        return UncertainVector(self.names, self.values, self.covariance(input_covariance))


def complex_step_jacobian(
    function: Evaluator,
    inputs: Mapping[str, float],
    perturbed: Sequence[str],
    outputs: Sequence[str] | None = None,
) -> Propagated:
    """Evaluate ``function`` once and return its outputs with the exact Jacobian.

    Args:
        function: Maps named inputs to named outputs using analytic, broadcasting numpy
            arithmetic only (no ``abs``, no conjugating linear algebra).
        inputs: Every input value, in SI units unless its name says otherwise.
        perturbed: The inputs to differentiate with respect to (those with non-zero σ).
        outputs: The outputs to keep, in order; default: all, in the function's order.

    Returns:
        The outputs and d outputs / d perturbed inputs.
    """
    n = len(perturbed)
    args: dict[str, object] = dict(inputs)
    eye = np.eye(n) * COMPLEX_STEP
    for k, name in enumerate(perturbed):
        args[name] = inputs[name] + 1j * eye[k]
    result = function(args)
    keys = tuple(result) if outputs is None else tuple(outputs)
    values = np.empty(len(keys))
    jac = np.zeros((len(keys), n))
    for i, key in enumerate(keys):
        out = np.asarray(result[key])
        if out.ndim == 0:
            values[i] = out.real
            continue
        values[i] = out.real.flat[0]
        jac[i, :] = np.broadcast_to(out.imag, (n,)) / COMPLEX_STEP
    return Propagated(keys, values, jac, tuple(perturbed))


def monte_carlo(
    function: Evaluator,
    inputs: Mapping[str, float],
    covariance: FloatArray,
    perturbed: Sequence[str],
    samples: int,
    seed: int,
    outputs: Sequence[str] | None = None,
) -> dict[str, FloatArray]:
    """Evaluate ``function`` on normally distributed samples of the perturbed inputs.

    Args:
        function: As for :func:`complex_step_jacobian`; evaluated once on arrays of samples.
        inputs: Mean value of every input.
        covariance: Covariance of the perturbed inputs, in ``perturbed`` order.
        perturbed: Inputs drawn at random; the others stay at their mean.
        samples: Number of samples.
        seed: Seed of the random generator (reproducible).
        outputs: Outputs to return; default all.

    Returns:
        ``{output: array of shape (samples,)}``.
    """
    rng = np.random.default_rng(seed)
    mean = np.array([inputs[name] for name in perturbed])
    draws = rng.multivariate_normal(mean, covariance, size=samples, method="cholesky")
    args: dict[str, object] = dict(inputs)
    for k, name in enumerate(perturbed):
        args[name] = draws[:, k]
    result = function(args)
    keys = tuple(result) if outputs is None else tuple(outputs)
    return {k: np.broadcast_to(np.asarray(result[k], dtype=float), (samples,)) for k in keys}
