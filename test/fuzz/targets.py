"""The file readers under fuzzing, each with its valid seed files and the tokens of its format.

Seeds are the shipped files (``config/``, BicycleParameters' text files in the shared folder)
and, where none ships (riders, trials), small valid files generated here.
"""

from __future__ import annotations

import io
import shutil
from collections.abc import Callable
from dataclasses import dataclass, field
from pathlib import Path

import numpy as np
from scipy.io import savemat

from bike_rig.bag.simulated import write_simulated_bag
from bike_rig.bag.writer import Compression
from bike_rig.config.paths import config_dir
from bike_rig.core.io_bp import dump_bp_parameter_yaml
from bike_rig.core.loader import load_input
from bike_rig.core.ride.record import read_ride_csv
from bike_rig.core.rider import PAPER_RIDER, load_rider
from bike_rig.core.rider_yeadon import read_yeadon_configuration, read_yeadon_measurements
from bike_rig.core.sim import load_true_parameters, simulate_session
from bike_rig.core.sim.rig import load_rig
from bike_rig.core.trials import read_trial
from bike_rig.offline.info import summarize
from bike_rig.ros.launch import load_graph
from test.fuzz.mutate import YAML_TOKENS
from test.support.paper import shared_dir
from test.support.small_sessions import small_rig

__all__ = ["Target", "targets"]

#: Fragments of the trial formats worth inserting.
_CSV_TOKENS = (b",", b";", b"\t", b"time_ms", b"rate", b"volts", b"#", b"\n\n", b"\xef\xbb\xbf", b"t[us]")
_NPY_TOKENS = (b"(1, 2)", b"(20000000000,)", b"'<f8'", b"'|O'", b"'<U9'", b"True", b"{", b"\x93NUMPY", b"\x02\x00")
_MCAP_TOKENS = (
    b"\x89MCAP0\r\n",
    b"\xff" * 8,
    b"\x00" * 8,
    b"\xff\xff\xff\x7f",
    b"\x06",
    b"\x08",
    b"\x0b",
    b"zstd",
    b"lz4",
    b"ros2",
    b"cdr",
    b"\x28\xb5\x2f\xfd",
    b"\x02\x14\x00\x00\x00\x00\x00\x00\x00",
)
_MAT_TOKENS = (b"\x0f\x00\x00\x00", b"\x0e\x00\x00\x00", b"\xff\xff\xff\x7f", b"IM", b"MI", b"\x78\x9c")


@dataclass
class Target:
    """One reader under fuzzing.

    Attributes:
        name: Its name in the campaign's table.
        reader: Reads one file; returns anything, raises a BikeRigError on a bad file.
        suffix: The file name ending its inputs are written with.
        seeds: Valid files' bytes.
        tokens: Format fragments for the token mutation.
    """

    name: str
    reader: Callable[[Path], object]
    suffix: str
    seeds: list[bytes] = field(default_factory=list)
    tokens: tuple[bytes, ...] = ()


def _trial_columns() -> tuple[np.ndarray, np.ndarray]:
    """A 2 s damped oscillation at 1 kHz: times [s] and rates [rad/s]."""
    t = np.arange(2000) / 1000.0
    return t, 0.3 * np.exp(-0.05 * t) * np.sin(2 * np.pi * t / 0.8) + 0.01


def _csv_seeds() -> list[bytes]:
    t, x = _trial_columns()
    rows = "".join(f"{a:.6f},{b:.6f}\n" for a, b in zip(t, x))
    return [
        ("time,rate\n" + rows).encode(),
        (
            "# a comment\ntime_ms;rate;volts\n"
            + "".join(f"{a * 1e3:.3f};{b:.6f};{b + 2.5:.5f}\n" for a, b in zip(t, x))
        ).encode(),
        "".join(f"{b:.6f}\n" for b in x).encode(),
        "".join(f"{a:.6f}\t{b:.6f}\n" for a, b in zip(t, x)).encode(),
    ]


def _ride_seeds() -> list[bytes]:
    """Ride records: seconds with speed and torque, and ISO 8601 timestamps."""
    t, x = _trial_columns()
    t, x = t[::10], x[::10]  # 100 Hz
    rows = "".join(f"{a:.2f},{b:.6f},4.5,0\n" for a, b in zip(t, x))
    stamps = "".join(f"2024-05-01T10:00:{a:09.6f},{b:.6f}\n" for a, b in zip(t, x))
    return [("time,roll_rate,speed,steer_torque\n" + rows).encode(), ("timestamp,gyro_x\n" + stamps).encode()]


def _npy_seeds() -> list[bytes]:
    t, x = _trial_columns()
    out = []
    for array in (np.column_stack([t, x]), x, x.astype(np.float32), (x * 1000).astype(np.int16)):
        buf = io.BytesIO()
        np.save(buf, array)
        out.append(buf.getvalue())
    return out


def _mat_seeds() -> list[bytes]:
    t, x = _trial_columns()
    meta = {"bicycle": "Browser", "part": "Frame", "pendulum": "Torsional", "angleOrder": "First", "trial": "1"}
    out = []
    for fields, compress in (
        ({"data": x, "sampleRate": 1000.0, **meta}, False),
        ({"data": x, "ActualRate": 1000, **meta}, True),
        ({"data": x, "time": t}, True),
    ):
        buf = io.BytesIO()
        savemat(buf, fields, do_compression=compress)
        out.append(buf.getvalue())
    return out


