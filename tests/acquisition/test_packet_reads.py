"""Reading one RTDE state packet's fields while ur_rtde's receive thread replaces the packet.

The real client's thread cannot be made to stall on cue, so a stand-in replays a packet stream
the way ur_rtde does after a stall: queued packets applied one after another, here one before
each getter call while the backlog lasts."""

from __future__ import annotations

import pytest

from resus.acquisition.backends import rtde_link
from resus.acquisition.backends.rtde_link import read_packet

PERIOD = 0.002
"""The e-Series controller's packet period (500 Hz)."""


class ReplayingReceive:
    """Getters of an `RTDEReceiveInterface` whose packet n has timestamp n * PERIOD and every
    field equal to n; each call first applies one more queued packet while `backlog` lasts."""

    def __init__(self, backlog: float) -> None:
        self.packet = 0
        self.backlog = backlog

    def _current(self) -> int:
        if self.backlog > 0:
            self.packet += 1
            self.backlog -= 1
        return self.packet

    def getTimestamp(self) -> float:  # noqa: N802 (ur_rtde's names)
        return self._current() * PERIOD

    def getActualTCPPose(self) -> list[float]:  # noqa: N802
        return [float(self._current())] * 6

    def getActualQ(self) -> list[float]:  # noqa: N802
        return [float(self._current())] * 6


@pytest.mark.parametrize("backlog", [0, 1, 2, 7, 40])  # 40 packets: an 80 ms stall
def test_every_field_comes_from_the_packet_of_the_timestamp(backlog):
    receive = ReplayingReceive(backlog)
    stamp, (pose, joints) = read_packet(receive, "getActualTCPPose", "getActualQ")
    assert stamp == pytest.approx(pose[0] * PERIOD) and pose == joints == [pose[0]] * 6
    assert pose[0] == backlog  # the first read that agreed is after the backlog ran out
    assert receive.backlog == 0


def test_a_packet_stream_that_never_settles_is_an_error_not_a_mixed_packet(monkeypatch):
    monkeypatch.setattr(rtde_link, "PACKET_READ_TIMEOUT", 0.05)
    with pytest.raises(RuntimeError, match=r"every state packet read for 0.05 s mixed two"):
        read_packet(ReplayingReceive(float("inf")), "getActualTCPPose")
