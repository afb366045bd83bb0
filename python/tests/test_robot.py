"""omni4.Robot without a controller, on real LCM (udpm, ttl=0, conftest.lcm_test_url): the command
stream it sends (seq, utime, keep-alive period, IDLE on stop and close), argument checks, and
the bounded waits."""
import importlib
import math
import threading
import time

import lcm
import pytest
from conftest import lcm_test_url

import omni4

KEEPALIVE_S = 0.05


random_url = lcm_test_url


class Listener:
    """Collects (monotonic receive time [s], command_t) from OMNI4_CMD on its own LCM."""

    def __init__(self, url):
        self.lc = lcm.LCM(url)
        self.cmds = []
        self.lc.subscribe(omni4.CHANNEL_CMD, self._on)
        self.done = threading.Event()
        self.t = threading.Thread(target=self._loop, daemon=True)
        self.t.start()

    def _on(self, _ch, data):
        self.cmds.append((time.monotonic(), omni4.command_t.decode(data)))

    def _loop(self):
        while not self.done.is_set():
            self.lc.handle_timeout(20)

    def wait_for(self, pred, timeout_s=30.0):
        """Until a received command satisfies pred (counted, not timed: a loaded machine only
        makes it later; timeout_s is the failure bound)."""
        end = time.monotonic() + timeout_s
        while not any(pred(c) for _, c in list(self.cmds)):
            assert time.monotonic() < end, f"no such command within {timeout_s} s"
            time.sleep(0.01)

    def close(self):
        self.done.set()
        self.t.join(2)
        assert not self.t.is_alive(), "listener thread did not end within 2 s"


@pytest.fixture
def bus():
    url = random_url()
    listener = Listener(url)
    yield url, listener
    listener.close()


def test_keepalive_resends_the_last_command_with_increasing_seq(bus):
    url, listener = bus
    with omni4.Robot(url, keepalive_s=KEEPALIVE_S) as robot:
        t0_us = time.time() * 1e6
        robot.velocity(0.25, -0.1, 1.5)
        time.sleep(1.0)
        t_stop_us = time.time() * 1e6
        robot.stop()
        time.sleep(0.3)
    # (split by the sender's stamps: on a loaded machine this listener may handle them late)
    listener.wait_for(lambda c: c.mode == omni4.command_t.MODE_IDLE and c.utime >= t_stop_us)
    cmds = [(t, c) for t, c in listener.cmds if c.utime >= t0_us]
    vel = [(t, c) for t, c in cmds if c.mode == omni4.command_t.MODE_VELOCITY]
    # 1 s at 50 ms: 20 messages (measured 20-21). How many a loaded machine lets out in a
    # second of wall time is not asserted (the period is: the sender's own stamps below).
    assert len(vel) >= 3, f"{len(vel)} VELOCITY messages in 1 s: no keep-alive"
    assert all(list(c.velocity) == [0.25, -0.1, 1.5] for _, c in vel)
    stamped = sorted(b[1].utime - a[1].utime for a, b in zip(vel, vel[1:]))
    print(f"keep-alive gaps (stamped): median {stamped[len(stamped) // 2] / 1e3:.1f} ms, "
          f"max {stamped[-1] / 1e3:.0f} ms")
    # Each re-send waits keepalive_s after the previous one (never sooner: a send before its
    # time would be a busy loop); a loaded machine only makes some later.
    assert stamped[0] >= 0.9 * KEEPALIVE_S * 1e6, f"keep-alives {stamped[0]} us apart"
    seqs = [c.seq for _, c in cmds]
    assert seqs == list(range(seqs[0], seqs[0] + len(seqs))), "seq must increase by one"
    now_us = time.time() * 1e6
    assert all(abs(c.utime - now_us) < 5e6 for _, c in cmds), "utime: the host clock [us]"
    # After stop(): one IDLE, then nothing moving.
    after = [c for t, c in cmds if c.utime > t_stop_us]
    assert all(c.mode == omni4.command_t.MODE_IDLE for c in after)
    assert any(c.mode == omni4.command_t.MODE_IDLE for _, c in cmds)


def test_voltage_and_coast_are_kept_alive_and_close_sends_idle(bus):
    url, listener = bus
    robot = omni4.Robot(url, keepalive_s=KEEPALIVE_S)
    robot.voltage([1.0, -2.0, 3.0, -4.0], ramp_s=0.5)
    time.sleep(0.3)
    robot.coast()
    time.sleep(0.3)
    robot.close()
    listener.wait_for(lambda c: c.mode == omni4.command_t.MODE_IDLE)
    time.sleep(0.2)
    modes = [c.mode for _, c in listener.cmds]
    volt = [c for _, c in listener.cmds if c.mode == omni4.command_t.MODE_VOLTAGE]
    # 0.3 s at 50 ms: ~6 of each; at least two (kept alive, not sent once), whatever the load.
    assert len(volt) >= 2 and all(list(c.voltage) == [1, -2, 3, -4] and c.ramp_s == 0.5
                                  for c in volt)
    assert modes.count(omni4.command_t.MODE_COAST) >= 2
    assert modes[-1] == omni4.command_t.MODE_IDLE
    assert not robot._ka.is_alive() and not robot._rx.is_alive()
    with pytest.raises(RuntimeError, match="closed"):
        robot.velocity(0, 0, 0)
    robot.close()  # idempotent


