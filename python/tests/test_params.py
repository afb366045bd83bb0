"""omni4.params without a controller: bounded waits, resends with the same request id (against a
stand-in robot on real LCM), the robot's reason in the exception, and omni4-param's exit codes."""
import threading
import time

import lcm
import pytest
from conftest import lcm_test_url

import omni4
from omni4 import params
from omni4.params import ParamClient, ParamRefused, ParamTimeout


url = lcm_test_url


class FakeRobot:
    """Answers OMNI4_PARAM_REQ; drops the first `drop` requests it sees."""

    def __init__(self, u, drop=0, result=0, message=""):
        self.lc = lcm.LCM(u)
        self.seen = []
        self.drop, self.result, self.message = drop, result, message
        self.lc.subscribe(omni4.CHANNEL_PARAM_REQ, self._on)
        self.stop = threading.Event()
        self.t = threading.Thread(target=self._run, daemon=True)
        self.t.start()

    def _on(self, channel, data):
        q = omni4.param_request_t.decode(data)
        self.seen.append(q)
        if len(self.seen) <= self.drop:
            return
        r = omni4.param_reply_t()
        r.request_id, r.op, r.result, r.message, r.seq, r.path = \
            q.request_id, q.op, self.result, self.message, 7, "/etc/omni4/robot.ini"
        v = omni4.param_value_t()
        v.key, v.value, v.unit, v.type, v.min, v.max = "control.kp", "30", "V/(m/s)", 0, 0, 1e4
        v.choices, v.change, v.doc = "", 0, "PI proportional gain"
        r.params, r.n = [v], 1
        self.lc.publish(omni4.CHANNEL_PARAM_REPLY, r.encode())

    def _run(self):
        while not self.stop.is_set():
            self.lc.handle_timeout(20)

    def close(self):
        self.stop.set()
        self.t.join(timeout=5)


def test_no_robot_is_a_bounded_timeout():
    with ParamClient(url(), timeout_s=0.1, retries=1) as p:
        t0 = time.monotonic()
        with pytest.raises(ParamTimeout, match="no answer from omni4-fw in 2 x 0.1 s"):
            p.get("control.kp")
        # never before 2 x 0.1 s; how much later a loaded machine wakes it is not asserted
        assert time.monotonic() - t0 >= 0.2


def test_resend_keeps_the_request_id():
    u = url()
    robot = FakeRobot(u, drop=1)
    try:
        # 1.5 s per try: the stand-in's answer to the resend always comes within it, so there
        # is no third try (0.2 s let a loaded machine see one)
        with ParamClient(u, timeout_s=1.5, retries=2) as p:
            a = p.set("control.kp", 30.0)
        assert a.seq == 7 and a.params[0].value == 30.0
        assert len(robot.seen) == 2
        assert robot.seen[0].request_id == robot.seen[1].request_id
        assert robot.seen[0].keys == ["control.kp"] and robot.seen[0].values == ["30.0"]
    finally:
        robot.close()


def test_refusal_carries_the_reason():
    u = url()
    robot = FakeRobot(u, result=omni4.param_reply_t.RESULT_REFUSED,
                      message="control.kp: out of range value: 1e+09 outside [0, 10000]")
    try:
        with ParamClient(u, timeout_s=10) as p:  # the answer ends the wait: no resend
            with pytest.raises(ParamRefused, match="set refused: control.kp: out of range") as e:
                p.set("control.kp", 1e9)
        assert e.value.result == omni4.param_reply_t.RESULT_REFUSED
        assert len(robot.seen) == 1  # an answer is final: no resend
    finally:
        robot.close()


def test_values_and_ini_text():
    assert params.format_value(0.1) == "0.1" and params.format_value(True) == "true"
    assert params.format_value(1 / 3) == repr(1 / 3) and params.format_value(7) == "7"
    p = params.Param("control.kp", "30", "V/(m/s)", 0, 0.0, 1e4, "", "live", "gain")
    s = params.Param("params.secret", "(set)", "", 3, 0.0, 0.0, "", "restart", "token")
    text = params.format_ini([p, s])
    assert "[control]\n; gain [V/(m/s)] (live)\nkp = 30\n" in text
    assert "(set)" not in text.split("secret =")[0] and "\nsecret" not in text
    # a wheel's own key: written where it differs from its scalar, left out where equal
    m = [params.Param(f"model.{k}", v, "ohm", 0, 0.0, 0.0, "", "live", "R")
         for k, v in (("R", "4.3"), ("R_0", "4.3"), ("R_1", "4.5"), ("Kv_2", "4.3"))]
    text = params.format_ini(m)
    assert "\nR = 4.3\n" in text and "\nR_1 = 4.5\n" in text and "\nKv_2 = 4.3\n" in text
    assert "R_0" not in text


def test_cli_usage_errors_exit_2(capsys, tmp_path):
    assert params.main(["set", "control.kp"]) == 2
    assert params.main(["get", "kp"]) == 2
    assert params.main(["load", str(tmp_path / "missing.ini")]) == 2
    assert params.main(["list", "extra"]) == 2
    err = capsys.readouterr().err.strip().splitlines()
    assert len(err) == 4 and all(line.startswith("omni4-param: ") for line in err)
    with pytest.raises(SystemExit) as e:
        params.main(["frobnicate"])
    assert e.value.code == 2
    with pytest.raises(SystemExit) as e:
        params.main(["--help"])
    assert e.value.code == 0


def test_cli_no_robot_exits_1(capsys):
    assert params.main(["--lcm", url(), "--timeout", "0.05", "get", "control.kp"]) == 1
    assert "no answer" in capsys.readouterr().err


def test_save_adapted_usage_and_no_omni4_adapt(capsys):
    """--adapted goes with save only (usage, 2); save --adapted with no OMNI4_ADAPT on the bus
    (a robot that answers parameters only): one line, status 1, and no SAVE sent."""
    assert params.main(["--adapted", "list"]) == 2
    assert "--adapted goes with save only" in capsys.readouterr().err
    u = url()
    robot = FakeRobot(u)
    try:
        assert params.main(["--lcm", u, "--timeout", "0.1", "save", "--adapted"]) == 1
    finally:
        robot.close()
    err = capsys.readouterr().err.strip().splitlines()
    assert len(err) == 1 and "save --adapted: no OMNI4_ADAPT on" in err[0], err
    assert not any(q.op == omni4.param_request_t.OP_SAVE for q in robot.seen)


def test_adapted_changes_set_every_wheel_and_the_mean():
    """Nothing in use differs: no change. One R_j in use differs: every R_j (each wheel its own
    key) and the scalar R as their mean (computed here); a C in use that differs is set."""
    a = omni4.adapt_t()
    a.R, a.Cv, a.Cvn, a.Cw = [4.3111, 4.3111, 4.3111, 4.3111], 1.8738, 2.2198, 0.1385
    model = {"model.R": "4.3111", **{f"model.R_{j}": "4.3111" for j in range(4)},
             "model.Cv": "1.8738", "model.Cvn": "2.2198", "model.Cw": "0.1385"}
    assert params.adapted_changes(a, model) == {}
    a.R = [5.0, 4.3111, 4.0, 4.3111]
    a.Cw = 0.2
    got = params.adapted_changes(a, model)
    assert got == {"model.R_0": "5.000000", "model.R_1": "4.311100", "model.R_2": "4.000000",
                   "model.R_3": "4.311100", "model.R": f"{(5.0 + 4.3111 * 2 + 4.0) / 4:.6f}",
                   "model.Cw": "0.200000"}
