"""A client for the running controller (omni4-fw) over LCM, for scripts and notebooks.

    with omni4.Robot() as robot:                  # DEFAULT_LCM_URL, or Robot("udpm://...")
        robot.velocity(0.2, 0.0, 0.0)             # v [m/s], vn [m/s], w [rad/s]
        for m in robot.motors(timeout_s=1.0, duration_s=2.0):
            print(m.utime, m.wheel_speed)
    # leaving the block sends IDLE (after a goal: its cancel, which brakes a moving robot to
    # rest) and ends the client's threads

Commands go out as command_t on OMNI4_CMD, seq increasing by one per message, utime from
this host's clock [us]. The controller's watchdog (`[control] cmd_timeout_ms`, default 200 ms,
docs/faults.md) ramps a robot whose command stream stops to zero and then IDLE, so a keep-alive
thread re-sends the last VELOCITY, VOLTAGE or COAST command every `keepalive_s` (default 50 ms,
a quarter of the default timeout). If this process dies, the keep-alive stops with it and the
watchdog stops the robot. Every wait has a timeout and raises TimeoutError naming what it
waited for.

Refused commands. The controller refuses (and ignores: the previous command stays in force, the
watchdog then stops the robot) a command out of its limits, not finite, or not allowed in its
mode; it says so only by the FAULT_CMD_REJECTED bit (0x0400) in the samples that follow. This
client makes a refusal an exception, CommandRejected (a ValueError, so `except ValueError`
code still catches it):

- before sending: velocity() and voltage() refuse a NaN or infinite value, and compare the
  command with the controller's `[limits]` (vel_lin_max, vel_rot_max, supply_v, read with a
  GET on the first command and followed on OMNI4_PARAM_CHANGED) and ramp_s with [0, 60] s,
  and raise naming the limit
  ("v 100 m/s beyond [limits] vel_lin_max 3 m/s"); nothing is sent, the command kept alive
  before stays so. If the controller does not answer the GET, the check is skipped (the GET
  is tried again 5 s later).
- after sending (what the client cannot predict, e.g. any command while the robot is in FAULT):
  the receive thread reads the samples that follow each VELOCITY, VOLTAGE or COAST command. By
  default the call returns at once (a 50 Hz stream never waits) and a refusal is raised by the
  next command, motors() / wait_motors() or check(); velocity(..., wait=True) (or
  Robot(wait=True)) instead waits for the verdict: the bit in a sample at least
  max(10 ms, 10 loop periods) after the send, at most confirm_timeout_s. A refused command is
  no longer kept alive. Another sender's refused command in the same window is indistinguishable.
"""
import atexit
import math
import queue
import threading
import time
import weakref

import lcm

from . import _vocab
from . import (CHANNEL_CMD, CHANNEL_MOTORS, CHANNEL_PARAM_CHANGED, DEFAULT_LCM_URL, command_t,
               motors_t, param_changed_t)
from .goal import GoalMixin

DEFAULT_KEEPALIVE_S = 0.05   # re-send period [s]; the controller's default watchdog is 200 ms
RX_POLL_MS = 50              # receive thread's wait per LCM handle call [ms]
RX_QUEUE_MESSAGES = 10000    # LCM's receive queue for OMNI4_MOTORS: 10 s at 1 kHz
JOIN_TIMEOUT_S = 2.0         # bounded join of the client's threads on close [s]
LATCHING_FAULTS = _vocab.LATCHING  # the latching FAULT_* bits (core's vocab.def)
RAMP_MAX_S = 60.0            # the controller refuses ramp_s outside [0, 60] s (core/src/ctl.c)
LIMIT_KEYS = ("limits.vel_lin_max", "limits.vel_rot_max", "limits.supply_v")
CONFIRM_MIN_S = 0.01         # a verdict comes from samples at least this long after the send
CONFIRM_TICKS = 10           # ... and at least this many loop periods after it
CONFIRM_TIMEOUT_S = 0.5      # wait=True: longest wait for the verdict [s]
LIMITS_TIMEOUT_S = 0.25      # the GET of the limits: per try [s] (2 tries)
LIMITS_CLOSE_WAIT_S = 2.0    # close: longest wait for a GET in flight to return [s]
LIMITS_RETRY_S = 5.0         # no answer: the check is skipped, and the GET tried again after


