"""omni4-goto and Robot's goal waiting against a fake controller in this process (memq://: the
fake answers each goal_t on the Robot's own LCM instance with the goal_status_t a test scripts).
What they must do: refuse bad numbers with one line and status 2, take negative numbers as
poses, read a one-row CSV, judge progress by the status's content (not by messages arriving),
cancel the goal (never IDLE) on Ctrl-C and on no progress, and say when another client's goal
replaced theirs. Every wait is bounded; no duration is asserted."""
import os
import signal
import threading

import pytest

import omni4
from omni4 import goal
from omni4.goal_status_t import goal_status_t as S
from omni4.goal_t import goal_t

BOUND_S = 30          # failure bound only: a passing test never waits it out


class FakeController:
    """Answers every goal_t GO (and its keep-alives) with script(n, goal) -> goal_status_t or
    None (n: how many GO messages so far), a CANCEL with ABORTED / CANCELLED; records every
    goal_t and command_t."""

    def __init__(self, robot, script):
        self.robot, self.script = robot, script
        self.goals, self.commands, self.n = [], [], 0
        self.seq = 1000
        lc = robot._lc
        lc.subscribe(omni4.CHANNEL_GOAL, self._on_goal)
        lc.subscribe(omni4.CHANNEL_CMD,
                     lambda c, d: self.commands.append(omni4.command_t.decode(d)))

    def status(self, goal_id, status, reason=0, distance=1.0, index=0, n=1, time_to_go=1.0):
        st = S()
        self.seq += 1
        st.seq, st.utime, st.goal_id, st.status, st.reason = self.seq, self.seq * 1000, goal_id, \
            status, reason
        st.index, st.n, st.distance_m, st.time_to_go_s = index, n, distance, time_to_go
        return st

    def _on_goal(self, _channel, data):
        g = goal_t.decode(data)
        self.goals.append(g)
        if g.action == goal_t.ACTION_CANCEL:
            st = self.status(g.goal_id, S.STATUS_ABORTED, S.REASON_CANCELLED)
        else:
            self.n += 1
            st = self.script(self.n, g)
        if st is not None:
            self.robot._lc.publish(omni4.CHANNEL_GOAL_STATUS, st.encode())

    def cancels(self):
        """The CANCELs received, once one has come (bounded wait: memq:// delivers them on the
        Robot's receive thread, which a closed Robot no longer runs: then pumped here)."""
        done = threading.Event()
        for _ in range(BOUND_S * 100):
            if any(g.action == goal_t.ACTION_CANCEL for g in self.goals):
                break
            if self.robot._closed.is_set():
                self.robot._lc.handle_timeout(10)
            else:
                done.wait(0.01)
        return [g for g in self.goals if g.action == goal_t.ACTION_CANCEL]


@pytest.fixture
def fake(monkeypatch):
    """fake(script): a Robot on memq:// with a FakeController; omni4-goto run in this process
    (goal.main) gets that Robot."""
    made = []

    def make(script):
        def robot_type(url, **kw):
            r = omni4.Robot("memq://", **kw)
            made.append(FakeController(r, script))
            return r
        monkeypatch.setattr(omni4.robot, "Robot", robot_type)
        return made
    yield make
    for f in made:
        f.robot.close(stop=False)


def goto(argv, capsys):
    """omni4-goto run in this process: (status, stderr lines)."""
    try:
        status = goal.main(["-q"] + argv)
    except SystemExit as e:
        status = e.code
    return status, capsys.readouterr().err.splitlines()


@pytest.mark.parametrize("argv, words", [
    (["0", "0", "0", "--timeout", "-1"], "--timeout: -1: must be a finite number > 0"),
    (["0", "0", "0", "--timeout", "nan"], "--timeout: nan: must be a finite number > 0"),
    (["0", "0", "0", "--timeout", "0"], "--timeout: 0: must be a finite number > 0"),
    (["0", "0", "0", "--speed", "-1"], "--speed: -1: must be a finite number >= 0 m/s"),
    (["0", "0", "0", "--speed", "inf"], "--speed: inf: must be a finite number >= 0 m/s"),
    (["0", "0", "0", "--blend", "5"], "--blend: 5: must be 0 (the controller's default"),
    (["0", "0", "0", "--blend", "0.005"], "--blend: 0.005: must be 0"),
    (["0", "0", "0", "--no-progress", "-2"], "--no-progress: -2: must be a finite number > 0"),
    (["nan", "0", "0"], "pose 1 [nan, 0.0, 0.0]: values must be finite"),
    (["0", "0", "-inf"], "values must be finite"),
    (["0", "0"], "X Y THETA expected"),
])
def test_bad_numbers_are_one_line_and_status_2(argv, words, capsys, fake):
    made = fake(lambda n, g: None)
    status, err = goto(argv, capsys)
    assert status == 2 and len(err) == 1 and words in err[0], err
    assert err[0].startswith("omni4-goto: ") and not made      # nothing sent: no Robot made