def test_motors_iterator_times_out_without_a_controller():
    with omni4.Robot(random_url()) as robot:
        t = time.monotonic()
        with pytest.raises(TimeoutError, match="no OMNI4_MOTORS for 0.3 s"):
            for _ in robot.motors(timeout_s=0.3):
                pass
        took = time.monotonic() - t
        # Never before its time; how much later a loaded machine wakes it is not asserted.
        assert took >= 0.3, f"timeout of 0.3 s took {took:.3f} s"
        t = time.monotonic()
        # duration_s ends the iteration before timeout_s raises (5 s: far beyond any wake-up)
        assert list(robot.motors(timeout_s=5, duration_s=0.2)) == []
        assert time.monotonic() - t >= 0.2
        with pytest.raises(TimeoutError, match="a sample out of FAULT"):
            robot.clear_fault(timeout_s=0.2)
        assert robot.latest is None and math.isinf(robot.latest_age_s)


def test_bad_arguments_are_refused_before_sending(bus):
    url, listener = bus
    with omni4.Robot(url) as robot:
        with pytest.raises(ValueError, match="finite"):
            robot.velocity(float("nan"), 0, 0)
        with pytest.raises(ValueError, match="4 values"):
            robot.voltage([1, 2, 3])
        with pytest.raises(ValueError, match="keepalive_s"):
            omni4.Robot(url, keepalive_s=0)
        time.sleep(0.1)
        assert robot.sent == 0
    with pytest.raises(RuntimeError, match="cannot open LCM URL"):
        omni4.Robot("nonsense://")


def test_params_is_the_param_client_or_a_clear_attribute_error():
    with omni4.Robot(random_url()) as robot:
        try:
            importlib.import_module("omni4.params")
        except ImportError:
            with pytest.raises(AttributeError, match="needs omni4.params.ParamClient"):
                robot.params
        else:
            assert type(robot.params).__name__ == "ParamClient"


LIMITS = {"limits.vel_lin_max": 1.5, "limits.vel_rot_max": 20.0, "limits.supply_v": 12.0}


def test_commands_beyond_the_limits_raise_naming_the_limit_and_send_nothing(bus):
    url, listener = bus
    with omni4.Robot(url, limits=LIMITS) as robot:
        robot.velocity(0.5, 0, 0)                    # in range: sent, kept alive
        with pytest.raises(omni4.CommandRejected,
                           match=r"v 100 m/s beyond \[limits\] vel_lin_max 1.5 m/s"):
            robot.velocity(100, 0, 0)
        with pytest.raises(omni4.CommandRejected, match=r"vn -1.6 m/s beyond .*vel_lin_max"):
            robot.velocity(0, -1.6, 0)
        with pytest.raises(omni4.CommandRejected, match=r"w 21 rad/s beyond .*vel_rot_max 20"):
            robot.velocity(0, 0, 21)
        with pytest.raises(omni4.CommandRejected, match=r"voltage\[0\] 50 V beyond \[limits\] "
                                                        r"supply_v 12 V"):
            robot.voltage([50] * 4)
        with pytest.raises(ValueError, match=r"ramp_s -1 s outside \[0, 60\] s"):
            robot.voltage([1] * 4, ramp_s=-1)
        robot.velocity(1.5, -1.5, 20)                # the limits themselves are allowed
        robot.stop()
        assert robot.rejected == 5
    deadline = time.monotonic() + 10           # both commands received (bounded, no timing)
    while not {(0.5, 0.0, 0.0), (1.5, -1.5, 20.0)} <= {tuple(c.velocity) for _, c in
                                                     listener.cmds}:
        assert time.monotonic() < deadline, listener.cmds
        time.sleep(0.01)
    sent = [c for _, c in listener.cmds]
    assert {tuple(c.velocity) for c in sent if c.mode == omni4.command_t.MODE_VELOCITY} == \
        {(0.5, 0.0, 0.0), (1.5, -1.5, 20.0)}
    assert not any(c.mode == omni4.command_t.MODE_VOLTAGE for c in sent)


def test_udpm_urls_ask_for_a_large_receive_buffer():
    """A udpm URL gets recv_buf_size appended (after ? or &), a URL that names one or is not
    udpm is left as it is."""
    n = omni4.robot.RECEIVE_BUFFER_BYTES
    assert n >= 1 << 20
    w = omni4.robot.with_receive_buffer
    assert w("udpm://239.255.76.67:7667") == f"udpm://239.255.76.67:7667?recv_buf_size={n}"
    assert w("udpm://239.255.76.67:7667?ttl=0") == \
        f"udpm://239.255.76.67:7667?ttl=0&recv_buf_size={n}"
    assert w("udpm://239.255.76.67:7667?recv_buf_size=1000") == \
        "udpm://239.255.76.67:7667?recv_buf_size=1000"
    assert w("memq://") == "memq://"


class BlockingLimitsClient:
    """Stands in for the limits' ParamClient: its GET blocks until released (a controller that
    has not answered yet) and it records whether it was closed while a GET was in flight."""

    def __init__(self):
        self.entered = threading.Event()
        self.release = threading.Event()
        self.in_get = False
        self.closed_during_get = None

    def get_many(self, _keys):
        self.in_get = True
        self.entered.set()
        self.release.wait(10)
        self.in_get = False
        raise omni4.params.ParamError("no answer")

    def close(self):
        self.closed_during_get = self.in_get


def test_close_waits_for_the_limits_request_in_flight(monkeypatch):
    """The limits' GET pumps its client's LCM on its own thread: close() must not release the
    client under it (unsubscribing frees the handler LCM is about to call: a segfault), but wait
    for it to return, then release it."""
    fake = BlockingLimitsClient()
    monkeypatch.setattr(omni4.Robot, "_open_limits_client", lambda self, _type: fake)
    robot = omni4.Robot(random_url(), keepalive_s=KEEPALIVE_S)
    assert fake.entered.wait(10), "the limits' GET never started"
    closer = threading.Thread(target=robot.close)
    closer.start()
    time.sleep(0.2)                            # close() is waiting (or, wrongly, has released)
    fake.release.set()
    closer.join(10)
    assert not closer.is_alive()
    assert fake.closed_during_get is False
