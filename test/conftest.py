"""Fixtures shared by every test folder (keep it small: folder-specific fixtures live there).

Also marks the tiers: a test that uses a ROS fixture (directly or through another fixture) is
marked ``ros``, so that ``pytest -m "not ros and not slow"`` (``make test-fast``) starts no ROS
process.
"""

from __future__ import annotations

from collections.abc import Iterator
from pathlib import Path
from typing import TYPE_CHECKING

import pytest

from bike_rig.rosenv import remove_stale_fastdds_segments, ros_environment, unique_domain_id
from test.support.paper import SharedFolderMissingError, shared_dir

if TYPE_CHECKING:
    from test.support.probe import Probe

#: Fixtures that reserve the run's ROS domain or start ROS processes: a test using any of them is marked ``ros``.
ROS_FIXTURES = frozenset({"ros_domain_id", "ros_env", "node_env", "probe"})


def pytest_collection_modifyitems(config: pytest.Config, items: list[pytest.Item]) -> None:
    """Mark ``ros`` every test that uses a ROS fixture (its fixture closure names one)."""
    for item in items:
        if ROS_FIXTURES.intersection(getattr(item, "fixturenames", ())):
            item.add_marker(pytest.mark.ros)


@pytest.fixture(scope="session")
def ros_domain_id() -> Iterator[int]:
    """A ROS_DOMAIN_ID reserved for this pytest run (held until the session ends).

    Also removes Fast DDS shared-memory files left by killed processes of earlier runs, which
    would slow down discovery.
    """
    remove_stale_fastdds_segments()
    with unique_domain_id() as domain_id:
        yield domain_id


@pytest.fixture
def ros_env(ros_domain_id: int) -> dict[str, str]:
    """Environment for a ROS process started by a test: LOCALHOST discovery, the run's domain.

    A fresh copy per test, from bike_rig.rosenv.ros_environment.
    """
    return ros_environment(domain_id=ros_domain_id)


@pytest.fixture(scope="session", name="shared_dir")
def shared_dir_fixture() -> Path:
    """The read-only reference material (data, paper, notes): ``<repo>/../shared``.

    Located by ``test.support.paper.shared_dir`` (which honours ``$BIKE_RIG_SHARED``); a
    missing folder fails the test with that function's message instead of a traceback.
    """
    try:
        return shared_dir()
    except SharedFolderMissingError as exc:
        problem = str(exc)
    pytest.fail(f"{problem}: the tests expect shared/ beside the repository, as CI provides it", pytrace=False)


@pytest.fixture
def probe(ros_env: dict[str, str]) -> Iterator[Probe]:
    """The test's own ROS node on the run's domain (:class:`test.support.probe.Probe`), closed after the test."""
    from test.support.probe import Probe  # rclpy only for the tests that use it

    with Probe(ros_env) as p:
        yield p
