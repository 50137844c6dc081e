"""bike_rig.ros.env: the environment of ROS processes, domain ids, stale shared memory."""

from __future__ import annotations

import os
import time
import xml.etree.ElementTree as ET
from pathlib import Path

import pytest

from bike_rig.config.paths import config_file
from bike_rig.ros import env as rosenv
from bike_rig.ros.env import (
    StaticPeerError,
    fallback_domain_id,
    remove_stale_fastdds_segments,
    ros_environment,
    unique_domain_id,
)


def test_environment_forces_localhost_rmw_and_domain() -> None:
    base = {
        "PATH": "/usr/bin",
        "ROS_AUTOMATIC_DISCOVERY_RANGE": "SUBNET",
        "ROS_LOCALHOST_ONLY": "1",
        "ROS_STATIC_PEERS": "192.0.2.1",
        "RMW_IMPLEMENTATION": "rmw_cyclonedds_cpp",
        "ROS_DOMAIN_ID": "5",
    }
    env = ros_environment(base, domain_id=42)
    assert env == {
        "PATH": "/usr/bin",
        "ROS_AUTOMATIC_DISCOVERY_RANGE": "LOCALHOST",
        "RMW_IMPLEMENTATION": "rmw_fastrtps_cpp",
        "ROS_DOMAIN_ID": "42",
        "FASTDDS_DEFAULT_PROFILES_FILE": str(config_file("dds/fastdds.xml")),
    }
    assert base["ROS_DOMAIN_ID"] == "5"  # the base is not modified


def test_the_fastdds_profile_outlasts_a_stall_and_a_users_own_is_kept() -> None:
    """The shipped profile's participant lease outlasts a 20 s stall (Fast DDS's default is 20 s)."""
    profile = ET.parse(config_file("dds/fastdds.xml")).getroot()
    ns = {"d": "http://www.eprosima.com"}
    (default,) = [p for p in profile.iterfind(".//d:participant", ns) if p.get("is_default_profile") == "true"]
    lease = default.find("d:rtps/d:builtin/d:discovery_config/d:leaseDuration/d:sec", ns)
    assert lease is not None and int(lease.text or 0) >= 60
    own = ros_environment({"FASTDDS_DEFAULT_PROFILES_FILE": "/lab/dds.xml"}, domain_id=3)
    assert own["FASTDDS_DEFAULT_PROFILES_FILE"] == "/lab/dds.xml"


def test_environment_keeps_an_inherited_domain_id() -> None:
    assert ros_environment({"ROS_DOMAIN_ID": " 7 "})["ROS_DOMAIN_ID"] == "7"


def test_environment_without_domain_uses_the_process_reservation() -> None:
    env = ros_environment({})
    assert env["ROS_DOMAIN_ID"] == str(rosenv.process_domain_id())
    assert ros_environment({})["ROS_DOMAIN_ID"] == env["ROS_DOMAIN_ID"]


def test_environment_defaults_to_os_environ(monkeypatch: pytest.MonkeyPatch) -> None:
    monkeypatch.setenv("BIKE_RIG_ROSENV_PROBE", "x")
    monkeypatch.delenv("ROS_DOMAIN_ID", raising=False)
    env = ros_environment(domain_id=3)
    assert env["BIKE_RIG_ROSENV_PROBE"] == "x"
    assert env["ROS_DOMAIN_ID"] == "3"
    assert "ROS_DOMAIN_ID" not in os.environ  # a copy: os.environ is left alone


@pytest.mark.parametrize("bad", [{"ROS_DOMAIN_ID": "abc"}, {"ROS_DOMAIN_ID": "102"}])
def test_environment_rejects_bad_inherited_domain(bad: dict[str, str]) -> None:
    with pytest.raises(ValueError, match="ROS_DOMAIN_ID"):
        ros_environment(bad)


def test_environment_rejects_bad_domain_argument() -> None:
    with pytest.raises(ValueError, match="outside"):
        ros_environment({}, domain_id=-1)


def test_unique_domain_ids_differ_while_held() -> None:
    with unique_domain_id() as first, unique_domain_id() as second:
        assert first != second
        assert 1 <= first <= 100
        assert 1 <= second <= 100


