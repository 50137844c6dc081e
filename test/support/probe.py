"""The test's own end of a ROS graph: an rclpy node in its own context on the run's domain.

Used through the ``probe`` fixture of test/conftest.py, or as a context manager for a second
participant (a late joiner) or one on another graph's domain.
"""

from __future__ import annotations

import importlib
import os
import sys
import time
import uuid
from collections.abc import Callable, Mapping, Sequence
from typing import Any

import rclpy
from rclpy.executors import SingleThreadedExecutor
from rclpy.signals import SignalHandlerOptions

from bike_rig.config import topics
from bike_rig.ros.qos import profile
from test.support.processes import RosProcess

__all__ = ["ABORT", "RESEND_S", "START", "STEP_TIMEOUT_S", "STOP", "Probe", "msgs", "node_command", "srvs"]

#: The rig's message and service classes (built into the venv).
msgs: Any = importlib.import_module("bike_rig_msgs.msg")
srvs: Any = importlib.import_module("bike_rig_msgs.srv")

#: Deadline of one step a test waits for (a match, a message, a response), s.
STEP_TIMEOUT_S = 60.0
#: A request to an idempotent service not answered within this long is sent again (see Probe.call), s.
RESEND_S = 2.0
#: TrialEvent kinds.
START, STOP, ABORT = 0, 1, 2
#: The variables rcl reads when the probe's context starts; set for its lifetime, then restored.
_ENV_KEYS = ("ROS_AUTOMATIC_DISCOVERY_RANGE", "ROS_DOMAIN_ID", "RMW_IMPLEMENTATION")


def node_command(module: str, *parameters: str, params_file: str | None = None) -> list[str]:
    """``python -m MODULE --ros-args [--params-file F] -p ...``."""
    cmd = [sys.executable, "-m", module, "--ros-args"]
    if params_file:
        cmd += ["--params-file", params_file]
    for p in parameters:
        cmd += ["-p", p]
    return cmd


class Probe:
    """The test's DDS participant: its own rclpy context on the domain of ``env`` (LOCALHOST).

    Publishes and listens on bike_rig topics with their contract QoS and calls services; every
    wait has a deadline.

    Args:
        env: A ROS environment (the ``ros_env`` fixture, or ``ros_environment(domain_id=...)``).
    """

    def __init__(self, env: Mapping[str, str]) -> None:
        self._saved = {k: os.environ.get(k) for k in (*_ENV_KEYS, "ROS_LOCALHOST_ONLY")}
        os.environ.update({k: env[k] for k in _ENV_KEYS})
        os.environ.pop("ROS_LOCALHOST_ONLY", None)
        self.context = rclpy.Context()
        rclpy.init(
            context=self.context, domain_id=int(env["ROS_DOMAIN_ID"]), signal_handler_options=SignalHandlerOptions.NO
        )
        self.node = rclpy.create_node(f"probe_{uuid.uuid4().hex[:8]}", context=self.context)
        self.executor = SingleThreadedExecutor(context=self.context)
        self.executor.add_node(self.node)
        self.inbox: dict[str, list[Any]] = {}
        self._publishers: dict[str, Any] = {}
        self._clients: dict[str, Any] = {}

    @property
    def received(self) -> dict[str, list[Any]]:
        """Every message kept so far, by topic name (the lists :meth:`listen` returned)."""
        return self.inbox

    def listen(self, topic: topics.Topic, msg_type: Any) -> list[Any]:
        """Subscribe with the topic's QoS; the returned list fills as messages arrive."""
        box = self.inbox.setdefault(topic.name, [])
        self.node.create_subscription(msg_type, topic.name, box.append, profile(topic))
        return box

    subscribe = listen

    def publisher(self, topic: topics.Topic, msg_type: Any, matched: bool = False) -> Any:
        """The probe's publisher on ``topic`` (one per topic) with the topic's QoS.

        Args:
            topic: The rig topic to publish on (its name and QoS).
            msg_type: The message class of the topic.
            matched: Wait until a subscription has matched: a live delivery. (Data published
                before the match reaches a transient-local subscriber too, as a late joiner,
                but only with the writer's next heartbeat, up to 3 s later with Fast DDS.)
        """
        if topic.name not in self._publishers:
            self._publishers[topic.name] = self.node.create_publisher(msg_type, topic.name, profile(topic))
        pub = self._publishers[topic.name]
        if matched:
            self.wait_for(lambda: pub.get_subscription_count() > 0, f"a subscriber of {topic.name}")
        return pub

    def spin_until(
        self, condition: Callable[[], bool], timeout: float, what: str, describe: Callable[[], str] = lambda: ""
    ) -> None:
        """Spin until ``condition()``; fail after ``timeout`` s, with ``describe()`` in the message."""
        deadline = time.monotonic() + timeout
        while not condition():
            if time.monotonic() > deadline:
                raise AssertionError(f"timed out after {timeout} s waiting for {what}\n{describe()}".rstrip())
            self.executor.spin_once(timeout_sec=0.02)

    def wait_for(self, condition: Callable[[], bool], what: str, timeout: float = STEP_TIMEOUT_S) -> None:
        """Spin until ``condition()``; fail after ``timeout`` s."""
        self.spin_until(condition, timeout, what)

    def wait_message(
        self, topic: topics.Topic, condition: Callable[[Any], bool], what: str, processes: Sequence[RosProcess] = ()
    ) -> Any:
        """The first message on ``topic`` (listened to before) for which ``condition`` holds."""
        box = self.inbox[topic.name]
        self.spin_until(
            lambda: any(condition(m) for m in box),
            STEP_TIMEOUT_S,
            what,
            lambda: "\n".join(p.describe() for p in processes),
        )
        return next(m for m in box if condition(m))

    def call(self, service: Any, *args: Any, timeout: float = STEP_TIMEOUT_S) -> Any:
        """Call a service and return its response: ``call(client, request)`` or ``call(srv_type, name, request)``.

        With a client of the test's own, the request is sent once. With a service type and name
        (an idempotent service), the probe makes the client, and a request not answered within
        ``RESEND_S`` is sent again until ``timeout``: ``service_is_ready()`` only means the
        request path is matched, and DDS drops a response whose reader has not matched yet.
        """
        if hasattr(service, "call_async"):
            (request,) = args
            self.spin_until(service.service_is_ready, timeout, f"service {service.srv_name}")
            future = service.call_async(request)
            self.spin_until(future.done, timeout, f"a response from {service.srv_name}")
            return future.result()
        name, request = args
        client = self._clients.get(name)
        if client is None:
            client = self._clients[name] = self.node.create_client(service, name)
        self.wait_for(lambda: client.service_is_ready(), f"service {name}", timeout)
        deadline = time.monotonic() + timeout
        while True:
            future = client.call_async(request)
            try:
                self.wait_for(
                    future.done, f"a response from {name}", min(RESEND_S, max(0.0, deadline - time.monotonic()))
                )
            except AssertionError:
                client.remove_pending_request(future)
                if time.monotonic() >= deadline:
                    raise AssertionError(f"timed out after {timeout} s waiting for a response from {name}") from None
                continue
            return future.result()

    def __enter__(self) -> Probe:
        return self

    def __exit__(self, *exc: object) -> None:
        self.close()

    def close(self) -> None:
        """Shut the context down and restore the process's ROS variables."""
        self.executor.shutdown(timeout_sec=1.0)
        self.node.destroy_node()
        rclpy.shutdown(context=self.context)
        for key, value in self._saved.items():
            if value is None:
                os.environ.pop(key, None)
            else:
                os.environ[key] = value
