"""The operator's tools against omni4-fw (sim backend), each controller on its own random udpm
port (conftest.lcm_test_url, ttl=0; never the default URL):

- omni4-param clear-fault: refused while a latching fault's cause is present (a 0.3 A current
  offset: CURRENT_SENSOR), saying why, from the command and from omni4.Robot; FAULT_BUS from
  foreign OMNI4_MOTORS samples: refused naming BUS while the controller holds it, then taken
  (tried until a generous deadline); nothing to clear on a healthy controller.
- omni4-fw's parameter summary: its "bad" figure against this test's own count of the bad
  requests it sent (bad GETs among them, each answered BAD_REQUEST), resends of a lost reply
  counted once.
- omni4-teleop (on a pseudo-terminal) and omni4-status --watch on a URL where nothing runs:
  "no robot answers", then, once a controller starts there, "answers again".
- omni4-status --watch on a terminal (a pty) redraws in place; piped it writes line by line.
"""
import os
import re
import select
import signal
import subprocess
import time

import lcm
import pytest
from conftest import lcm_test_url
from livefw import EXIT_TIMEOUT_S, SCALE, START_TIMEOUT_S, Firmware, Pty, tool

import omni4
from omni4.param_reply_t import param_reply_t
from omni4.params import ParamClient, ParamRefused

pytestmark = pytest.mark.live

SAY_TIMEOUT_S = 60 * SCALE          # "appears before it", never a timing figure: a hang bound
REDRAW = b"\x1b[H\x1b[J"
FAULT, IDLE = omni4.motors_t.MODE_FAULT, omni4.motors_t.MODE_IDLE


class Lines:
    """Lines of a pipe, each read with a timeout (select), so no test waits without end."""

    def __init__(self, f):
        self.fd = f.fileno()
        self.buf = b""

    def next(self, timeout_s):
        end = time.monotonic() + timeout_s
        while b"\n" not in self.buf:
            left = end - time.monotonic()
            if left <= 0:
                raise AssertionError(f"no line within {timeout_s} s (so far {self.buf!r})")
            if select.select([self.fd], [], [], left)[0]:
                data = os.read(self.fd, 4096)
                if not data:
                    raise AssertionError(f"the pipe closed (so far {self.buf!r})")
                self.buf += data
        line, self.buf = self.buf.split(b"\n", 1)
        return line.decode() + "\n"


def clear_fault(url, timeout_s=2.0):
    return subprocess.run([*tool("omni4-param"), "--lcm", url, "--timeout", str(timeout_s),
                           "clear-fault"], capture_output=True, text=True,
                          timeout=EXIT_TIMEOUT_S + 3 * timeout_s)


# ---- omni4-param clear-fault ----------------------------------------------------------------

def test_clear_fault_refused_while_a_current_sensor_fault_is_present(omni4_bin, tmp_path):
    fw = Firmware(omni4_bin("omni4-fw"), tmp_path, lcm_test_url(), "[sim]\ncurrent_offset_a2 = 0.3\n")
    try:
        m = fw.bus.wait(lambda m: m.mode == FAULT, START_TIMEOUT_S)
        assert m is not None and m.faults & omni4.motors_t.FAULT_CURRENT_SENSOR, fw.bus.last
        r = clear_fault(fw.url)
        print(r.stdout, r.stderr)
        assert r.returncode == 1 and r.stdout == ""
        assert r.stderr.count("\n") == 1, r.stderr
        assert r.stderr.startswith("omni4-param: clear-fault refused: still FAULT: the cause of "
                                   "a latching fault is still present: CURRENT_SENSOR (")
        assert "0.25 A" in r.stderr
        assert fw.bus.wait(lambda m: True, 1.0).mode == FAULT
        # the same from Python: a clear refused with the reason, a command in FAULT refused
        with omni4.Robot(fw.url, limits=False) as robot:
            with pytest.raises(omni4.CommandRejected, match=r"clear_fault\(\) refused by the "
                               r"controller on .*: still FAULT: .*CURRENT_SENSOR"):
                robot.clear_fault(timeout_s=2.0)
            with pytest.raises(omni4.CommandRejected, match=r"the robot is in FAULT .*omni4-param "
                                                            r"clear-fault"):
                robot.velocity(0.1, 0, 0, wait=True)
            assert robot.rejected == 2
    finally:
        fw.stop()


