"""The operator console's latencies on a real graph: keystroke → START, STOP → result shown.

The graph of ``bike-rig session`` runs as processes (driver with the operator-driven simulated
rig, fitter, parameter and model nodes, recorder) on a ROS domain reserved for this run, with
LOCALHOST discovery; this process is the console: the same controller and rclpy link the
console's keys call (:mod:`bike_rig.session`, :mod:`bike_rig.ros.nodes.session_link`).

* keystroke → START: from the ``start`` command (what F2 runs) to the driver's START event
  arriving back at the console (so the driver's START was published before; this bounds it);
* STOP → result: from the ``stop`` command (F3) to the trial's result line being produced by
  the console's refresh (the fitter's period estimate received and turned into the line).

``--trials`` trials of rig time ``--stop-after`` wall seconds at ``--time-scale``. Targets
(issue 11): p99 ≤ 50 ms and ≤ 100 ms. The first trial is a warm-up (DDS's first service call
is slow) and not counted.
"""

from __future__ import annotations

import argparse
import os
import sys
import tempfile
import time
from pathlib import Path

import numpy as np

from bike_rig.config.paths import config_file
from bike_rig.core.sim import load_rig
from bike_rig.pipeline.acquire import TrialEventKind, TrialEventRecord
from bike_rig.ros.env import remove_stale_fastdds_segments, unique_domain_id
from bike_rig.ros.launch import load_graph
from bike_rig.ros.running import RunningGraph
from bike_rig.session.setup import build_controller


def _overrides(folder: Path, time_scale: float) -> dict[str, dict[str, object]]:
    return {
        "driver": {
            "source": "sim",
            "mode": "operator",
            "bicycle": str(config_file("bicycles/browser.yaml")),
            "time_scale": time_scale,
        },
        "parameter": {"bicycle": "Browser", "measurements": ""},
        "recorder": {"output": str(folder / "bag")},
    }


def _p(values: list[float], q: float) -> float:
    return float(np.percentile(np.asarray(values), q))


def main() -> int:
    """Run the benchmark; 0 when both targets are met."""
    ap = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    ap.add_argument("--trials", type=int, default=60)
    ap.add_argument("--time-scale", type=float, default=50.0)
    ap.add_argument("--stop-after", type=float, default=0.3, help="wall seconds between start and stop")
    a = ap.parse_args()
    remove_stale_fastdds_segments()
    from bike_rig.ros.nodes.session_link import SessionLink

    starts: list[float] = []
    results: list[float] = []
    with tempfile.TemporaryDirectory() as tmp, unique_domain_id() as domain:
        folder = Path(tmp)
        graph_spec = load_graph(config_file("graph.yaml")).with_parameters(_overrides(folder, a.time_scale))
        graph = RunningGraph(graph_spec, folder / "logs", domain).start()
        os.environ["ROS_DOMAIN_ID"] = str(domain)
        link = SessionLink("bench_console")
        try:
            ctl = build_controller(load_rig(config_file("rig.yaml")), "Browser", link)
            for k in range(a.trials + 1):
                t0 = time.perf_counter()
                reply = ctl.execute("start TcR1#1")
                if reply[0].kind != "ok":
                    print(f"start refused: {reply[0].text}", file=sys.stderr)
                    return 1
                trial_id = reply[0].data["trial_id"]
                seen = False
                while not seen:
                    for ev in link.events():
                        seen |= (
                            isinstance(ev, TrialEventRecord)
                            and ev.kind == TrialEventKind.START
                            and (ev.trial_id == trial_id)
                        )
                        if isinstance(ev, TrialEventRecord):
                            ctl.session.on_trial_event(ev, time.monotonic())
                    time.sleep(0.0005)
                t_start = time.perf_counter() - t0
                time.sleep(a.stop_after)
                t1 = time.perf_counter()
                ctl.execute("stop")
                got = False
                while not got:
                    got = any(r.kind == "result" and r.data.get("trial_id") == trial_id for r in ctl.pump())
                    time.sleep(0.0005)
                t_result = time.perf_counter() - t1
                if k:
                    starts.append(1e3 * t_start)
                    results.append(1e3 * t_result)
        finally:
            link.close()
            graph.stop()
    ok_start = _p(starts, 99) <= 50.0
    ok_result = _p(results, 99) <= 100.0
    print(f"{a.trials} trials, time scale {a.time_scale:g}, load average {os.getloadavg()[0]:.2f}, 2 CPUs")
    print(
        f"  keystroke -> START  median {_p(starts, 50):6.1f} ms  p99 {_p(starts, 99):6.1f} ms  "
        f"(target p99 <= 50 ms: {'OK' if ok_start else 'MISSED'})"
    )
    print(
        f"  STOP -> result      median {_p(results, 50):6.1f} ms  p99 {_p(results, 99):6.1f} ms  "
        f"(target p99 <= 100 ms: {'OK' if ok_result else 'MISSED'})"
    )
    return 0 if ok_start and ok_result else 1


if __name__ == "__main__":
    sys.exit(main())
