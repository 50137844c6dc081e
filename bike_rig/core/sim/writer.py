"""Writing a simulated session to a directory that ``bike-rig fit`` and ``params`` consume.

``DIR/session.yaml`` (a measurement file written by
:func:`~bike_rig.core.io_yaml.dump_measurements_yaml`, each period replaced by its trial files,
relative paths), ``truth.yaml`` (``format: bike_rig-sim-truth/1``, for validation only),
``trials/<name>.npy`` (float64 (N, 2): time s, rate rad/s) and, with ``volts=True``,
``volts/<name>.npy`` (float64 (N,): raw ADC volts). Described in ``docs/simulated-rig.md``.
"""

from __future__ import annotations

from dataclasses import asdict
from pathlib import Path
from typing import Any

import numpy as np
import yaml

from ..io_yaml import dump_measurements_yaml
from ..measurements import Measurements, Reading
from .errors import SimulationError
from .session import SimulatedSession

__all__ = ["TRIALS_DIR", "TRUTH_FORMAT", "VOLTS_DIR", "session_yaml", "truth_document", "write_session"]

TRUTH_FORMAT = "bike_rig-sim-truth/1"
TRIALS_DIR = "trials"
VOLTS_DIR = "volts"
#: Placeholder period values in the dumped measurement file, unique and never a real period.
_SENTINEL_BASE = 7_000_000.0


def _trial_paths(session: SimulatedSession, key: str) -> list[str]:
    return [f"{TRIALS_DIR}/{t.name}.npy" for t in session.trials_of(key)]


def session_yaml(session: SimulatedSession) -> str:
    """The text of ``session.yaml``: static readings as ``[value, sigma]``, periods as trial lists."""
    readings = dict(session.readings)
    sentinels = {}
    for j, m in enumerate(session.plan):
        value = _SENTINEL_BASE + j
        readings[m.key] = Reading(value, 0.0)
        sentinels[f"[{value!r}, 0.0]"] = "{trials: [" + ", ".join(_trial_paths(session, m.key)) + "]}"
    extras = {"simulated_by": "bike_rig.core.sim", "seed": session.seed, "rig": session.rig.name}
    text = dump_measurements_yaml(Measurements(session.bicycle, readings, session.label, extras))
    for placeholder, entry in sentinels.items():
        if text.count(placeholder) != 1:
            raise SimulationError(f"internal: period placeholder {placeholder} written {text.count(placeholder)} times")
        text = text.replace(placeholder, entry)
    header = (
        "# Simulated measurement session (bike_rig.core.sim). Every period entry lists its trials:\n"
        "# .npy files of shape (N, 2), columns time s and gyro rate rad/s, relative to this file.\n"
    )
    return header + text


def truth_document(session: SimulatedSession) -> dict[str, Any]:
    """The content of ``truth.yaml``: true parameters, static readings, periods and each trial's motion.

    Each trial's motion is its modes, its dry friction (``dry_friction``: μ, the friction
    torque over the inertia, rad/s²; ``dry_friction_fraction``: the swing lost per cycle over
    the initial swing, 1) and whether its swing is finite (``finite_swing``: restoring torque
    ∝ sin θ).
    """
    t = session.truth
    return {
        "format": TRUTH_FORMAT,
        "bicycle": session.bicycle,
        "seed": session.seed,
        "rig": session.rig.source,
        "note": "the truth behind session.yaml, for validation only; SI units, angles in degrees",
        "parameters": dict(t.parameters),
        "static": dict(t.static),
        "periods": dict(t.periods),
        "damped_periods": dict(t.damped_periods),
        "stiffness": t.stiffness,
        "rod_inertia": t.rod_inertia,
        "gyro_scale_factor": t.scale_factor,
        "trials": [
            {
                "file": f"{TRIALS_DIR}/{tr.name}.npy",
                "key": tr.key,
                "samples": int(tr.rate.shape[0]),
                "sample_rate": tr.sample_rate,
                "beating": tr.beating,
                "modes": [asdict(m) for m in tr.modes],
                "dry_friction": tr.dry_friction,
                "dry_friction_fraction": tr.dry_friction_fraction,
                "finite_swing": tr.finite_swing,
            }
            for tr in session.trials
        ],
    }


def write_session(session: SimulatedSession, out_dir: str | Path, *, volts: bool = False) -> Path:
    """Write ``session`` to ``out_dir`` (created if needed; existing files are replaced).

    Args:
        session: A simulated session.
        out_dir: The session directory.
        volts: Also write the raw ADC volts under ``volts/``.

    Returns:
        The path of ``session.yaml``.
    """
    out = Path(out_dir)
    (out / TRIALS_DIR).mkdir(parents=True, exist_ok=True)
    if volts:
        (out / VOLTS_DIR).mkdir(exist_ok=True)
    for tr in session.trials:
        np.save(out / TRIALS_DIR / f"{tr.name}.npy", tr.samples())
        if volts:
            np.save(out / VOLTS_DIR / f"{tr.name}.npy", tr.volts)
    (out / "truth.yaml").write_text(
        yaml.safe_dump(truth_document(session), sort_keys=False, allow_unicode=True, width=1 << 16), encoding="utf-8"
    )
    path = out / "session.yaml"
    path.write_text(session_yaml(session), encoding="utf-8")
    return path