def test_clear_fault_taken_once_the_cause_is_gone(omni4_bin, tmp_path):
    fw = Firmware(omni4_bin("omni4-fw"), tmp_path, lcm_test_url())
    try:
        r = clear_fault(fw.url)
        assert r.returncode == 0, r.stderr
        # OVERRUN (a tick that started a period late) is a warning a loaded machine raises at
        # any time: it may show beside IDLE; a latching fault may not.
        assert re.fullmatch(r"nothing to clear: IDLE, (no faults|OVERRUN) \(latched bits and "
                            r"warnings reset\)\n", r.stdout), r.stdout
        k = [10**9]

        def inject():
            fw.bus.foreign(k[0])
            k[0] += 1
        m = fw.bus.wait(lambda m: m.mode == FAULT and m.faults & omni4.motors_t.FAULT_BUS,
                        START_TIMEOUT_S, each=inject)
        assert m is not None, f"no FAULT_BUS from foreign samples (last {fw.bus.last})"
        # The controller holds FAULT_BUS 1 s after the last foreign sample it heard: until then
        # a clear is refused naming BUS, then taken (tried until a generous deadline).
        deadline = time.monotonic() + SAY_TIMEOUT_S
        while True:
            r = clear_fault(fw.url)
            print(r.returncode, r.stdout, r.stderr)
            if r.returncode != 1 or time.monotonic() > deadline:
                break
            assert re.match(r"omni4-param: clear-fault refused: still FAULT: the cause of a "
                            r"latching fault is still present: BUS \(.*another controller",
                            r.stderr), r.stderr
            time.sleep(0.3)
        assert r.returncode == 0 and r.stderr == "", r.stderr
        assert re.fullmatch(r"cleared: IDLE, (no faults|OVERRUN) "
                            r"\(was FAULT, [A-Z_ ]*\bBUS\b[A-Z_ ]*\)\n", r.stdout), r.stdout
        assert fw.bus.wait(lambda m: m.mode == IDLE, 1.0) is not None
    finally:
        fw.stop()


# ---- omni4-fw's "bad" figure ------------------------------------------------------------------

def undecodable_until_answered(url, tries=5, wait_s=3.0):
    """Publishes bytes that are no param_request_t until omni4-fw's BAD_REQUEST reply to them
    (request_id 0, "undecodable (N bytes)") is heard; each try a new length N.
    Returns (tries published, True if answered)."""
    lc = lcm.LCM(url)
    heard = []

    def on(_channel, data):
        r = param_reply_t.decode(data)
        if r.result == param_reply_t.RESULT_BAD_REQUEST and r.request_id == 0:
            heard.append(r.message)

    sub = lc.subscribe(omni4.CHANNEL_PARAM_REPLY, on)
    try:
        for i in range(tries):
            junk = b"not a param_request_t" + b"!" * i
            lc.publish(omni4.CHANNEL_PARAM_REQ, junk)
            deadline = time.monotonic() + wait_s
            while time.monotonic() < deadline:
                lc.handle_timeout(50)
                if any(f"({len(junk)} bytes)" in m for m in heard):
                    return i + 1, True
        return tries, False
    finally:
        lc.unsubscribe(sub)


def test_the_bad_figure_counts_every_bad_request(omni4_bin, tmp_path):
    url = lcm_test_url()
    fw = Firmware(omni4_bin("omni4-fw"), tmp_path, url)
    sent_bad = 0
    try:
        # a lost reply is asked again with the same id: answered from omni4-fw's cache and
        # counted once (UDP loses datagrams on a loaded machine; the figure counts requests)
        with ParamClient(url, timeout_s=2.0, retries=5) as p:
            assert p.get("control.kp").value > 0 and len(p.list()) > 10     # good ones
            bad = [lambda: p.get("control.nope"), lambda: p.get_many(["model.R", "x.y"]),
                   lambda: p.get("nosection"),
                   lambda: p.get_many([f"model.R{i}" for i in range(300)]),  # too many keys
                   lambda: p.set("control.nope", 1),
                   lambda: p._request(42)]                                  # unknown op
            for call in bad:
                with pytest.raises(ParamRefused) as e:
                    call()
                assert e.value.result == param_reply_t.RESULT_BAD_REQUEST, str(e.value)
                sent_bad += 1
            with pytest.raises(ParamRefused) as e:          # refused, not bad
                p.set("limits.vel_lin_max", 1000)
            assert e.value.result == param_reply_t.RESULT_REFUSED, str(e.value)
            published = p.sent
        # no id to repeat: each one that arrives is a bad request of its own
        junk_sent, answered = undecodable_until_answered(url)
        assert answered, f"no BAD_REQUEST reply to {junk_sent} undecodable requests"
    finally:
        err = fw.stop()
    print(err)
    said = re.search(r"^omni4-fw: params: requests (\d+), .*\bbad (\d+),", err, re.M)
    assert said, err
    requests, bad_figure = int(said.group(1)), int(said.group(2))
    print(f"bad requests sent {sent_bad} + undecodable {junk_sent}; published {published} + "
          f"{junk_sent}; omni4-fw's figures: requests {requests}, bad {bad_figure}")
    assert sent_bad == 6
    # each bad request counted once, the undecodable ones as many as arrived (at least one)
    assert sent_bad + 1 <= bad_figure <= sent_bad + junk_sent
    # 2 good, 6 bad, 1 refused and the undecodable: each at least once, at most as often as sent
    assert sent_bad + 3 + 1 <= requests <= published + junk_sent


