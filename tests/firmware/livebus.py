"""What the live firmware tests share: a check list that prints as it goes, and an LCM bus on a
thread of its own that sends commands and waits (bounded, named) for what it has heard.

A test subclasses Bus, subscribes its channels in __init__ before calling start(), and keeps
what it hears under self.lock."""
import random
import threading
import time

import lcm

import omni4

results = []

# The tests' udpm ports (as python/tests/conftest.py and tests/hil/bounded_wait.sh): never the
# default 7667, where a user's robot may run, nor bench/'s 7700-7899.
TEST_PORTS = (7900, 10999)


def test_url(port=None):
    """udpm://239.255.76.67:PORT?ttl=0: the given port, else a random one of TEST_PORTS."""
    return f"udpm://239.255.76.67:{port or random.randint(*TEST_PORTS)}?ttl=0"


def check(ok, what):
    """Records and prints one check; returns ok."""
    results.append((bool(ok), what))
    print(("ok    " if ok else "FAIL  ") + what, flush=True)
    return ok


def failed():
    return sum(1 for ok, _ in results if not ok)


class Bus(threading.Thread):
    def __init__(self, url):
        super().__init__(daemon=True)
        self.lc = lcm.LCM(url)
        self.lock = threading.Lock()
        self.stop_flag = threading.Event()

    def run(self):
        while not self.stop_flag.is_set():
            self.lc.handle_timeout(20)

    def close(self):
        self.stop_flag.set()
        self.join(timeout=2)

    def send(self, mode, volts=(0.0, 0.0, 0.0, 0.0), seq=0):
        """A command_t on OMNI4_CMD (velocity 0, no ramp)."""
        c = omni4.command_t()
        c.utime, c.seq, c.mode = int(time.time() * 1e6), seq, mode
        c.velocity, c.voltage, c.ramp_s = [0.0] * 3, list(volts), 0.0
        self.lc.publish(omni4.CHANNEL_CMD, c.encode())

    def wait(self, pred, timeout_s, what, each=None):
        """pred(self) under the lock until true (returned) or timeout_s; each() between tries.
        Raises TimeoutError naming what."""
        deadline = time.monotonic() + timeout_s
        while time.monotonic() < deadline:
            if each:
                each()
            with self.lock:
                r = pred(self)
            if r:
                return r
            time.sleep(0.01)
        raise TimeoutError(f"waited {timeout_s:g} s for {what}")
