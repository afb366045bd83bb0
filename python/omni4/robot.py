"""A client for the running controller (omni4-fw) over LCM, for scripts and notebooks.

    with omni4.Robot() as robot:                  # DEFAULT_LCM_URL, or Robot("udpm://...")
        robot.velocity(0.2, 0.0, 0.0)             # v [m/s], vn [m/s], w [rad/s]
        for m in robot.motors(timeout_s=1.0, duration_s=2.0):
            print(m.utime, m.wheel_speed)
    # leaving the block sends IDLE and ends the client's threads

Commands go out as command_t on OMNI4_CMD, seq increasing by one per message, utime from
this host's clock [us]. The controller's watchdog (`[control] cmd_timeout_ms`, default 200 ms,
docs/faults.md) ramps a robot whose command stream stops to zero and then IDLE, so a keep-alive
thread re-sends the last VELOCITY, VOLTAGE or COAST command every `keepalive_s` (default 50 ms,
a quarter of the default timeout). If this process dies, the keep-alive stops with it and the
watchdog stops the robot. Every wait has a timeout and raises TimeoutError naming what it
waited for.
"""
import atexit
import math
import queue
import threading
import time
import weakref

import lcm

from . import CHANNEL_CMD, CHANNEL_MOTORS, DEFAULT_LCM_URL, command_t, motors_t

DEFAULT_KEEPALIVE_S = 0.05   # re-send period [s]; the controller's default watchdog is 200 ms
RX_POLL_MS = 50              # receive thread's wait per LCM handle call [ms]
RX_QUEUE_MESSAGES = 10000    # LCM's receive queue for OMNI4_MOTORS: 10 s at 1 kHz
JOIN_TIMEOUT_S = 2.0         # bounded join of the client's threads on close [s]
LATCHING_FAULTS = (motors_t.FAULT_OVERCURRENT | motors_t.FAULT_DRIVER_TIMEOUT |
                   motors_t.FAULT_DRIVER | motors_t.FAULT_BUS | motors_t.FAULT_ENCODER |
                   motors_t.FAULT_CURRENT_SENSOR | motors_t.FAULT_SUPPLY)
_KEPT_ALIVE = (command_t.MODE_VELOCITY, command_t.MODE_VOLTAGE, command_t.MODE_COAST)


def _finite(name, values, n):
    vals = [float(x) for x in values]
    if len(vals) != n:
        raise ValueError(f"{name}: {n} values expected, got {len(vals)}")
    if not all(math.isfinite(x) for x in vals):
        raise ValueError(f"{name}: values must be finite, got {vals}")
    return vals


