"""Refused commands and the operator tools' small parts, without a controller (real LCM on a
random udpm port, ttl=0): a NaN or infinite command raises omni4.CommandRejected (still a
ValueError for old code), nothing is sent and it is counted; why a clear is refused, read from
a sample (the e-stop line, the latching faults); the silence watch of omni4-status and
omni4-teleop on an injected clock."""
import random
import threading
import time

import lcm
import pytest

import omni4
from omni4.robot import clear_refusal_reason
from omni4.status import Silence

LIMITS = {"limits.vel_lin_max": 3.0, "limits.vel_rot_max": 20.0, "limits.supply_v": 12.0}
NAN, INF = float("nan"), float("inf")


def random_url():
    # 7700-10999: the range 7600-7699 holds the tests' fixed ports
    return f"udpm://239.255.76.67:{random.randint(7700, 10999)}?ttl=0"


class CmdListener:
    """Counts command_t messages on OMNI4_CMD of a URL."""

    def __init__(self, url):
        self.lc = lcm.LCM(url)
        self.cmds = []
        self.lc.subscribe(omni4.CHANNEL_CMD, lambda _c, d: self.cmds.append(d))
        self.done = threading.Event()
        self.t = threading.Thread(target=self._loop, daemon=True)
        self.t.start()

    def _loop(self):
        while not self.done.is_set():
            self.lc.handle_timeout(20)

    def close(self):
        self.done.set()
        self.t.join(2)


@pytest.mark.parametrize("limits", [LIMITS, False])
@pytest.mark.parametrize("call", [
    lambda r: r.velocity(NAN, 0, 0), lambda r: r.velocity(0, INF, 0),
    lambda r: r.velocity(0, 0, -INF), lambda r: r.voltage([1, NAN, 1, 1]),
    lambda r: r.voltage([1, 1, 1, INF]), lambda r: r.voltage([1, 1, 1, 1], ramp_s=NAN),
    lambda r: r.voltage([1, 1, 1, 1], ramp_s=INF)],
    ids=["v-nan", "vn-inf", "w-minf", "u1-nan", "u3-inf", "ramp-nan", "ramp-inf"])
def test_a_value_not_finite_raises_command_rejected_and_sends_nothing(call, limits):
    url = random_url()
    listener = CmdListener(url)
    try:
        with omni4.Robot(url, limits=limits) as robot:
            with pytest.raises(omni4.CommandRejected, match="finite") as e:
                call(robot)
            assert isinstance(e.value, ValueError)        # `except ValueError` still catches it
            assert e.value.command is None and "finite" in e.value.reason
            assert robot.rejected == 1
            time.sleep(0.1)
            assert robot.sent == 0 and listener.cmds == []
    finally:
        listener.close()


def test_a_wrong_number_of_values_is_a_plain_value_error():
    with omni4.Robot(random_url(), limits=False) as robot:
        with pytest.raises(ValueError, match="4 values") as e:
            robot.voltage([1, 2, 3])
        assert not isinstance(e.value, omni4.CommandRejected)


def _sample(mode, faults):
    m = omni4.motors_t()
    m.mode, m.faults = mode, faults
    return m


def test_why_a_clear_is_refused_comes_from_the_sample():
    M = omni4.motors_t
    estop = clear_refusal_reason(_sample(M.MODE_ESTOP, M.FAULT_ESTOP | M.FAULT_CMD_REJECTED))
    assert estop == "still ESTOP: the e-stop line is still asserted (ESTOP): release it, then clear"
    both = clear_refusal_reason(_sample(M.MODE_FAULT, M.FAULT_SUPPLY | M.FAULT_ESTOP |
                                        M.FAULT_OVERCURRENT | M.FAULT_CMD_REJECTED))
    assert both.startswith("still FAULT: the e-stop line is still asserted")
    assert "the cause of a latching fault is still present: OVERCURRENT (a current above " \
           "[limits] current_max_a); SUPPLY (the supply is below [limits] supply_min_v)" in both
    bus = clear_refusal_reason(_sample(M.MODE_FAULT, M.FAULT_BUS))
    assert "BUS (" in bus and "another controller" in bus
    assert clear_refusal_reason(_sample(M.MODE_FAULT, 0)) == \
        "still FAULT: faults 0x0000: the cause is still present"
    for bit in (M.FAULT_OVERCURRENT, M.FAULT_DRIVER_TIMEOUT, M.FAULT_DRIVER, M.FAULT_BUS,
                M.FAULT_ENCODER, M.FAULT_CURRENT_SENSOR, M.FAULT_SUPPLY):
        assert "latching fault" in clear_refusal_reason(_sample(M.MODE_FAULT, bit)), hex(bit)


def test_silence_is_said_once_after_a_second_and_once_when_it_ends():
    now = [50.0]
    s = Silence(1.0, clock=lambda: now[0])
    now[0] = 50.999
    assert s.check() is None
    now[0] = 51.0                              # 1 s from the start without a message
    assert s.check() == "lost" and s.check() is None
    now[0] = 53.5
    assert s.check() is None                   # said once per silence
    s.heard()
    assert s.check() == "back" and s.gap_s == pytest.approx(3.5) and s.check() is None
    now[0] = 54.0
    s.heard()
    now[0] = 54.9
    assert s.check() is None                   # 0.9 s: not yet
    now[0] = 55.0
    assert s.check() == "lost"
    s.heard(54.95)                             # a message heard (stamped) before now
    assert s.check() == "back" and s.gap_s == pytest.approx(0.95)