class CommandRejected(ValueError):
    """A command the controller refuses (or would refuse): str(e) is one line with the reason.
    command: the command_t (None when refused before sending); reason: the text."""

    def __init__(self, reason, command=None):
        super().__init__(reason)
        self.reason = reason
        self.command = command


# A udpm URL without a receive buffer of its own asks for this many bytes (the kernel caps it at
# net.core.rmem_max), as omni4-record does: the default ~200 kB holds about 0.2 s of the robot's
# 1 kHz samples, so a client that is not scheduled for a moment would lose some.
RECEIVE_BUFFER_BYTES = 4194304


def with_receive_buffer(url):
    """url with recv_buf_size=RECEIVE_BUFFER_BYTES appended when it is udpm:// and names none."""
    if not url.startswith("udpm://") or "recv_buf_size=" in url:
        return url
    return f"{url}{'&' if '?' in url else '?'}recv_buf_size={RECEIVE_BUFFER_BYTES}"


def _describe(msg):
    if msg.mode == command_t.MODE_VELOCITY:
        return "velocity({:g}, {:g}, {:g})".format(*msg.velocity)
    if msg.mode == command_t.MODE_VOLTAGE:
        return "voltage([{}], ramp_s={:g})".format(", ".join(f"{u:g}" for u in msg.voltage),
                                                   msg.ramp_s)
    if msg.mode == command_t.MODE_COAST:
        return "coast()"
    return f"mode {msg.mode}"


def _values(name, values, n):
    """The n values as floats; ValueError if there are not n (a call that is no command)."""
    vals = [float(x) for x in values]
    if len(vals) != n:
        raise ValueError(f"{name}: {n} values expected, got {len(vals)}")
    return vals


# Why a controller keeps FAULT after a clear: the cause of each latching bit (docs/faults.md).
CLEAR_HINTS = (
    (motors_t.FAULT_OVERCURRENT, "a current above [limits] current_max_a"),
    (motors_t.FAULT_CURRENT_SENSOR, "a current sensor at its rail, or a current-sense offset "
     "beyond 0.25 A; a clear is taken once a measured set within the limit is in force"),
    (motors_t.FAULT_DRIVER_TIMEOUT, "a motor driver is silent"),
    (motors_t.FAULT_DRIVER, "a motor driver reports a fault"),
    (motors_t.FAULT_BUS, "the bus to the drivers is down, or another controller publishes "
     "OMNI4_MOTORS on this URL; a clear is taken 1 s after it falls silent"),
    (motors_t.FAULT_ENCODER, "an encoder reading is implausible"),
    (motors_t.FAULT_SUPPLY, "the supply is below [limits] supply_min_v"),
)


def clear_refusal_reason(m):
    """One line: why the controller keeps sample m's FAULT / ESTOP after a CLEAR_FAULT (it takes
    the clear only when the e-stop line is released and no latching fault's cause is present)."""
    mode = _vocab.mode_name(m.mode)
    why = []
    if m.faults & motors_t.FAULT_ESTOP:
        why.append("the e-stop line is still asserted (ESTOP): release it, then clear")
    latched = [f"{_vocab.fault_names(bit)[0]} ({hint})" for bit, hint in CLEAR_HINTS if m.faults & bit]
    if latched:
        why.append("the cause of a latching fault is still present: " + "; ".join(latched))
    if not why:
        why.append(f"faults 0x{m.faults:04x}: the cause is still present")
    return f"still {mode}: " + "; ".join(why)


