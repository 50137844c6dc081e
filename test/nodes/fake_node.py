"""A stand-in node process for launcher tests.

Writes its environment and arguments (atomically, as ``<pid>.json``), then waits for a signal
(or exits with the status given by ``--exit N``).
"""

from __future__ import annotations

import json
import os
import signal
import sys
import time


def main() -> int:
    args = sys.argv[1:]
    out = os.environ["FAKE_NODE_OUT"]
    name = os.environ.get("FAKE_NODE_NAME", "node")
    env = {k: os.environ.get(k) for k in ("ROS_AUTOMATIC_DISCOVERY_RANGE", "ROS_DOMAIN_ID")}
    # written aside and renamed: a reader polling ``*.json`` sees no report or a whole one
    tmp = f"{out}/{os.getpid()}.tmp"
    with open(tmp, "w") as f:
        json.dump({"args": args, "env": env, "name": name}, f)
    os.replace(tmp, f"{out}/{os.getpid()}.json")
    if "--exit" in args:
        return int(args[args.index("--exit") + 1])
    stopped = {"sig": 0}

    def handler(signum: int, _frame: object) -> None:
        stopped["sig"] = signum

    signal.signal(signal.SIGINT, handler)
    signal.signal(signal.SIGTERM, handler)
    while not stopped["sig"]:
        time.sleep(0.02)
    return 0


if __name__ == "__main__":
    sys.exit(main())
