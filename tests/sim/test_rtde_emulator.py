"""The unmodified ur_rtde 1.6.5 client against the emulator subprocess (kinematic arm)."""

from __future__ import annotations

import time
from collections.abc import Callable

import dashboard_client
import numpy as np
import pytest
import rtde_control
import rtde_receive
from scan_session import read_state

from sim.robot.kinematics import forward_kinematics
from sim.rtde.faults import FaultPlan
from sim.rtde.launch import launch
from sim.rtde.server import DASHBOARD_PORT, RTDE_PORT, Ports
from sim.transforms import pose_from_ur

pytestmark = [pytest.mark.slow, pytest.mark.hang_guard]


@pytest.fixture(scope="module")
def emulator():
    with launch(arm="kinematic") as running:
        yield running


@pytest.fixture(scope="module")
def clients(emulator):
    receive = rtde_receive.RTDEReceiveInterface(emulator.host)
    control = rtde_control.RTDEControlInterface(emulator.host)
    try:
        yield control, receive
    finally:
        control.disconnect()
        receive.disconnect()


def _wait_until(condition: Callable[[], bool], timeout: float = 2.0) -> None:
    """Poll `condition` until it holds or `timeout` s pass: the next RTDE packet may be late on a
    busy machine. The caller's own assert then says what was wrong if it never held."""
    deadline = time.monotonic() + timeout
    while not condition() and time.monotonic() < deadline:
        time.sleep(0.005)


def test_handshake_all_default_recipes_and_program_running(clients, emulator):
    control, receive = clients
    assert receive.isConnected() and control.isConnected()
    # The receive stream connected before the control script was sent, so it shows the script
    # playing from the next packet its thread takes in; on a loaded host that thread can lag
    # the control interface's answer by more than a cycle.
    _wait_until(lambda: receive.getRuntimeState() == 2)
    assert control.isProgramRunning() and receive.getRuntimeState() == 2
    assert receive.getRobotMode() == 7 and receive.getSafetyMode() == 1
    assert not receive.isProtectiveStopped() and not receive.isEmergencyStopped()
    assert "rtde_control running" in emulator.log()


def test_dashboard_answers_like_polyscope(emulator):
    client = dashboard_client.DashboardClient(emulator.host)
    client.connect()
    try:
        assert client.polyscopeVersion() == "5.11.0.108249"
        assert client.getSerialNumber().isdigit()
        assert client.robotmode() == "Robotmode: RUNNING"
        assert client.safetystatus() == "Safetystatus: NORMAL"
        client.closeSafetyPopup()
        with pytest.raises(RuntimeError, match="not protective stopped"):
            client.unlockProtectiveStop()
    finally:
        client.disconnect()


def test_tcp_pose_is_the_forward_kinematics_of_the_joints(clients):
    _, receive = clients
    q, tcp = np.array(receive.getActualQ()), np.array(receive.getActualTCPPose())
    np.testing.assert_allclose(pose_from_ur(tcp), forward_kinematics(q), atol=1e-9)
    first, began = receive.getTimestamp(), time.monotonic()
    time.sleep(0.2)
    robot_elapsed, wall_elapsed = receive.getTimestamp() - first, time.monotonic() - began
    # Simulated time runs with the clock: never ahead of it (beyond a packet or two of
    # staleness in `first`; bounded by the wall time measured, not the 0.2 s asked for, which
    # a loaded machine may oversleep), and not far behind it (a stalled loop drops the time
    # it lost beyond `MAX_LAG`).
    assert 0.1 < robot_elapsed < wall_elapsed + 0.05


def _first_packet_at(receive, position: np.ndarray, timeout: float = 2.0) -> float:
    """Robot time of the first packet with the TCP within 1 um of `position`. moveL returns
    when the control interface's stream reports it done; the receive interface's stream
    may be a packet or two behind it on a loaded machine."""
    deadline = time.monotonic() + timeout
    while time.monotonic() < deadline:
        stamp, pose, _ = read_state(receive)
        if np.allclose(pose[:3], position, atol=1e-6):
            return stamp
        time.sleep(0.001)
    raise AssertionError(f"TCP not at {position}: {pose[:3]}")


def test_movel_reaches_its_target_in_the_profile_time(clients):
    """Timed on the robot clock: a loaded machine runs the emulator behind the wall clock."""
    control, receive = clients
    began, start, _ = read_state(receive)
    goal = start + np.array([0.03, -0.02, -0.04, 0.0, 0.0, 0.0])
    assert control.moveL(goal.tolist(), 0.1, 0.5)
    elapsed = _first_packet_at(receive, goal[:3]) - began
    distance = float(np.linalg.norm(goal[:3] - start[:3]))
    profile_time = distance / 0.1 + 0.1 / 0.5  # cruise plus one ramp
    # The move starts in the cycle after the command arrives, a few cycles after the packet
    # read before it (more when this process waits for a core).
    assert profile_time - 0.004 < elapsed < profile_time + 0.1
    assert control.moveL(start.tolist(), 0.25, 1.2)


def smoothed_step(k: np.ndarray, ratio: float) -> np.ndarray:
    """Fraction of a step that two first-order stages, each keeping `ratio` of its error per
    cycle, have passed on after k cycles: 1 - r**k - k (1 - r) r**k."""
    return 1.0 - ratio**k - k * (1.0 - ratio) * ratio**k


