"""Oversized batches from another process: the fitter rejects each, and its memory stays bounded.

The fitter drops a batch above ``max_batch_samples`` (flag ``oversized_batch``), but the
middleware (Fast DDS) has received it first and keeps a payload buffer of the largest message
it took, so the first big batch raises the fitter's resident memory once. How much of the freed
copies the allocator keeps varies with the threads' timing, so the check is loose: after each of
``--batches`` batches the RSS stays within five payloads of where it started (one kept copy per
batch would pass that by the eighth). Prints the RSS after each batch; exit 1 when a batch was
not rejected, the fitter died, or the bound was passed.
"""

from __future__ import annotations

import argparse
import subprocess
import sys
import tempfile
import time
from pathlib import Path

REPO = Path(__file__).resolve().parents[1]
sys.path.insert(0, str(REPO))

from bike_rig.ros.env import remove_stale_fastdds_segments, ros_environment, unique_domain_id  # noqa: E402

#: Payloads of growth allowed over the start, whatever the number of batches.
MAX_PAYLOADS = 5


def rejected_line(samples: int) -> str:
    """What the fitter logs for each oversized batch."""
    return f"batch of {samples} samples at index 0 rejected (max_batch_samples 10000)"


def rss_mb(pid: int) -> float:
    """Resident memory of ``pid``, MB."""
    for line in Path(f"/proc/{pid}/status").read_text().splitlines():
        if line.startswith("VmRSS:"):
            return int(line.split()[1]) / 1024
    raise RuntimeError(f"no VmRSS for {pid}")


def settled_rss(pid: int, wait_s: float = 8.0) -> float:
    """The RSS once it stops moving (two readings 0.5 s apart within 0.5 MB), MB."""
    deadline = time.monotonic() + wait_s
    last = rss_mb(pid)
    while time.monotonic() < deadline:
        time.sleep(0.5)
        now = rss_mb(pid)
        if abs(now - last) < 0.5:
            return now
        last = now
    return last


def wait_rejected(log: Path, text: str, count: int, timeout_s: float = 60.0) -> None:
    """Wait until the fitter's log says it rejected ``count`` oversized batches."""
    deadline = time.monotonic() + timeout_s
    while log.read_text().count(text) < count:
        if time.monotonic() > deadline:
            raise RuntimeError(f"the fitter did not reject batch {count} in {timeout_s} s: {log.read_text()[-2000:]}")
        time.sleep(0.05)


def run(samples: int, batches: int, env: dict[str, str], log_path: Path) -> tuple[float, list[float]]:
    """Start the fitter and the sender, send the batches; the settled RSS before and after each, MB."""
    text = rejected_line(samples)
    with log_path.open("w") as log:
        fitter = subprocess.Popen(
            [sys.executable, "-m", "bike_rig.ros.nodes.fitter"], cwd=REPO, env=env, stdout=log, stderr=subprocess.STDOUT
        )
        sender = subprocess.Popen(
            [sys.executable, str(REPO / "bench" / "big_batches.py"), str(samples), str(batches)],
            stdin=subprocess.PIPE,
            stdout=subprocess.PIPE,
            text=True,
            env=env,
        )
        try:
            assert sender.stdin is not None and sender.stdout is not None
            if sender.stdout.readline().strip() != "MATCHED":
                raise RuntimeError("the sender did not match the fitter")
            before = settled_rss(fitter.pid)
            after = []
            for k in range(batches):
                sender.stdin.write("GO\n")
                sender.stdin.flush()
                if sender.stdout.readline().strip() != "SENT":
                    raise RuntimeError(f"the sender did not send batch {k + 1}")
                wait_rejected(log_path, text, k + 1)  # measured once taken, not while it is converted
                after.append(settled_rss(fitter.pid))
                print(f"batch {k + 1}: fitter RSS {after[-1]:.1f} MB ({after[-1] - before:+.1f} MB)", flush=True)
            if fitter.poll() is not None:
                raise RuntimeError(f"the fitter ended with status {fitter.returncode}")
        finally:
            sender.kill()
            sender.wait(10)
            fitter.terminate()
            fitter.wait(20)
            for stream in (sender.stdin, sender.stdout):
                if stream is not None:
                    stream.close()
    if log_path.read_text().count(text) != batches:
        raise RuntimeError(f"not every batch was rejected once: {log_path.read_text()[-2000:]}")
    return before, after


def main(argv: list[str] | None = None) -> int:
    """Run the check (see the module docstring); 1 when it fails."""
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--samples", type=int, default=2_000_000, help="samples per batch (default 2,000,000)")
    parser.add_argument("--batches", type=int, default=8, help="oversized batches sent (default 8)")
    args = parser.parse_args(argv)
    payload = args.samples * 8 / 2**20
    remove_stale_fastdds_segments()
    with unique_domain_id() as domain_id, tempfile.TemporaryDirectory(prefix="bike_rig_fitter_memory_") as tmp:
        env = ros_environment(domain_id=domain_id)
        env["PYTHONPATH"] = ":".join(filter(None, [str(REPO), env.get("PYTHONPATH")]))
        try:
            before, after = run(args.samples, args.batches, env, Path(tmp) / "fitter.log")
        except RuntimeError as exc:
            print(f"bench_fitter_memory: FAILED: {exc}")
            return 1
    worst = max(after) - before
    print(
        f"fitter RSS before {before:.1f} MB, largest growth {worst:+.1f} MB = {worst / payload:.2f} payloads "
        f"of {payload:.1f} MB (bound {MAX_PAYLOADS})"
    )
    if worst >= MAX_PAYLOADS * payload:
        print(f"bench_fitter_memory: FAILED: the fitter kept more than {MAX_PAYLOADS} payloads")
        return 1
    print(f"bench_fitter_memory: ok: {args.batches} batches rejected, growth within {MAX_PAYLOADS} payloads")
    return 0


if __name__ == "__main__":
    sys.exit(main())
