"""What the operator reads: flag advice without repeats, the live warnings' timing and advice, the connection line."""

from __future__ import annotations

import numpy as np
import pytest

from bike_rig.config.paths import config_file
from bike_rig.console.app import MIN_TOP_ROWS, layout_rows
from bike_rig.core.period.advice import FLAG_ADVICE
from bike_rig.core.sim import load_rig, load_true_parameters, simulate_session
from bike_rig.session.live import LiveTrace, silence_advice
from bike_rig.session.setup import connection
from bike_rig.session.state import flag_text


def test_flag_text_says_each_thing_once() -> None:
    assert flag_text("aborted", "the trial was aborted") == "aborted: the trial was aborted → redo it"
    reason = "3.1 cycles in the window (at least 8 wanted): record longer"
    assert flag_text("too_few_cycles", reason) == f"too_few_cycles: {reason}"
    # a reason that does not say the advice keeps all of it
    assert (
        flag_text("clipped", "12 samples at the rail") == f"clipped: 12 samples at the rail → {FLAG_ADVICE['clipped']}"
    )  # type: ignore[index]


def test_no_small_amplitude_warning_on_a_partial_record() -> None:
    """Simulated trials fed in batches as the console gets them: no 'swing it wider' on a good trial."""
    rig = load_rig(config_file("rig.yaml"))
    name, truth = load_true_parameters(config_file("bicycles/browser.yaml"))
    sim = simulate_session(truth, rig, 4, name)
    for trial in sim.trials[:9]:
        live = LiveTrace(trial.name, 0.0)
        for k in range(0, trial.rate.size, 50):
            live.add(trial.rate[k : k + 50], trial.sample_rate, k / trial.sample_rate, first_index=k)
            said = [w for w in live.status(k / trial.sample_rate).warnings if "too small" in w]
            assert not said, (trial.name, k, said)
    # a swing lost in the noise still warns once the window is full
    x = np.arange(4000) / 1000.0
    live = LiveTrace("t", 0.0)
    noise = 1e-3 * np.random.default_rng(2).standard_normal(x.size)
    live.add(1e-4 * np.sin(2 * np.pi * x / 1.2) + noise, 1000.0, 0.0)
    assert any("too small to fit" in w for w in live.status(0.0).warnings)


@pytest.mark.parametrize(
    ("source", "said", "not_said"),
    [("sim gyro", "machine loaded", "unplugged"), ("can gyro", "CAN id", "machine"), ("daq gyro", "DAQ", "CAN")],
)
def test_silence_advice_depends_on_the_source(source: str, said: str, not_said: str) -> None:
    assert said in silence_advice(source) and not_said not in silence_advice(source)
    warning = LiveTrace("t", 0.0, source=source).status(2.0).warnings[0]
    assert warning.startswith(f"no samples yet from the {source} for 2.0 s") and said in warning


def test_connection_names_the_bus_the_domain_and_the_view_line() -> None:
    text, data = connection("can", {"can_interface": "socketcan", "can_channel": "can0", "can_id": 256}, 17)
    assert text == "can gyro on socketcan:can0 id 0x100 · ROS domain 17 · live view: bike-rig view --domain-id 17"
    assert data["view"] == "bike-rig view --domain-id 17" and data["channel"] == "can0"
    assert connection("sim", {}, 3)[0].startswith("simulated gyro · ROS domain 3")


def test_the_log_grows_with_the_window() -> None:
    small, large = layout_rows(24, 68), layout_rows(50, 68)
    assert small[0] >= MIN_TOP_ROWS and small[1] >= 7  # the log keeps more than the old 5 lines at 80×24
    assert large[1] >= 27  # a 26-line reply and the log's border at 200×50
    assert sum(small) == 24 - 4 and sum(large) == 50 - 4
    assert layout_rows(200, 68)[0] == 69  # never more rows than the plan has