def test_servol_approaches_its_target_through_the_lookahead_filter(clients):
    """UR's servo smooths a stream over its lookahead time (`sim.robot.motions.Servo`): a
    target 10 mm away, streamed at 500 Hz, is approached cycle by cycle as by two first-order
    stages of half the lookahead each (critically damped, so the velocity starts from zero
    instead of jumping), x_k = step * smoothed_step(k, r) with r = (lookahead / 2) /
    (lookahead / 2 + period) after k cycles. Checked on the robot clock, packet by packet, so
    it holds however late this loop or the emulator runs."""
    control, receive = clients
    began, start, _ = read_state(receive)
    step, lookahead, period = 0.01, 0.05, 0.002
    target = start.copy()
    target[0] += step
    samples = []
    while not samples or samples[-1][0] < began + 0.4:
        cycle = control.initPeriod()
        assert control.servoL(target.tolist(), 0.5, 0.5, period, lookahead, 300)
        stamp, pose, _ = read_state(receive)
        samples.append((stamp, pose[0] - start[0]))
        control.waitPeriod(cycle)
    control.servoStop(2.0)
    times, moved = np.array(samples).T
    first = int(np.argmax(moved > 1e-9))
    ratio = 0.5 * lookahead / (0.5 * lookahead + period)
    candidates = np.arange(1, 200)
    fit = np.abs(step * smoothed_step(candidates, ratio) - moved[first])
    cycles = int(candidates[np.argmin(fit)])  # how long it had been moving
    assert fit.min() < 1e-9, (cycles, fit.min())
    applied = times[first] - cycles * period  # the cycle that took the target
    k = np.round((times[first:] - applied) / period)
    np.testing.assert_allclose(moved[first:], step * smoothed_step(k, ratio), atol=1e-7)
    assert moved[-1] > 0.9 * step  # 0.3 s and more: six lookahead times


def test_tcp_offset_moves_the_reported_tcp(clients):
    control, receive = clients
    flange = pose_from_ur(receive.getActualTCPPose())
    assert control.setTcp([0.0, 0.0, 0.1, 0.0, 0.0, 0.0])
    assert control.getTCPOffset() == [0.0, 0.0, 0.1, 0.0, 0.0, 0.0]
    expected = flange[:3, 3] + 0.1 * flange[:3, 2]
    _wait_until(
        lambda: np.allclose(pose_from_ur(receive.getActualTCPPose())[:3, 3], expected, atol=1e-9)
    )
    tcp = pose_from_ur(receive.getActualTCPPose())
    np.testing.assert_allclose(tcp[:3, 3], expected, atol=1e-9)
    assert control.setTcp([0.0] * 6)


def test_a_second_control_client_is_refused_its_registers(clients, emulator):
    with pytest.raises(RuntimeError, match="already in use"):
        rtde_control.RTDEControlInterface(emulator.host)


def test_unimplemented_command_is_reported_and_stops_the_program(clients, emulator):
    control, _ = clients
    assert control.teachMode() is False
    assert not control.isProgramRunning()
    assert "command id 18 (TEACH_MODE) is not implemented" in emulator.log()
    assert control.reuploadScript()
    _wait_until(control.isProgramRunning)
    assert control.isProgramRunning()


def test_fault_times_count_from_the_emulator_start_or_from_the_first_motion_command():
    plan = FaultPlan.parse(["drop@motion+2.5+1", "protective-stop@motion+6"])
    assert plan.drop_after_motion and plan.protective_stop_after_motion
    assert plan.drop_time(None) == plan.protective_stop_time(None) == np.inf  # no motion yet
    assert (plan.drop_time(10.0), plan.protective_stop_time(10.0)) == (12.5, 16.0)
    assert not plan.refusing(12.4, 10.0) and plan.refusing(13.0, 10.0)
    assert not plan.refusing(13.5, 10.0) and not plan.refusing(13.0, None)
    absolute = FaultPlan.parse(["protective-stop@3"])
    assert absolute.protective_stop_time(None) == absolute.protective_stop_time(10.0) == 3.0
    with pytest.raises(ValueError, match="motion\\+T"):
        FaultPlan.parse(["drop@motion-1"])


def test_motion_relative_fault_strikes_after_the_first_motion_command():
    with launch(faults=("protective-stop@motion+0.2",)) as running:
        receive = rtde_receive.RTDEReceiveInterface(running.host)
        control = rtde_control.RTDEControlInterface(running.host)
        try:
            time.sleep(0.5)  # connected and idle: no motion yet, no fault
            assert running.fault_time() is None and not receive.isProtectiveStopped()
            start = receive.getActualTCPPose()
            began = receive.getTimestamp()
            assert control.moveL(start, 0.1, 0.5)  # a move to where it is: a motion command
            deadline = time.monotonic() + 5.0
            while not receive.isProtectiveStopped() and time.monotonic() < deadline:
                time.sleep(0.01)
            assert receive.isProtectiveStopped()
            assert "first motion command (MOVEL)" in running.log()
            # 0.2 s after the cycle that ran moveL, which is at most a few cycles after `began`
            assert 0.2 - 1e-6 <= running.fault_emulator_time() - began < 0.3
        finally:
            control.disconnect()
            receive.disconnect()


def test_ports_stay_within_the_tcp_range():
    assert Ports(100).dashboard == DASHBOARD_PORT + 100 and Ports(-29998).dashboard == 1
    assert Ports(65535 - RTDE_PORT).rtde == 65535
    for base in (-29999, 65536 - RTDE_PORT):
        with pytest.raises(ValueError, match=f"port base {base} puts the ports at .*1-65535"):
            Ports(base)