@pytest.mark.parametrize("argv, pose", [
    (["0", "0", "-1e-3"], [0.0, 0.0, -1e-3]),
    (["--", "0", "0", "-1"], [0.0, 0.0, -1.0]),
    (["-1.5", "-.25", "-2E+0"], [-1.5, -0.25, -2.0]),
])
def test_negative_numbers_are_poses(argv, pose, capsys, fake):
    made = fake(lambda n, g: FakeController.status(made[0], g.goal_id, S.STATUS_REACHED,
                                                   distance=0.0))
    status, err = goto(argv, capsys)
    assert status == 0, err
    assert [list(p) for p in made[0].goals[0].poses] == [pose]


@pytest.mark.parametrize("text, rows", [
    ("60.5;0;0\n", [[60.5, 0.0, 0.0]]),
    ("60.5,0,0\n", [[60.5, 0.0, 0.0]]),
    ("x;y;theta\n1;2;3\n", [[1.0, 2.0, 3.0]]),
    ("# corners\nx, y, theta\n1, 2, 3\n\n4\t5\t-6e-1\n", [[1.0, 2.0, 3.0], [4.0, 5.0, -0.6]]),
])
def test_path_rows_and_header(tmp_path, text, rows):
    p = tmp_path / "p.csv"
    p.write_text(text)
    assert goal.read_path(str(p)) == rows


@pytest.mark.parametrize("text, line", [
    ("1,2,3\nx,y,theta\n", 2),            # a header after the first row
    ("1,abc,3\n", 1),                     # neither numbers nor a header
    ("x,y,theta\n1,2,3\n4,5,six\n", 3),
])
def test_path_row_neither_numbers_nor_header_names_file_and_line(tmp_path, text, line, capsys):
    p = tmp_path / "p.csv"
    p.write_text(text)
    with pytest.raises(ValueError, match=f"^{p}:{line}: x, y, theta expected"):
        goal.read_path(str(p))
    status, err = goto(["--path", str(p)], capsys)
    assert status == 2 and len(err) == 1 and f"{p}:{line}:" in err[0], err


def test_no_progress_is_judged_by_the_status_not_by_messages(capsys, fake):
    """A goal answered every keep-alive with the same ACTIVE status (the robot held against an
    obstacle) makes no progress: cancelled (ACTION_CANCEL with its id), one line, status 1."""
    made = fake(lambda n, g: FakeController.status(made[0], g.goal_id, S.STATUS_ACTIVE,
                                                   distance=0.8, time_to_go=0.0))
    status, err = goto(["1", "0", "0", "--no-progress", "0.5"], capsys)
    f = made[0]
    assert status == 1 and len(err) == 1, err
    assert "made no progress for 0.5 s" in err[0] and "cancelled" in err[0], err
    assert f.n >= 3, "fewer than three statuses: no stream was judged"
    assert [c.goal_id for c in f.cancels()] == [f.goals[0].goal_id]
    assert not f.commands, "a command_t (IDLE) was sent"


def test_a_goal_that_progresses_is_waited_for(fake):
    """Distance falling at every status: the no-progress bound is never met; REACHED ends it."""
    def script(n, g):
        if n < 30:
            return FakeController.status(made[0], g.goal_id, S.STATUS_ACTIVE,
                                         distance=1.0 - 0.01 * n, time_to_go=1.0)
        return FakeController.status(made[0], g.goal_id, S.STATUS_REACHED, distance=0.0)
    made = fake(script)
    r = omni4.robot.Robot("memq://", limits=False)
    st = r.go_to(1, 0, 0, no_progress_s=0.2, timeout_s=BOUND_S)
    assert st.status == S.STATUS_REACHED and made[0].n >= 30


def _interrupt_after(f, n):
    """SIGINT to this process once the fake has answered n goal_t messages (bounded)."""
    def run():
        done = threading.Event()
        for _ in range(BOUND_S * 100):
            if f.n >= n:
                break
            done.wait(0.01)
        os.kill(os.getpid(), signal.SIGINT)
    threading.Thread(target=run, daemon=True).start()