def test_unique_domain_id_survives_an_oserror_in_the_body() -> None:
    with pytest.raises(OSError, match="body"), unique_domain_id():
        raise OSError("body")


def test_unique_domain_id_falls_back_to_the_pid(monkeypatch: pytest.MonkeyPatch) -> None:
    import domain_coordinator.impl

    def refuse(*args: object, **kwargs: object) -> None:
        raise OSError("no port")

    # every bind fails, so the coordinator gives up with RuntimeError
    monkeypatch.setattr(domain_coordinator.impl.socket.socket, "bind", refuse)
    with unique_domain_id() as value:
        assert value == fallback_domain_id()


def test_fallback_domain_id_range() -> None:
    assert fallback_domain_id(0) == 1
    assert fallback_domain_id(199) == 100
    assert all(1 <= fallback_domain_id(pid) <= 100 for pid in range(1000, 1300))


def _fake_proc(root: Path, pid: int, maps: list[str], fds: list[Path]) -> None:
    proc = root / str(pid)
    (proc / "fd").mkdir(parents=True)
    (proc / "maps").write_text(
        "".join(f"7f00-7f01 rw-s 00000000 00:19 12 {m}\n" for m in maps) + "7f02-7f03 r--p 00000000 00:00 0\n"
    )
    for i, target in enumerate(fds):
        (proc / "fd" / str(i)).symlink_to(target)


def test_stale_segments_are_removed_and_used_ones_kept(tmp_path: Path) -> None:
    shm, proc = tmp_path / "shm", tmp_path / "proc"
    shm.mkdir()
    proc.mkdir()
    live = [  # one live port (mapped segment, open lock file, mutex not open) and participant
        "fastdds_port7411",
        "fastdds_port7411_el",
        "sem.fastdds_port7411_mutex",
        "fastdds_0123abcd",
        "fastdds_0123abcd_el",
    ]
    stale = [
        "fastdds_port7413",
        "fastdds_port7413_el",
        "sem.fastdds_port7413_mutex",
        "fastdds_feedbeef",
        "fastdds_feedbeef_el",
    ]
    fresh = ["fastdds_port7415", "fastdds_port7415_el"]  # unused, but just created
    others = ["lttng-ust-wait-6", "other_fastdds_x"]
    old = time.time() - 3600
    for name in live + stale + fresh + others:
        (shm / name).write_bytes(b"x")
        if name not in fresh:
            os.utime(shm / name, (old, old))
    _fake_proc(proc, 100, [str(shm / "fastdds_port7411"), str(shm / "fastdds_0123abcd")], [shm / "fastdds_port7411_el"])
    _fake_proc(proc, 101, [], [shm / "fastdds_0123abcd_el"])
    (proc / "self").mkdir()  # not a pid: ignored

    removed = remove_stale_fastdds_segments(shm, min_age_s=10.0, proc=proc)

    assert sorted(p.name for p in removed) == sorted(stale)
    assert sorted(p.name for p in shm.iterdir()) == sorted(live + fresh + others)


def test_no_segments_is_a_no_op(tmp_path: Path) -> None:
    assert remove_stale_fastdds_segments(tmp_path, proc=tmp_path / "missing") == []


def test_static_peers_are_set_only_when_given_and_discovery_stays_localhost() -> None:
    env = ros_environment({"ROS_STATIC_PEERS": "192.0.2.1"}, domain_id=3, static_peers=[" 10.213.0.2", "fd00::2"])
    assert env["ROS_STATIC_PEERS"] == "10.213.0.2;fd00::2"  # ROS 2 separates peers with ';'
    assert env["ROS_AUTOMATIC_DISCOVERY_RANGE"] == "LOCALHOST"  # unicast to the peers, no multicast
    assert "ROS_STATIC_PEERS" not in ros_environment({"ROS_STATIC_PEERS": "192.0.2.1"}, domain_id=3)


@pytest.mark.parametrize("peer", ["rig.local", "10.0.0.300", "", "10.0.0.1;10.0.0.2"])
def test_a_static_peer_must_be_an_ip_address(peer: str) -> None:
    with pytest.raises(StaticPeerError, match=r"^static peer .* is not an IP address \(e\.g\. 10\.0\.0\.2\)$"):
        ros_environment({}, domain_id=3, static_peers=[peer])