def _rider_seeds() -> list[bytes]:
    r = PAPER_RIDER
    jason = shared_dir() / "data" / "bicycleparameters" / "riders" / "Jason" / "RawData"
    return [
        f"name: paper\nmass: {r.mass}\nx: {r.x}\nz: {r.z}\n".encode()
        + f"Ixx: {r.Ixx}\nIyy: {r.Iyy}\nIzz: {r.Izz}\nIxz: {r.Ixz}\n".encode(),
        b"{mass: 80, x: 0.3, z: -1.1, Ixx: 8, Iyy: 8, Izz: 2.4, Ixz: -1.9}\n",
        f"name: Jason\nyeadon_measurements: {jason / 'JasonYeadonMeas.txt'}\n".encode()
        + f"yeadon_configuration: {jason / 'JasonBrowserYeadonCFG.txt'}\n".encode()
        + b"inertia: true\nmeasurement_sigma: 0.005\nmass_sigma: 0.5\npose_sigma: false\n"
        + b"bicycle_geometry: {lst: 0.53, whb: 0.58}\n",
    ]


class _BagReader:
    """Reads a bag whose storage file (``part="mcap"``) or metadata.yaml is the fuzzer's input.

    The other file of the bag is the valid one; the bag is then read as ``bike-rig bag info``
    reads it (open, :func:`~bike_rig.offline.session.read_session`, summary).
    """

    def __init__(self, bag: Path, part: str) -> None:
        self.bag, self.part = bag, part
        self.metadata = (bag / "metadata.yaml").read_bytes()
        self.mcap = (bag / "bag_0.mcap").read_bytes()

    def __call__(self, path: Path) -> object:
        data = path.read_bytes()
        (self.bag / "metadata.yaml").write_bytes(data if self.part == "metadata" else self.metadata)
        (self.bag / "bag_0.mcap").write_bytes(data if self.part == "mcap" else self.mcap)
        return summarize(self.bag)


def _bag_targets(workdir: Path) -> list[Target]:
    """The bag readers' targets: a small simulated session's bag (1 s trials, 54 kB), zstd and uncompressed."""
    name, truth = load_true_parameters(config_dir() / "bicycles" / "browser.yaml")
    session = simulate_session(truth, load_rig(small_rig(workdir / "bag-rig", duration_s=1.0)), 3, name)
    plain = write_simulated_bag(workdir / "bag-plain" / "bag", session, compression=Compression.NONE)
    zstd = write_simulated_bag(workdir / "bag-zstd" / "bag", session)
    mcaps = [(b / "bag_0.mcap").read_bytes() for b in (zstd, plain)]
    metadata = [(b / "metadata.yaml").read_bytes() for b in (zstd, plain)]
    return [
        Target("bag", _BagReader(zstd, "mcap"), ".mcap", mcaps, _MCAP_TOKENS),
        Target("bag-metadata", _BagReader(zstd, "metadata"), ".yaml", metadata, YAML_TOKENS),
    ]


def targets(workdir: Path) -> list[Target]:
    """Every file reader with its seeds; ``workdir`` receives the files a graph file refers to.

    Inputs of the ``graph`` target must be written in ``workdir`` (their ``params:`` files are
    relative to them).
    """
    bicycles = config_dir() / "bicycles"
    raw = shared_dir() / "data" / "bicycleparameters"
    jason = raw / "riders" / "Jason" / "RawData"
    for params in config_dir().glob("*.yaml"):
        shutil.copy(params, workdir / params.name)
    parameter_seeds = [(bicycles / "benchmark.yaml").read_bytes()]
    parameter_seeds.append(dump_bp_parameter_yaml(load_input(bicycles / "benchmark.yaml")).encode())  # type: ignore[arg-type]
    return [
        Target(
            "measurements",
            load_input,
            ".yaml",
            [p.read_bytes() for p in sorted(bicycles.glob("*.yaml")) if p.stem != "benchmark"],
            YAML_TOKENS,
        ),
        Target("parameters", load_input, ".yaml", parameter_seeds, YAML_TOKENS),
        Target(
            "bp-text",
            load_input,
            ".txt",
            [p.read_bytes() for p in sorted(raw.glob("*/*/*.txt"))],
            (b" = ", b"+/-", b"#", b",", b"\n"),
        ),
        Target("rig", load_rig, ".yaml", [(config_dir() / "rig.yaml").read_bytes()], YAML_TOKENS),
        Target("graph", load_graph, ".yaml", [(config_dir() / "graph.yaml").read_bytes()], YAML_TOKENS),
        Target("rider", load_rider, ".yaml", _rider_seeds(), YAML_TOKENS),
        Target(
            "yeadon-measurements",
            read_yeadon_measurements,
            ".txt",
            [(jason / "JasonYeadonMeas.txt").read_bytes()],
            YAML_TOKENS,
        ),
        Target(
            "yeadon-configuration",
            read_yeadon_configuration,
            ".txt",
            [(jason / "JasonBrowserYeadonCFG.txt").read_bytes()],
            YAML_TOKENS,
        ),
        Target("trial-csv", lambda p: read_trial(p, 1000.0), ".csv", _csv_seeds(), _CSV_TOKENS),
        Target("ride-csv", read_ride_csv, ".csv", _ride_seeds(), (*_CSV_TOKENS, b"T10:", b"roll_rate", b"1e999")),
        Target("trial-npy", lambda p: read_trial(p, 1000.0), ".npy", _npy_seeds(), _NPY_TOKENS),
        Target("trial-mat", lambda p: read_trial(p, 1000.0), ".mat", _mat_seeds(), _MAT_TOKENS),
        *_bag_targets(workdir),
    ]