class Robot(GoalMixin):
    """One robot on one LCM URL. Thread-safe; close() (or the with block) ends it.

    url: LCM URL of the robot's bus (DEFAULT_LCM_URL: udpm on this host, ttl=0).
    keepalive_s: re-send period of the last moving command [s]; keep it well below the
        controller's `[control] cmd_timeout_ms` (a quarter or less).
    queue_len: motors_t samples buffered per motors() iterator; a consumer slower than the
        loop rate loses the oldest (counted in `dropped`).
    secret: passed to the parameter client (`params`).
    wait: default of velocity() / voltage() / coast() `wait`: False (return at once, a refusal
        raises at the next call) or True (wait for the controller's verdict).
    limits: None (read the controller's [limits] on the first command), a dict of LIMIT_KEYS
        to values, or False (no check before sending; refusals still come back after).
    confirm_timeout_s: longest wait for a verdict with wait=True [s]; TimeoutError after."""

    def __init__(self, url=DEFAULT_LCM_URL, keepalive_s=DEFAULT_KEEPALIVE_S, queue_len=10000,
                 secret=None, wait=False, limits=None, confirm_timeout_s=CONFIRM_TIMEOUT_S):
        if not 0 < keepalive_s <= 1.0:
            raise ValueError(f"keepalive_s {keepalive_s}: must be in (0, 1] s")
        self.url = url
        self.keepalive_s = float(keepalive_s)
        self._queue_len = int(queue_len)
        self._secret = secret
        try:
            self._lc = lcm.LCM(with_receive_buffer(url))
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
        self.wait = bool(wait)
        self.confirm_timeout_s = float(confirm_timeout_s)
        self._limits = None if limits is None else (False if limits is False else dict(limits))
        self._limits_client = None
        self._limits_retry_s = 0.0             # monotonic [s]: next GET of the limits
        self._limits_lock = threading.Lock()
        self._pending = None                   # the command awaiting the controller's verdict
        self._rejected = None                  # a CommandRejected not raised yet
        self._verdict = threading.Condition(self._lock)
        self._period_s = 0.001                 # loop period, from the samples' utime
        self.rejected = 0                      # commands refused (before or after sending)
        self._sub = self._lc.subscribe(CHANNEL_MOTORS, self._on_motors)
        self._sub_changed = self._lc.subscribe(CHANNEL_PARAM_CHANGED, self._on_param_changed)
        # LCM keeps 30 undelivered messages per subscription by default (30 ms at 1 kHz): a
        # receive thread that waits longer for the GIL would lose samples.
        self._sub.set_queue_capacity(RX_QUEUE_MESSAGES)
        self._rx = threading.Thread(target=self._rx_loop, name="omni4-robot-rx", daemon=True)
        self._ka = threading.Thread(target=self._keepalive_loop, name="omni4-robot-keepalive",
                                    daemon=True)
        self._rx.start()
        self._ka.start()
        self._goal_setup()                     # go_to / follow (goal.py)
        if self._limits is None:               # the first command need not wait a round trip
            threading.Thread(target=self._known_limits, name="omni4-robot-limits",
                             daemon=True).start()
        ref = weakref.ref(self)
        self._atexit = lambda: ref() is not None and ref().close()
        atexit.register(self._atexit)

    # ---- commands ------------------------------------------------------------------------
    def velocity(self, v_m_s, vn_m_s, w_rad_s, wait=None):
        """VELOCITY mode: robot velocity v, vn [m/s] and w [rad/s] (robot frame, eq 2 signs,
        docs/kinematics.md), kept alive until the next command or stop(). Beyond [limits]
        vel_lin_max / vel_rot_max: CommandRejected, nothing sent. wait: see the module doc
        (None: the Robot's default)."""
        self._raise_rejected()
        msg = command_t()
        msg.mode = command_t.MODE_VELOCITY
        msg.velocity = _values("velocity", (v_m_s, vn_m_s, w_rad_s), 3)
        self._refuse_nonfinite(msg, "velocity", msg.velocity)
        lim = self._known_limits()
        if lim:
            for name, x, key, unit in (("v", msg.velocity[0], "vel_lin_max", "m/s"),
                                       ("vn", msg.velocity[1], "vel_lin_max", "m/s"),
                                       ("w", msg.velocity[2], "vel_rot_max", "rad/s")):
                top = lim.get(f"limits.{key}")
                if top is not None and abs(x) > top:
                    self._refuse(f"{_describe(msg)}: {name} {x:g} {unit} beyond [limits] {key} "
                                 f"{top:g} {unit}")
        self._command(msg, keep_alive=True, wait=wait)

    def voltage(self, volts, ramp_s=0.0, wait=None):
        """VOLTAGE mode: 4 channel voltages [V] (index j = motor j), reached by a linear ramp
        of ramp_s [s] from the present output (0 = step); kept alive. |voltage| beyond [limits]
        supply_v or ramp_s outside [0, 60] s: CommandRejected, nothing sent."""
        self._raise_rejected()
        msg = command_t()
        msg.mode = command_t.MODE_VOLTAGE
        msg.voltage = _values("voltage", volts, 4)
        msg.ramp_s = _values("ramp_s", (ramp_s,), 1)[0]
        self._refuse_nonfinite(msg, "voltage", msg.voltage + [msg.ramp_s])
        if not 0.0 <= msg.ramp_s <= RAMP_MAX_S:
            self._refuse(f"{_describe(msg)}: ramp_s {msg.ramp_s:g} s outside [0, {RAMP_MAX_S:g}] s")
        top = (self._known_limits() or {}).get("limits.supply_v")
        if top is not None:
            for j, u in enumerate(msg.voltage):
                if abs(u) > top:
                    self._refuse(f"{_describe(msg)}: voltage[{j}] {u:g} V beyond [limits] "
                                 f"supply_v {top:g} V")
        self._command(msg, keep_alive=True, wait=wait)

    def coast(self, wait=None):
        """COAST mode: H-bridges disabled (null traction); kept alive."""
        self._raise_rejected()
        msg = command_t()
        msg.mode = command_t.MODE_COAST
        self._command(msg, keep_alive=True, wait=wait)

    def check(self):
        """Raises the CommandRejected of a command refused since the last call that raised
        (once); returns None otherwise."""
        self._raise_rejected()

    @property
    def limits(self):
        """The controller's limits this client checks commands against ({key: value}; empty
        when unknown or disabled)."""
        return dict(self._known_limits() or {})

    def _refuse_nonfinite(self, msg, name, vals):
        """CommandRejected, nothing sent, if a value is NaN or infinite (the controller
        refuses such a command whole)."""
        if not all(math.isfinite(x) for x in vals):
            self._refuse(f"{_describe(msg)}: {name} values must be finite")

    def _refuse(self, reason, msg=None):
        with self._lock:
            self.rejected += 1
        raise CommandRejected(reason, msg)

    def _raise_rejected(self):
        with self._lock:
            e, self._rejected = self._rejected, None
        if e is not None:
            raise e

    def _known_limits(self):
        """The [limits] in force, read once from the controller (None: unknown / disabled)."""
        with self._limits_lock:              # one GET at a time; the others wait for it
            return self._fetch_limits_locked()

    def _fetch_limits_locked(self):
        if self._closed.is_set():           # closing: its client is being released
            return self._limits or None
        if self._limits is None and time.monotonic() >= self._limits_retry_s:
            try:
                from .params import ParamClient, ParamError
                if self._limits_client is None:
                    self._limits_client = self._open_limits_client(ParamClient)
                got = {p.key: float(p.value) for p in self._limits_client.get_many(LIMIT_KEYS)}
            except (ImportError, ParamError, ValueError):
                self._limits_retry_s = time.monotonic() + LIMITS_RETRY_S
                return None                 # no answer: the controller's own check remains
            with self._lock:
                if self._limits is None:
                    self._limits = got
        return self._limits or None

    def _open_limits_client(self, client_type):
        """The GET of the limits on an LCM instance of its own (on the robot's URL), which this
        thread handles while it waits: the reply never queues behind the receive thread's 1 kHz
        of samples, which on a loaded host can take seconds. memq:// is one instance's own bus,
        so there the robot's instance is shared (its receive thread delivers the reply)."""
        if (self.url or "").startswith("memq://"):
            return client_type(self._lc, secret=self._secret, timeout_s=LIMITS_TIMEOUT_S,
                               retries=1, pump=False)
        return client_type(self.url, secret=self._secret, timeout_s=LIMITS_TIMEOUT_S, retries=1)

    def _on_param_changed(self, _channel, data):
        try:
            m = param_changed_t.decode(data)
        except Exception:  # another type on the channel
            return
        with self._lock:
            if not isinstance(self._limits, dict):
                return
            for k, v in zip(m.keys, m.values):
                if k in LIMIT_KEYS:
                    try:
                        self._limits[k] = float(v)
                    except ValueError:
                        pass

    def stop(self):
        """Sends IDLE (outputs off) and stops re-sending. The client stays usable."""
        msg = command_t()
        msg.mode = command_t.MODE_IDLE
        self._command(msg, keep_alive=False)

    def clear_fault(self, timeout_s=1.0):
        """Sends CLEAR_FAULT (the controller leaves FAULT / ESTOP for IDLE if the cause is gone;
        in another mode it resets the latched bits and warnings) and forgets the command kept
        alive. Returns the first motors_t sample (arriving from now on) in a mode other than
        FAULT / ESTOP without latching faults. A sample still in FAULT / ESTOP once the clear
        has had time to act (as for wait=True) raises CommandRejected saying why the controller
        keeps it (clear_refusal_reason: the e-stop line still asserted, a latching fault's
        cause still present); no sample within timeout_s [s]: TimeoutError."""
        msg = command_t()
        msg.mode = command_t.MODE_CLEAR_FAULT
        q = queue.Queue(self._queue_len)
        with self._lock:
            self._queues.add(q)
        try:
            self._command(msg, keep_alive=False)
            with self._lock:
                self._rejected = None            # what was refused before the clear is moot
                sent_s = self._last_send_s
            m = self._clear_verdict(q, sent_s, time.monotonic() + timeout_s)
        finally:
            with self._lock:
                self._queues.discard(q)
        if m is None:
            last = self._latest
            state = "no sample at all" if last is None else \
                f"last: mode {last.mode}, faults 0x{last.faults:04x}"
            raise TimeoutError(f"omni4.Robot: a sample out of FAULT after CLEAR_FAULT did not "
                               f"arrive within {timeout_s} s on {self.url} ({state})")
        if m.mode in _vocab.FAULTED_MODES or m.faults & LATCHING_FAULTS:
            with self._lock:
                self.rejected += 1
            raise CommandRejected(f"clear_fault() refused by the controller on {self.url}: "
                                  f"{clear_refusal_reason(m)}", msg)
        return m

    def _clear_verdict(self, q, sent_s, deadline):
        """The first sample out of FAULT, or the first still in it once the clear has settled
        (3 samples and max(10 ms, 10 loop periods) after the send), or None at the deadline."""
        n = 0
        while True:
            left = deadline - time.monotonic()
            if left <= 0:
                return None
            try:
                m = q.get(timeout=left)
            except queue.Empty:
                return None
            n += 1
            if m.mode not in _vocab.FAULTED_MODES and \
                    not m.faults & LATCHING_FAULTS:
                return m
            since = time.monotonic() - sent_s
            if n >= 3 and since >= max(CONFIRM_MIN_S, CONFIRM_TICKS * self._period_s):
                return m

    def _forget_command(self):
        """A goal replaces the command kept alive (nothing sent)."""
        with self._lock:
            self._cmd = None
            self._pending = None

    def _command(self, msg, keep_alive, wait=False):
        if self._closed.is_set():
            raise RuntimeError("omni4.Robot: closed")
        self._forget_goal()                    # a command replaces the goal
        track = msg.mode in _vocab.KEPT_ALIVE_MODES
        with self._lock:
            self._cmd = msg if keep_alive and msg.mode in _vocab.KEPT_ALIVE_MODES else None
            self._send_locked(msg)
            last = self._latest
            self._pending = None if not track else {
                "msg": msg, "t": self._last_send_s, "seq": -1 if last is None else last.seq,
                # a bit already set (or no sample yet) can only be read after the settle time
                "prior": last is None or bool(last.faults & motors_t.FAULT_CMD_REJECTED)}
        self._wake.set()
        if track and (self.wait if wait is None else wait):
            self._await_verdict(msg)

    def _await_verdict(self, msg):
        deadline = time.monotonic() + self.confirm_timeout_s
        with self._verdict:
            while self._pending is not None and self._pending["msg"] is msg:
                left = deadline - time.monotonic()
                if left <= 0:
                    self._pending = None
                    raise TimeoutError(
                        f"omni4.Robot: no verdict on {_describe(msg)} within "
                        f"{self.confirm_timeout_s} s on {self.url} (no {CHANNEL_MOTORS}?)")
                self._verdict.wait(left)
        self._raise_rejected()

    def _judge_locked(self, m, now):
        """The pending command's verdict from sample m (arrived at now), under the lock."""
        p = self._pending
        if p is None:
            return
        since = now - p["t"]
        settled = since >= max(CONFIRM_MIN_S, CONFIRM_TICKS * self._period_s) and \
            m.seq >= p["seq"] + 2
        if m.faults & motors_t.FAULT_CMD_REJECTED:
            if not (settled or not p["prior"]):
                return
            msg = p["msg"]
            if m.mode in _vocab.FAULTED_MODES:
                mode = _vocab.mode_name(m.mode)
                why = (f"the robot is in {mode} (faults 0x{m.faults:04x}); clear_fault() "
                       "(omni4-param clear-fault) first"
                       if m.mode == _vocab.MODES["FAULT"] else f"the robot is in {mode}")
            else:
                why = "out of the controller's limits, not finite, or not allowed now"
            self._rejected = CommandRejected(
                f"{_describe(msg)} refused by the controller on {self.url}: {why}", msg)
            self.rejected += 1
            if self._cmd is msg:
                self._cmd = None                 # not re-sent: the watchdog stops the robot
        elif not settled:
            return
        self._pending = None
        self._verdict.notify_all()

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
        now = time.monotonic()
        with self._lock:
            prev = self._latest
            if prev is not None and m.seq > prev.seq and m.utime > prev.utime:
                self._period_s = (m.utime - prev.utime) / (m.seq - prev.seq) * 1e-6
            self._latest = m
            self._latest_s = now
            self.received += 1
            self._judge_locked(m, now)
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
                    m = q.get(timeout=wait)
                except queue.Empty:
                    if end is not None and time.monotonic() >= end:
                        return
                    raise TimeoutError(f"omni4.Robot: no {CHANNEL_MOTORS} for {timeout_s} s on "
                                       f"{self.url} (is omni4-fw running on this URL?)") from None
                self._raise_rejected()
                yield m
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
    def close(self, stop=True):
        """Sends IDLE (stop=False: sends nothing, e.g. after a clear that must not stop another
        client's drive; nor after a goal, whose cancel stops the robot, braking it to rest if it
        moves: an IDLE would cut the brake), ends the keep-alive and receive threads (bounded
        joins). Idempotent."""
        if self._closed.is_set():
            return
        try:
            if stop and not self._goal_last:
                self.stop()
            else:
                with self._lock:
                    self._cmd = None
        finally:
            self._closed.set()
            self._goal_close()
            self._wake.set()
            for t in (self._ka, self._rx):
                if t is not threading.current_thread():
                    t.join(JOIN_TIMEOUT_S)
            for sub in (self._sub, self._sub_changed):
                try:
                    self._lc.unsubscribe(sub)
                except Exception:  # already gone: nothing to release
                    pass
            # A GET in flight (every GET holds _limits_lock) pumps the limits client's LCM on
            # its own thread: unsubscribing under it frees the handler that LCM is about to
            # call. Released once no GET runs; one still running after the wait keeps it.
            if self._limits_client is not None and \
                    self._limits_lock.acquire(timeout=LIMITS_CLOSE_WAIT_S):
                try:
                    self._limits_client.close()
                finally:
                    self._limits_lock.release()
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


__all__ = ["Robot", "CommandRejected", "DEFAULT_KEEPALIVE_S", "LATCHING_FAULTS",
           "clear_refusal_reason"]