@pytest.fixture
def sigint_raises():
    """SIGINT raises KeyboardInterrupt in this process for the test (what Python sets up in a
    program; another test's library may have put its own handler in place)."""
    old = signal.signal(signal.SIGINT, signal.default_int_handler)
    yield
    signal.signal(signal.SIGINT, old)


def test_ctrl_c_cancels_the_goal_never_idle(capsys, fake):
    def script(n, g):
        if n == 1:
            _interrupt_after(made[0], 3)
        return FakeController.status(made[0], g.goal_id, S.STATUS_ACTIVE, distance=10.0 - n)
    made = fake(script)
    status, err = goto(["5", "0", "0", "--timeout", str(BOUND_S)], capsys)
    f = made[0]
    assert status == 130, err
    assert err == ["omni4-goto: cancelled: the robot brakes to rest"], err
    assert [c.goal_id for c in f.cancels()] == [f.goals[0].goal_id]
    assert not f.commands, "a command_t (IDLE) was sent"


def test_go_to_interrupted_cancels_its_goal_before_raising(fake, sigint_raises):
    def script(n, g):
        if n == 1:
            _interrupt_after(made[0], 2)
        return FakeController.status(made[0], g.goal_id, S.STATUS_ACTIVE, distance=10.0 - n)
    made = fake(script)
    r = omni4.robot.Robot("memq://", limits=False)
    with pytest.raises(KeyboardInterrupt):
        r.go_to(5, 0, 0, timeout_s=BOUND_S)
    f = made[0]
    assert [c.goal_id for c in f.cancels()] == [f.goals[0].goal_id]
    assert r._goal_msg is None                  # no longer kept alive
    r.close()      # leaving the client: the cancel stops the robot (braking); an IDLE would
    assert not f.commands, "a command_t (IDLE) was sent"   # cut the brake and let it coast


def test_aborted_replaced_is_one_line_status_1(capsys, fake):
    """The controller's word: our goal ABORTED, REASON_REPLACED (another goal took over)."""
    def script(n, g):
        status = S.STATUS_ACTIVE if n < 3 else S.STATUS_ABORTED
        return FakeController.status(made[0], g.goal_id, status,
                                     S.REASON_REPLACED if n >= 3 else 0, distance=5.0 - n)
    made = fake(script)
    status, err = goto(["5", "0", "0"], capsys)
    assert status == 1 and len(err) == 1, err
    assert "ABORTED: replaced: another goal or a command took over" in err[0], err


def test_another_goal_in_force_after_ours_started_replaced_it(capsys, fake):
    """Statuses about another goal id in force once ours was ACTIVE: replaced, status 1, and
    ours no longer kept alive (a keep-alive would start it again)."""
    def script(n, g):
        if n < 3:
            return FakeController.status(made[0], g.goal_id, S.STATUS_ACTIVE, distance=5.0 - n)
        return FakeController.status(made[0], 77, S.STATUS_ACTIVE, distance=2.0 - 0.01 * n)
    made = fake(script)
    status, err = goto(["5", "0", "0", "--no-progress", str(BOUND_S)], capsys)
    assert status == 1 and len(err) == 1, err
    assert "replaced: goal 77 (another client's) is in force now" in err[0], err


def test_another_goal_in_force_while_ours_waits_for_its_plan_is_no_replacement(fake):
    """Before ours is handed over, the goal in force goes on (its statuses carry its id)."""
    def script(n, g):
        if n < 4:
            return FakeController.status(made[0], 77, S.STATUS_ACTIVE, distance=2.0 - 0.01 * n)
        if n < 6:
            return FakeController.status(made[0], g.goal_id, S.STATUS_ACTIVE, distance=5.0 - n)
        return FakeController.status(made[0], g.goal_id, S.STATUS_REACHED, distance=0.0)
    made = fake(script)
    r = omni4.robot.Robot("memq://", limits=False)
    st = r.go_to(5, 0, 0, timeout_s=BOUND_S)
    assert st.status == S.STATUS_REACHED


def test_every_reason_the_controller_sends_has_its_words():
    """goal_status_t's REASON_* (the .lcm file) each have a line in REASONS, and an ACTIVE goal
    settling at its pose says so."""
    from omni4.goal import REASONS, describe
    reasons = {v for k, v in vars(S).items() if k.startswith("REASON_")}
    assert reasons and reasons <= set(REASONS), reasons - set(REASONS)
    st = S()
    st.goal_id, st.status, st.reason, st.distance_m, st.angle_rad = 7, S.STATUS_ACTIVE, \
        S.REASON_SETTLING, 0.002, 0.001
    assert "holding it until the estimate is sure" in describe(st)