class Robot:
    """One robot on one LCM URL. Thread-safe; close() (or the with block) ends it.

    url: LCM URL of the robot's bus (DEFAULT_LCM_URL: udpm on this host, ttl=0).
    keepalive_s: re-send period of the last moving command [s]; keep it well below the
        controller's `[control] cmd_timeout_ms` (a quarter or less).
    queue_len: motors_t samples buffered per motors() iterator; a consumer slower than the
        loop rate loses the oldest (counted in `dropped`).
    secret: passed to the parameter client (`params`)."""

    def __init__(self, url=DEFAULT_LCM_URL, keepalive_s=DEFAULT_KEEPALIVE_S, queue_len=10000,
                 secret=None):
        if not 0 < keepalive_s <= 1.0:
            raise ValueError(f"keepalive_s {keepalive_s}: must be in (0, 1] s")
        self.url = url
        self.keepalive_s = float(keepalive_s)
        self._queue_len = int(queue_len)
        self._secret = secret
        try:
            self._lc = lcm.LCM(url)
        except (RuntimeError, OSError) as e:
            raise RuntimeError(f"omni4.Robot: cannot open LCM URL {url}: {e}") from None
        self._lock = threading.Lock()          # seq, command, queues
        self._wake = threading.Event()         # keep-alive: a new command or close
        self._closed = threading.Event()
        self._seq = 0
        self._cmd = None                       # the command kept alive (None: nothing moving)
        self._last_send_s = 0.0                # monotonic [s]
        self._queues = set()
        self._latest = None
        self._latest_s = None
        self.received = 0                      # motors_t samples received
        self.sent = 0                          # command_t messages sent
        self.dropped = 0                       # samples an iterator's full queue lost
        self._params = None
        self._sub = self._lc.subscribe(CHANNEL_MOTORS, self._on_motors)
        # LCM keeps 30 undelivered messages per subscription by default (30 ms at 1 kHz): a
        # receive thread that waits longer for the GIL would lose samples.
        self._sub.set_queue_capacity(RX_QUEUE_MESSAGES)
        self._rx = threading.Thread(target=self._rx_loop, name="omni4-robot-rx", daemon=True)
        self._ka = threading.Thread(target=self._keepalive_loop, name="omni4-robot-keepalive",
                                    daemon=True)
        self._rx.start()
        self._ka.start()
        ref = weakref.ref(self)
        self._atexit = lambda: ref() is not None and ref().close()
        atexit.register(self._atexit)

    # ---- commands ------------------------------------------------------------------------
    def velocity(self, v_m_s, vn_m_s, w_rad_s):
        """VELOCITY mode: robot velocity v, vn [m/s] and w [rad/s] (robot frame, eq 2 signs,
        docs/kinematics.md), kept alive until the next command or stop()."""
        msg = command_t()
        msg.mode = command_t.MODE_VELOCITY
        msg.velocity = _finite("velocity", (v_m_s, vn_m_s, w_rad_s), 3)
        self._command(msg, keep_alive=True)

    def voltage(self, volts, ramp_s=0.0):
        """VOLTAGE mode: 4 channel voltages [V] (index j = motor j), reached by a linear ramp
        of ramp_s [s] from the present output (0 = step); kept alive."""
        msg = command_t()
        msg.mode = command_t.MODE_VOLTAGE
        msg.voltage = _finite("voltage", volts, 4)
        msg.ramp_s = _finite("ramp_s", (ramp_s,), 1)[0]
        self._command(msg, keep_alive=True)

    def coast(self):
        """COAST mode: H-bridges disabled (null traction); kept alive."""
        msg = command_t()
        msg.mode = command_t.MODE_COAST
        self._command(msg, keep_alive=True)

    def stop(self):
        """Sends IDLE (outputs off) and stops re-sending. The client stays usable."""
        msg = command_t()
        msg.mode = command_t.MODE_IDLE
        self._command(msg, keep_alive=False)

    def clear_fault(self, timeout_s=1.0):
        """Sends CLEAR_FAULT (the controller leaves FAULT / ESTOP for IDLE if the cause is gone)
        and forgets the command kept alive. Waits up to timeout_s [s] for a motors_t sample
        in a mode other than FAULT / ESTOP without latching faults and returns it; raises
        TimeoutError if none comes (cause still present, or no controller on the URL)."""
        msg = command_t()
        msg.mode = command_t.MODE_CLEAR_FAULT
        self._command(msg, keep_alive=False)
        return self.wait_motors(
            lambda m: m.mode not in (motors_t.MODE_FAULT, motors_t.MODE_ESTOP) and
            not m.faults & LATCHING_FAULTS, timeout_s, what="a sample out of FAULT after "
            "CLEAR_FAULT")

    def _command(self, msg, keep_alive):
        if self._closed.is_set():
            raise RuntimeError("omni4.Robot: closed")
        with self._lock:
            self._cmd = msg if keep_alive and msg.mode in _KEPT_ALIVE else None
            self._send_locked(msg)
        self._wake.set()

    def _send_locked(self, msg):
        self._seq += 1
        msg.seq = self._seq
        msg.utime = int(time.time() * 1e6)
        self._lc.publish(CHANNEL_CMD, msg.encode())
        self._last_send_s = time.monotonic()
        self.sent += 1

    def _keepalive_loop(self):
        while not self._closed.is_set():
            with self._lock:
                due = self._last_send_s + self.keepalive_s - time.monotonic()
                if self._cmd is not None and due <= 0:
                    self._send_locked(self._cmd)
                    due = self.keepalive_s
            # Woken early by a new command or close; otherwise at the next due time.
            self._wake.wait(due if self._cmd is not None and due > 0 else self.keepalive_s)
            self._wake.clear()

    # ---- state ---------------------------------------------------------------------------
    def _on_motors(self, _channel, data):
        try:
            m = motors_t.decode(data)
        except Exception:  # another type on the channel: not ours to deliver
            return
        with self._lock:
            self._latest = m
            self._latest_s = time.monotonic()
            self.received += 1
            for q in self._queues:
                while True:
                    try:
                        q.put_nowait(m)
                        break
                    except queue.Full:
                        try:
                            q.get_nowait()
                            self.dropped += 1
                        except queue.Empty:
                            pass

    def _rx_loop(self):
        while not self._closed.is_set():
            self._lc.handle_timeout(RX_POLL_MS)

    @property
    def latest(self):
        """The last motors_t received (None before the first)."""
        return self._latest

    @property
    def latest_age_s(self):
        """Seconds since the last motors_t arrived (inf before the first)."""
        t = self._latest_s
        return math.inf if t is None else time.monotonic() - t

    def motors(self, timeout_s=1.0, duration_s=None):
        """Iterates over the motors_t samples that arrive from now on (loop rate, in order).

        timeout_s: longest wait for the next sample [s]; TimeoutError if it passes (no
            controller on the URL, or it stopped).
        duration_s: end the iteration after this long [s] (None: until the caller breaks)."""
        q = queue.Queue(self._queue_len)
        with self._lock:
            self._queues.add(q)
        end = None if duration_s is None else time.monotonic() + duration_s
        try:
            while True:
                wait = timeout_s
                if end is not None:
                    left = end - time.monotonic()
                    if left <= 0:
                        return
                    wait = min(wait, left)
                try:
                    yield q.get(timeout=wait)
                except queue.Empty:
                    if end is not None and time.monotonic() >= end:
                        return
                    raise TimeoutError(f"omni4.Robot: no {CHANNEL_MOTORS} for {timeout_s} s on "
                                       f"{self.url} (is omni4-fw running on this URL?)") from None
        finally:
            with self._lock:
                self._queues.discard(q)

    def wait_motors(self, predicate, timeout_s, what="a matching sample"):
        """The first motors_t sample (arriving from now on) for which predicate(m) is true;
        TimeoutError naming `what` after timeout_s [s]."""
        try:
            for m in self.motors(timeout_s=timeout_s, duration_s=timeout_s):
                if predicate(m):
                    return m
        except TimeoutError:
            pass
        last = self._latest
        state = "no sample at all" if last is None else \
            f"last: mode {last.mode}, faults 0x{last.faults:04x}"
        raise TimeoutError(f"omni4.Robot: {what} did not arrive within {timeout_s} s on "
                           f"{self.url} ({state})")

    # ---- parameters ----------------------------------------------------------------------
    @property
    def params(self):
        """The controller's parameter client (omni4.params.ParamClient), created on first use
        on this client's LCM instance: its replies arrive through this client's receive thread
        (pump=False), so nothing else calls lc.handle() on it."""
        if self._params is None:
            try:
                from .params import ParamClient
            except ImportError as e:
                raise AttributeError(f"Robot.params needs omni4.params.ParamClient, which this "
                                     f"installation lacks ({e})") from None
            self._params = ParamClient(self._lc, secret=self._secret, pump=False)
        return self._params

    # ---- life cycle ----------------------------------------------------------------------
    def close(self):
        """Sends IDLE, ends the keep-alive and receive threads (bounded joins). Idempotent."""
        if self._closed.is_set():
            return
        try:
            self.stop()
        finally:
            self._closed.set()
            self._wake.set()
            for t in (self._ka, self._rx):
                if t is not threading.current_thread():
                    t.join(JOIN_TIMEOUT_S)
            try:
                self._lc.unsubscribe(self._sub)
            except Exception:  # already gone: nothing to release
                pass
            if self._params is not None and hasattr(self._params, "close"):
                self._params.close()
            atexit.unregister(self._atexit)

    def __enter__(self):
        return self

    def __exit__(self, *exc):
        self.close()
        return False

    def __repr__(self):
        state = "closed" if self._closed.is_set() else "open"
        return f"<omni4.Robot {self.url} {state}: sent {self.sent}, received {self.received}>"


__all__ = ["Robot", "DEFAULT_KEEPALIVE_S", "LATCHING_FAULTS"]
