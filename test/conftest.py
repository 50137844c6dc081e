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

from bike_rig.ros.env import remove_stale_fastdds_segments, ros_environment, unique_domain_id
from test.support.paper import SharedFolderMissingError, shared_dir

if TYPE_CHECKING:
    from test.support.probe import Probe

#: Statistical campaigns, long simulations and whole reports (each several CPU-seconds; a file: all
#: of it, as its module fixtures are the cost): marked ``slow``, left out of ``make test-fast``.
SLOW_TESTS = (
    # campaigns: many seeded sessions or trials, sigma coverage, Monte Carlo
    "test/core/ride/test_calibration.py",
    "test/core/sim/test_round_trip.py",
    "test/core/sim/test_swing_round_trip.py",
    "test/core/sim/test_refined_round_trip.py::test_the_sigma_are_honest_over_ten_sessions",
    "test/core/sim/test_session.py::test_dry_friction_decays_the_swing_linearly_until_it_stops_and_keeps_the_period",
    "test/core/test_period_damping.py::test_the_damping_model_the_data_support_is_chosen_and_its_period_is_honest",
    "test/core/test_period_damping.py::test_a_finite_swing_gives_the_small_swing_period_of_the_integrated_pendulum",
    "test/core/test_period_damping.py::test_a_finite_swing_is_not_beating",
    "test/core/test_period_damping.py::test_a_torsional_pendulum_has_no_swing_term",
    "test/core/test_period_beating.py::test_clean_trials_are_not_flagged",
    "test/core/test_period.py::test_long_records_of_short_periods",
    "test/core/test_period.py::test_arbitrary_arrays_never_raise",
    "test/core/test_feedback.py::test_random_schedules_match_eig",
    "test/core/uncertainty/test_speed_sigma.py::test_sigma_agrees_with_monte_carlo",
    "test/core/test_rider_yeadon.py::test_a_rider_is_seated_once_for_parameter_sets_that_differ_beyond_w_rr_rf",
    "test/fuzz/test_readers_fuzz.py::test_mutated_inputs_never_crash_or_hang",
    "test/fuzz/test_readers_fuzz.py::test_yaml_readers_take_any_value_anywhere",
    "test/bag/test_recover.py::test_any_cut_recovers_exactly_the_complete_chunks",
    # whole reports and figure sets
    "test/report/test_report.py",
    "test/report/test_report_feedback.py",
    "test/report/test_report_chromium.py",
    "test/cli/test_report_cmd.py::test_report_writes_the_page",
    "test/cli/test_plot_cmd.py",
    "test/plots/test_trials.py::test_fit_figure_title_wraps_inside_the_figure_at_the_reports_size",
    # replays and reads of whole sessions in processes of their own
    "test/cli/test_startup.py::test_replay_gives_the_same_output_with_blas_threads",
    "test/cli/test_startup.py::test_replay_run_as_a_command_asks_for_one_blas_thread_unless_told",
    "test/cli/test_input_hygiene.py::test_a_large_csv_takes_memory_bounded_by_its_size",
    "test/bag/test_replay_yeadon.py::test_replay_with_a_yeadon_rider",
    "test/bag/test_schemas.py::test_a_gyro_batch_with_its_fields_in_another_order_is_read_with_the_bags_schema",
    "test/bag/test_split.py::test_split_by_size_keeps_every_message_in_order_and_every_file_opens_alone",
)

#: Fixtures that reserve the run's ROS domain or start ROS processes: a test using any of them is marked ``ros``.
ROS_FIXTURES = frozenset({"ros_domain_id", "ros_env", "node_env", "probe"})


def _is_slow(nodeid: str) -> bool:
    """Whether ``nodeid`` is one of SLOW_TESTS (a file, a test, or any parameter case of it)."""
    return any(nodeid == s or nodeid.startswith((s + "::", s + "[")) for s in SLOW_TESTS)


def pytest_collection_modifyitems(config: pytest.Config, items: list[pytest.Item]) -> None:
    """Mark ``ros`` every test that uses a ROS fixture (its fixture closure names one), ``slow`` SLOW_TESTS."""
    for item in items:
        if ROS_FIXTURES.intersection(getattr(item, "fixturenames", ())):
            item.add_marker(pytest.mark.ros)
        if _is_slow(item.nodeid):
            item.add_marker(pytest.mark.slow)


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

    A fresh copy per test, from bike_rig.ros.env.ros_environment.
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
