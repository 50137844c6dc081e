"""The fitter node as a real process: STOP → PeriodEstimate latency, and dropped samples.

This process plays the driver (an rclpy node publishing TrialEvent and GyroBatch messages of
50 samples with the topics' QoS) and listens to the periods; the fitter runs as its own process
(``python -m bike_rig.ros.nodes.fitter``), both on a ROS domain reserved for this run with LOCALHOST
discovery.

* Latency: ``--trials`` trials of ``--duration`` s at 1 kHz (30 s: 30,000 samples), each
  published ``--speedup`` times faster than real time; the latency is from just before the
  STOP is published to the PeriodEstimate's arrival here (this process's clock on both ends,
  so it includes the DDS delivery both ways). Target (issue): p99 ≤ 50 ms.
* Drops: trials of ``--drop-seconds`` s published in real time at 1 kHz and at the 10 kHz stress
  rate; samples published against the samples the fitter fitted (``n_samples``) and
  announced (``n_expected``). Target: 0 dropped.
"""

from __future__ import annotations

import argparse
import importlib
import math
import os
import signal
import statistics
import subprocess
import sys
import tempfile
import time
from pathlib import Path
from typing import Any

import numpy as np
import rclpy
from rclpy.context import Context
from rclpy.executors import SingleThreadedExecutor
from rclpy.signals import SignalHandlerOptions

from bike_rig.config.topics import GYRO, PERIODS, TRIAL_EVENTS
from bike_rig.ros.env import remove_stale_fastdds_segments, ros_environment, unique_domain_id
from bike_rig.ros.qos import profile

msgs: Any = importlib.import_module("bike_rig_msgs.msg")

BATCH = 50
TARGET_P99_S = 0.050
MATCH_TIMEOUT_S = 60.0
RESULT_TIMEOUT_S = 30.0


def trial_rates(n: int, rate: float, seed: int) -> np.ndarray:
    """A lightly damped 1.3 s pendulum with gyro noise, rad/s."""
    t = np.arange(n) / rate
    rng = np.random.default_rng(seed)
    return 0.05 * np.exp(-0.005 * t) * np.sin(2 * np.pi * t / 1.3) + 0.01 + 1e-4 * rng.standard_normal(n)


class Bench:
    """The driver stand-in and the listener."""

    def __init__(self, domain_id: int):
        self.context = Context()
        rclpy.init(context=self.context, domain_id=domain_id, signal_handler_options=SignalHandlerOptions.NO)
        self.node = rclpy.create_node("bench_fitter_latency", context=self.context)
        self.executor = SingleThreadedExecutor(context=self.context)
        self.executor.add_node(self.node)
        self.events = self.node.create_publisher(msgs.TrialEvent, TRIAL_EVENTS.name, profile(TRIAL_EVENTS))
        self.gyro = self.node.create_publisher(msgs.GyroBatch, GYRO.name, profile(GYRO))
        self.results: dict[str, tuple[float, Any]] = {}
        self.node.create_subscription(msgs.PeriodEstimate, PERIODS.name, self._on_period, profile(PERIODS))

    def _on_period(self, msg: Any) -> None:
        self.results.setdefault(msg.trial_id, (time.perf_counter(), msg))

    def spin_until(self, condition: Any, timeout: float, what: str) -> None:
        deadline = time.monotonic() + timeout
        while not condition():
            if time.monotonic() > deadline:
                raise RuntimeError(f"no {what} within {timeout} s")
            self.executor.spin_once(timeout_sec=0.01)

    def wait_for_fitter(self) -> None:
        self.spin_until(
            lambda: self.events.get_subscription_count() > 0 and self.gyro.get_subscription_count() > 0,
            MATCH_TIMEOUT_S,
            "fitter subscriptions",
        )
        self.spin_until(lambda: self.node.count_publishers(PERIODS.name) > 0, MATCH_TIMEOUT_S, "fitter publisher")

    def event(self, kind: int, trial_id: str, rate: float, count: int = 0) -> Any:
        return msgs.TrialEvent(
            kind=kind,
            trial_id=trial_id,
            part="frame",
            pendulum="compound",
            measurement_key="TcB1",
            sample_rate_hz=rate,
            sample_count=count,
        )

    def run_trial(self, trial_id: str, rates: np.ndarray, rate: float, speedup: float) -> tuple[float, Any]:
        """Publish one trial paced at ``rate × speedup`` samples/s; (latency s, estimate)."""
        self.events.publish(self.event(0, trial_id, rate))
        period = BATCH / rate / speedup
        t0 = time.perf_counter()
        for k, a in enumerate(range(0, rates.size, BATCH)):
            due = t0 + k * period
            while (wait := due - time.perf_counter()) > 0:
                self.executor.spin_once(timeout_sec=min(wait, 0.005))
            msg = msgs.GyroBatch(trial_id=trial_id, first_index=a, sample_rate_hz=rate)
            msg.rates = rates[a : a + BATCH].tolist()
            self.gyro.publish(msg)
        stop = self.event(1, trial_id, rate, rates.size)
        sent = time.perf_counter()
        self.events.publish(stop)
        self.spin_until(lambda: trial_id in self.results, RESULT_TIMEOUT_S, f"estimate of {trial_id}")
        received, estimate = self.results[trial_id]
        return received - sent, estimate

    def close(self) -> None:
        self.executor.shutdown()
        self.node.destroy_node()
        rclpy.shutdown(context=self.context)