# ---- no robot answers -------------------------------------------------------------------------

def test_teleop_says_no_robot_answers_and_when_it_is_back(omni4_bin, tmp_path):
    url = lcm_test_url()
    t = Pty([*tool("omni4-teleop"), "--lcm", url, "--no-joystick"])
    fw = None
    try:
        t.read_until(rb"w/s v", SAY_TIMEOUT_S)
        os.write(t.master, b"w")                      # "drives" into the void
        t.read_until(rb"no robot answers on " + re.escape(url.encode()) +
                     rb": no OMNI4_MOTORS for 1 s", SAY_TIMEOUT_S)
        assert b"answers again" not in t.out
        fw = Firmware(omni4_bin("omni4-fw"), tmp_path, url)
        t.read_until(rb"the robot on " + re.escape(url.encode()) + rb" answers again",
                     SAY_TIMEOUT_S)
        os.write(t.master, b"x")
        assert t.proc.wait(timeout=EXIT_TIMEOUT_S) == 0, t.out
    finally:
        t.close()
        if fw is not None:
            fw.stop()


def test_status_watch_says_no_robot_answers_and_when_it_is_back(omni4_bin, tmp_path):
    url = lcm_test_url()
    p = subprocess.Popen([*tool("omni4-status"), "--lcm", url, "--watch", "--listen", "5"],
                         stdout=subprocess.PIPE, stderr=subprocess.PIPE)
    fw = None
    err = Lines(p.stderr)
    try:
        line = err.next(SAY_TIMEOUT_S)
        assert line == (f"omni4-status: no robot answers on {url}: no OMNI4_MOTORS "
                                 f"for 1 s (is omni4-fw running on this URL?)\n")
        fw = Firmware(omni4_bin("omni4-fw"), tmp_path, url)
        line = err.next(SAY_TIMEOUT_S)
        assert re.fullmatch(rf"omni4-status: the robot on {re.escape(url)} answers again "
                            r"\(OMNI4_MOTORS after [0-9.]+ s of silence\)\n", line), line
        p.send_signal(signal.SIGINT)
        assert p.wait(timeout=EXIT_TIMEOUT_S) == 0
    finally:
        if p.poll() is None:
            p.kill()
        p.wait(timeout=EXIT_TIMEOUT_S)
        if fw is not None:
            fw.stop()


# ---- omni4-status --watch: in place on a terminal, line by line in a pipe -----------------------

@pytest.fixture(scope="module")
def fw_status(omni4_bin, tmp_path_factory):
    fw = Firmware(omni4_bin("omni4-fw"), tmp_path_factory.mktemp("status"), lcm_test_url())
    yield fw
    fw.stop()


def test_status_watch_redraws_in_place_on_a_terminal(fw_status):
    t = Pty([*tool("omni4-status"), "--lcm", fw_status.url, "--watch", "--listen", "0.3"])
    try:
        t.read_until(rb"(?s)(\x1b\[H\x1b\[J[^\x1b]*mode: IDLE.*){3}", SAY_TIMEOUT_S)
        os.killpg(t.proc.pid, signal.SIGINT)
        assert t.proc.wait(timeout=EXIT_TIMEOUT_S) == 0
    finally:
        t.close()
    blocks = t.out.split(REDRAW)
    print(repr(t.out[:300]))
    assert blocks[0] == b"", "something before the first redraw"
    assert all(b.count(b"mode: IDLE") == 1 for b in blocks[1:] if b.strip()), blocks


def test_status_watch_piped_is_line_by_line(fw_status):
    p = subprocess.Popen([*tool("omni4-status"), "--lcm", fw_status.url, "--watch",
                          "--listen", "0.3"], stdout=subprocess.PIPE, stderr=subprocess.PIPE)
    lines = Lines(p.stdout)
    try:
        out = ""
        while out.count("mode: IDLE") < 3:
            out += lines.next(SAY_TIMEOUT_S)
        p.send_signal(signal.SIGINT)
        assert p.wait(timeout=EXIT_TIMEOUT_S) == 0
    finally:
        if p.poll() is None:
            p.kill()
        p.wait(timeout=EXIT_TIMEOUT_S)
    assert "\x1b" not in out, repr(out)
    assert len(re.findall(r"(?m)^\d\d:\d\d:\d\d robot on ", out)) == 3, out
