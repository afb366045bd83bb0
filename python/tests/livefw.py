"""What the live tests of the operator's tools share: omni4-fw (sim backend) on a URL of the
test's own, a subscriber to its OMNI4_MOTORS, a program on a pseudo-terminal, the tools' argv.
Every wait is a failure bound (generous: a loaded machine must not reach it), never a figure."""
import os
import pty
import random
import re
import select
import signal
import subprocess
import sys
import termios
import threading
import time

import lcm
import pytest

import omni4

SCALE = max(1.0, float(os.environ.get("OMNI4_TEST_TIME_SCALE", "1")))
START_TIMEOUT_S = 10 * SCALE
EXIT_TIMEOUT_S = 60 * SCALE     # a failure bound: omni4-teleop's exit took > 10 s beside stress-ng
FOREIGN_SEQ = 10**9             # samples this test publishes as another controller's
MODULES = {"omni4-status": "omni4.status", "omni4-teleop": "omni4.teleop",
           "omni4-param": "omni4.params"}


def tool(name):
    """argv of a Python tool: its console script beside this interpreter, else `python -m`."""
    exe = os.path.join(os.path.dirname(sys.executable), name)
    return [exe] if os.access(exe, os.X_OK) else [sys.executable, "-m", MODULES[name]]


class Bus:
    """The last motors_t of a URL (a subscriber in a thread); publishes foreign samples."""

    def __init__(self, url):
        self.lc = lcm.LCM(url)
        self.last = None
        self.cond = threading.Condition()
        self.lc.subscribe(omni4.CHANNEL_MOTORS, self._on)
        self.done = threading.Event()
        self.thread = threading.Thread(target=self._run, daemon=True)
        self.thread.start()

    def _on(self, _channel, data):
        m = omni4.motors_t.decode(data)
        if m.seq >= FOREIGN_SEQ:            # our own foreign samples
            return
        with self.cond:
            self.last = m
            self.cond.notify_all()

    def _run(self):
        while not self.done.is_set():
            self.lc.handle_timeout(50)

    def wait(self, predicate, timeout_s, each=None):
        """The first sample with predicate(m) true (each() called every 10 ms), or None."""
        end = time.monotonic() + timeout_s
        while time.monotonic() < end:
            with self.cond:
                if self.last is not None and predicate(self.last):
                    return self.last
                self.cond.wait(0.01)
            if each is not None:
                each()
        return None

    def foreign(self, seq):
        """A sample of another controller (seq >= FOREIGN_SEQ, never the test controller's)."""
        m = omni4.motors_t()
        m.utime, m.seq, m.mode, m.faults = int(time.time() * 1e6), seq, 0, 0
        m.voltage, m.current, m.wheel_speed = [0.0] * 4, [0.0] * 4, [0.0] * 4
        self.lc.publish(omni4.CHANNEL_MOTORS, m.encode())

    def close(self):
        self.done.set()
        self.thread.join(timeout=2)


class Firmware:
    """omni4-fw (sim backend) on url with its INI's extra lines; stop() returns its stderr (the
    summary). --duration is a bound only (stop() ends it; 120 s ran out beside stress-ng)."""

    def __init__(self, fw_path, tmp_path, url, extra=""):
        self.url = url
        tag = random.randint(0, 1 << 30)
        ini = tmp_path / f"robot{tag}.ini"
        ini.write_text(f"[lcm]\nurl = {url}\n[hal]\nmotor = sim\n{extra}")
        self.err = open(tmp_path / f"fw{tag}.stderr", "w+")
        self.proc = subprocess.Popen([fw_path, "--config", str(ini), "--duration", "900"],
                                     stdout=subprocess.DEVNULL, stderr=self.err)
        self.bus = Bus(url)
        if self.bus.wait(lambda m: True, START_TIMEOUT_S) is None:
            self.stop()
            pytest.fail(f"omni4-fw sent no OMNI4_MOTORS within {START_TIMEOUT_S} s")

    def stop(self):
        self.bus.close()
        if self.proc.poll() is None:
            self.proc.send_signal(signal.SIGINT)
        try:
            self.proc.wait(timeout=EXIT_TIMEOUT_S)
        except subprocess.TimeoutExpired:
            self.proc.kill()
            self.proc.wait(timeout=EXIT_TIMEOUT_S)
        self.err.seek(0)
        return self.err.read()


class Pty:
    """A command with stdin, stdout and stderr on a pseudo-terminal (its settings kept in
    `before`, to compare with those after it exits)."""

    def __init__(self, argv):
        self.master, self.slave = pty.openpty()
        self.before = termios.tcgetattr(self.slave)
        self.proc = subprocess.Popen(argv, stdin=self.slave, stdout=self.slave,
                                     stderr=self.slave, close_fds=True, start_new_session=True)
        self.out = b""

    def read_until(self, pattern, timeout_s):
        end = time.monotonic() + timeout_s
        while not re.search(pattern, self.out):
            left = end - time.monotonic()
            if left <= 0:
                raise AssertionError(f"no {pattern!r} within {timeout_s} s: {self.out!r}")
            if select.select([self.master], [], [], left)[0]:
                try:
                    self.out += os.read(self.master, 4096)
                except OSError:
                    pass

    def send(self, keys):
        os.write(self.master, keys)

    def finish(self):
        """Its exit status and the terminal's settings after it (killed after EXIT_TIMEOUT_S)."""
        try:
            status = self.proc.wait(timeout=EXIT_TIMEOUT_S)
        except subprocess.TimeoutExpired:
            self.proc.kill()
            raise
        after = termios.tcgetattr(self.slave)
        self._close_fds()
        return status, after

    def close(self):
        if self.proc.poll() is None:
            self.proc.kill()
        self.proc.wait(timeout=EXIT_TIMEOUT_S)
        self._close_fds()

    def _close_fds(self):
        os.close(self.master)
        os.close(self.slave)