def percentile(values: list[float], q: float) -> float:
    return float(np.percentile(np.asarray(values), q))


def main(argv: list[str] | None = None) -> int:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--trials", type=int, default=40, help="latency trials (default 40)")
    parser.add_argument("--duration", type=float, default=30.0, help="latency trial length, s (default 30)")
    parser.add_argument("--speedup", type=float, default=30.0, help="publishing speed-up of the latency trials")
    parser.add_argument("--drop-seconds", type=float, default=10.0, help="real-time trial length of the drop runs")
    args = parser.parse_args(argv)

    remove_stale_fastdds_segments()
    with unique_domain_id() as domain_id, tempfile.TemporaryDirectory() as tmp:
        env = ros_environment(domain_id=domain_id)
        for key in ("ROS_AUTOMATIC_DISCOVERY_RANGE", "ROS_DOMAIN_ID", "RMW_IMPLEMENTATION"):
            os.environ[key] = env[key]
        os.environ.pop("ROS_LOCALHOST_ONLY", None)
        log_path = Path(tmp) / "fitter.stderr"
        with log_path.open("wb") as log:
            fitter = subprocess.Popen(
                ["timeout", "-k", "10", "1800", sys.executable, "-m", "bike_rig.ros.nodes.fitter"],
                env=env,
                stdout=subprocess.DEVNULL,
                stderr=log,
                start_new_session=True,
            )
            bench = Bench(domain_id)
            try:
                return run(bench, args)
            except RuntimeError as exc:
                print(f"bench_fitter_latency: {exc}\n{log_path.read_text()[-3000:]}", file=sys.stderr)
                return 1
            finally:
                bench.close()
                os.kill(fitter.pid, signal.SIGINT)
                try:
                    fitter.wait(timeout=20)
                except subprocess.TimeoutExpired:
                    os.killpg(fitter.pid, signal.SIGKILL)
                    fitter.wait()


def run(bench: Bench, args: argparse.Namespace) -> int:
    bench.wait_for_fitter()
    rate = 1000.0
    n = round(args.duration * rate)
    bench.run_trial("warm_up", trial_rates(n, rate, 0), rate, args.speedup)
    latencies = []
    for i in range(args.trials):
        latency, estimate = bench.run_trial(f"latency_{i}", trial_rates(n, rate, i + 1), rate, args.speedup)
        if estimate.n_samples != n:
            raise RuntimeError(f"latency_{i}: {estimate.n_samples} of {n} samples fitted")
        latencies.append(latency)
    p50, p99 = percentile(latencies, 50), percentile(latencies, 99)
    ok_latency = p99 <= TARGET_P99_S
    print(
        f"fitter STOP -> PeriodEstimate, {args.trials} trials of {args.duration:g} s at 1 kHz ({n:,} samples, "
        f"published at {args.speedup:g}x real time):"
    )
    print(
        f"  p50 {1e3 * p50:6.1f} ms   p99 {1e3 * p99:6.1f} ms   max {1e3 * max(latencies):6.1f} ms   "
        f"mean {1e3 * statistics.fmean(latencies):6.1f} ms   (target p99 <= {1e3 * TARGET_P99_S:.0f} ms: "
        f"{'met' if ok_latency else 'MISSED'})"
    )

    ok_drops = True
    for stress_rate in (1000.0, 10_000.0):
        m = round(args.drop_seconds * stress_rate)
        t0 = time.perf_counter()
        latency, estimate = bench.run_trial(f"drops_{stress_rate:g}", trial_rates(m, stress_rate, 99), stress_rate, 1.0)
        wall = time.perf_counter() - t0
        dropped = m - int(estimate.n_samples)
        ok_drops &= dropped == 0 and int(estimate.n_expected) == m
        print(
            f"drops at {stress_rate / 1e3:g} kHz ({m / BATCH:,.0f} batches of {BATCH} over {wall:.1f} s): "
            f"published {m:,}, fitted {int(estimate.n_samples):,}, announced {int(estimate.n_expected):,}, "
            f"dropped {dropped}; STOP -> estimate {1e3 * latency:.1f} ms; T = {estimate.period:.6f} s"
            + ("" if math.isfinite(estimate.period) else f" ({', '.join(estimate.flags)})")
        )
    return 0 if ok_latency and ok_drops else 1


if __name__ == "__main__":
    sys.exit(main())
