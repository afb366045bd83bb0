"""omni4.params: the robot's parameters over LCM, and the ``omni4-param`` command.

omni4-fw answers param_request_t on OMNI4_PARAM_REQ with one param_reply_t on OMNI4_PARAM_REPLY
(docs/design.md, "Parameters over LCM"). Keys are the INI's ``section.key`` names; values travel
as the text the INI holds. A set of several keys (or a load) is applied by the loop between two
ticks, whole or not at all; the robot's reason comes back in the exception.

    from omni4.params import ParamClient
    p = ParamClient()                  # omni4.DEFAULT_LCM_URL, or ParamClient("udpm://...")
    p.get("control.kp").value          # 20.0
    p.set("control.kp", 30)            # Applied(seq=..., ...)
    p.set({"model.R": 4.5, "model.Kv": 0.026})   # one atomic change
    p.load("PARAMS.ini")               # the [model] of omni4-ident identify, merged
    p.save()                           # the robot's INI, atomically; in force after a restart

Every wait is bounded: a request is sent, and sent again with the same request id if no reply
came within ``timeout_s`` (the robot answers a repeated id from its cache, so a change is never
applied twice), ``retries`` times; then ParamTimeout.
"""
import dataclasses
import os
import random
import sys
import threading
import time

import lcm

from . import CHANNEL_PARAM_REPLY, CHANNEL_PARAM_REQ  # defined before this module is imported
from ._cli import usage
from .param_reply_t import param_reply_t
from .param_request_t import param_request_t
from .param_value_t import param_value_t


RESULT_NAMES = {
    param_reply_t.RESULT_OK: "ok",
    param_reply_t.RESULT_REFUSED: "refused",
    param_reply_t.RESULT_BAD_REQUEST: "bad request",
    param_reply_t.RESULT_DENIED: "denied",
    param_reply_t.RESULT_BUSY: "busy",
    param_reply_t.RESULT_FAILED: "failed",
}
CHANGE_NAMES = {
    param_value_t.CHANGE_LIVE: "live",
    param_value_t.CHANGE_IDLE: "idle",
    param_value_t.CHANGE_RESTART: "restart",
}
OP_NAMES = {
    param_request_t.OP_LIST: "list", param_request_t.OP_GET: "get", param_request_t.OP_SET: "set",
    param_request_t.OP_SAVE: "save", param_request_t.OP_LOAD: "load",
}


class ParamError(Exception):
    """A parameter request that did not succeed. ``result`` is the robot's RESULT_* code (None
    when there was no answer); str(e) is one line with the robot's reason."""

    def __init__(self, message, result=None, op=None):
        super().__init__(message)
        self.result = result
        self.op = op


class ParamRefused(ParamError):
    """The robot answered and did not do it (out of range, invalid model, not while driving,
    restart only, wrong secret, malformed request, save failed). Nothing changed."""


class ParamTimeout(ParamError):
    """No answer within the bounded wait (omni4-fw not running, another LCM URL, lost packets)."""


@dataclasses.dataclass(frozen=True)
class Param:
    """One parameter as the robot holds it."""
    key: str        # "section.key"
    text: str       # the value as the INI holds it
    unit: str       # SI unit, "" for none
    type: int       # param_value_t.TYPE_*
    min: float      # inclusive range of numbers
    max: float
    choices: str    # "a|b|c" for strings with a fixed set, else ""
    change: str     # "live" | "idle" | "restart"
    doc: str

    @property
    def section(self):
        return self.key.split(".", 1)[0]

    @property
    def name(self):
        return self.key.split(".", 1)[1]

    @property
    def value(self):
        """The value as a Python float / int / bool / str."""
        if self.type == param_value_t.TYPE_DOUBLE:
            return float(self.text)
        if self.type == param_value_t.TYPE_INT:
            return int(self.text)
        if self.type == param_value_t.TYPE_BOOL:
            return self.text == "true"
        return self.text

    @classmethod
    def _from_msg(cls, m):
        return cls(m.key, m.value, m.unit, m.type, m.min, m.max, m.choices,
                   CHANGE_NAMES.get(m.change, str(m.change)), m.doc)


@dataclasses.dataclass(frozen=True)
class Applied:
    """The answer to a set or load: the keys that changed (with their new values) and the loop
    tick (motors_t.seq) from which they are in force (-1: nothing changed)."""
    seq: int
    params: tuple
    message: str
    request_id: int


def format_value(value):
    """A Python value as the INI text the robot parses (floats round-trip exactly)."""
    if isinstance(value, bool):
        return "true" if value else "false"
    if isinstance(value, float):
        return repr(value)
    return str(value)


class ParamClient:
    """Client of omni4-fw's parameter service.

    lcm_url_or_lcm_instance: an LCM URL (the robot's [lcm] url) or an lcm.LCM; None = the
    default URL. secret: the robot's [params] secret, needed by set / load / save when the robot
    has one. timeout_s: wait for one reply [s]; retries: resends with the same request id (`sent`
    counts every request published, resends included).
    pump: handle the LCM instance while waiting (True); pass False when another thread already
    runs lc.handle() on an instance you pass in (replies then arrive through that thread).
    """

    def __init__(self, lcm_url_or_lcm_instance=None, secret=None, timeout_s=1.0, retries=2,
                 pump=True):
        if not (timeout_s > 0):
            raise ValueError("timeout_s must be > 0")
        if isinstance(lcm_url_or_lcm_instance, lcm.LCM):
            self._lc, self._own = lcm_url_or_lcm_instance, False
        else:
            from . import DEFAULT_LCM_URL
            url = lcm_url_or_lcm_instance or DEFAULT_LCM_URL
            try:
                self._lc = lcm.LCM(url)
            except Exception as e:  # lcm raises a bare RuntimeError
                raise ParamError(f"cannot open LCM at '{url}': {e}") from None
            self._own = True
        self.secret = secret or ""
        self.timeout_s = float(timeout_s)
        self.retries = int(retries)
        self.pump = pump
        self.sent = 0  # requests published, resends included
        self._replies = {}
        self._cond = threading.Condition()
        self._lock = threading.Lock()
        self._sub = self._lc.subscribe(CHANNEL_PARAM_REPLY, self._on_reply)

    def close(self):
        if self._sub is not None:
            self._lc.unsubscribe(self._sub)
            self._sub = None

    def __enter__(self):
        return self

    def __exit__(self, *exc):
        self.close()

    # ---- requests ----------------------------------------------------------------------------

    def _on_reply(self, channel, data):
        try:
            r = param_reply_t.decode(data)
        except ValueError:
            return
        with self._cond:
            if r.request_id in self._replies:
                self._replies[r.request_id] = r
                self._cond.notify_all()

    def _wait(self, request_id, deadline):
        while True:
            with self._cond:
                r = self._replies.get(request_id)
                if r is not None:
                    return r
                left = deadline - time.monotonic()
                if left <= 0:
                    return None
                if not self.pump:
                    self._cond.wait(min(left, 0.05))
                    continue
            self._lc.handle_timeout(max(1, min(50, int(left * 1000))))

    def _request(self, op, keys=(), values=None, name="", text=""):
        q = param_request_t()
        q.request_id = random.getrandbits(62) + 1
        q.op = op
        q.secret = self.secret
        q.keys = [str(k) for k in keys]
        q.values = [str(v) for v in values] if values is not None else [""] * len(q.keys)
        q.n = len(q.keys)
        q.name = name
        q.text = text
        with self._lock:
            with self._cond:
                self._replies[q.request_id] = None
            try:
                for attempt in range(self.retries + 1):
                    q.utime = int(time.time() * 1e6)
                    self._lc.publish(CHANNEL_PARAM_REQ, q.encode())
                    self.sent += 1
                    r = self._wait(q.request_id, time.monotonic() + self.timeout_s)
                    if r is not None and r.result == param_reply_t.RESULT_BUSY:
                        with self._cond:
                            self._replies[q.request_id] = None
                        time.sleep(0.05 * (attempt + 1))
                        continue
                    if r is not None:
                        break
            finally:
                with self._cond:
                    self._replies.pop(q.request_id, None)
        opname = OP_NAMES.get(op, str(op))
        if r is None or r.result == param_reply_t.RESULT_BUSY:
            tries = self.retries + 1
            raise ParamTimeout(f"{opname}: no answer from omni4-fw in {tries} x {self.timeout_s:g} s"
                               f" (is it running on this LCM URL?)", None, op)
        if r.result != param_reply_t.RESULT_OK:
            what = RESULT_NAMES.get(r.result, str(r.result))
            raise ParamRefused(f"{opname} {what}: {r.message}", r.result, op)
        return r

    # ---- the operations ------------------------------------------------------------------------

    def list(self):
        """Every parameter, in the INI's order: a list of Param."""
        r = self._request(param_request_t.OP_LIST)
        return [Param._from_msg(m) for m in r.params]

    def get(self, key):
        """One parameter (Param; .value is typed). Unknown key: ParamRefused."""
        return self.get_many([key])[0]

    def get_many(self, keys):
        r = self._request(param_request_t.OP_GET, list(keys))
        return [Param._from_msg(m) for m in r.params]

    def set(self, key_or_mapping, value=None):
        """set("control.kp", 30) or set({"model.R": 4.5, "model.Kv": 0.026}): applied together
        between two ticks, or refused whole (ParamRefused with the robot's reason)."""
        if isinstance(key_or_mapping, dict):
            if value is not None:
                raise TypeError("set(mapping) takes no value")
            items = list(key_or_mapping.items())
        else:
            if value is None:
                raise TypeError("set(key, value): value missing")
            items = [(key_or_mapping, value)]
        if not items:
            raise ValueError("set: no keys")
        r = self._request(param_request_t.OP_SET, [k for k, _ in items],
                          [format_value(v) for _, v in items])
        return Applied(r.seq, tuple(Param._from_msg(m) for m in r.params), r.message,
                       r.request_id)

    def load(self, path):
        """Apply the keys of an INI file (e.g. the PARAMS.ini of omni4-ident identify: a partial
        [model] is merged with the running one, then the whole model is checked). Not saved:
        call save() to keep it over a restart."""
        with open(path, encoding="utf-8") as f:
            text = f.read()
        r = self._request(param_request_t.OP_LOAD, name=os.path.basename(path), text=text)
        return Applied(r.seq, tuple(Param._from_msg(m) for m in r.params), r.message,
                       r.request_id)

    def save(self):
        """Write the values in force to the robot's INI (atomically; a previous regular file is
        kept as .bak, a FIFO or device is written in place). Returns the path written (on the robot): when the INI is a symbolic link, the
        file it points to (replaced, its .bak beside it; the link is kept)."""
        return self._request(param_request_t.OP_SAVE).path

    def dump(self):
        """The values in force as INI text that omni4-fw loads (params.secret left out)."""
        return format_ini(self.list())


def format_ini(params, header=None):
    """INI text of a list of Param, in the robot's sections. A drive's own [model] key (R_2, ...)
    equal to its scalar is left out: absent, it reads back as the scalar (configuration.md)."""
    out = []
    if header:
        out.append(f"; {header}")
    section = None
    scalar = {p.name: p.text for p in params if p.section == "model"}
    for p in params:
        if p.section == "model" and "_" in p.name and scalar.get(p.name[:-2]) == p.text:
            continue
        if p.section != section:
            if section is not None:
                out.append("")
            section = p.section
            out.append(f"[{section}]")
        unit = f" [{p.unit}]" if p.unit else ""
        out.append(f"; {p.doc}{unit} ({p.change})")
        if p.key == "params.secret":
            out.append(f"; secret = ({'set' if p.text else 'none'}: not shown)")
        else:
            out.append(f"{p.name} = {p.text}")
    return "\n".join(out) + "\n"


# ---- omni4-param ---------------------------------------------------------------------------------

USAGE_EPILOG = """\
commands:
  list                          every parameter: value, unit, when it may change, range
  get KEY [KEY ...]             print KEY = VALUE
  set KEY VALUE [KEY VALUE ...] change them together between two loop ticks (or none)
  save                          write the values in force to the robot's INI (atomically)
  save --adapted                the same with the motor constants in use from the latest
                                OMNI4_ADAPT (R_0..R_3, their mean as R, Cv Cvn Cw) set first
                                where they differ from the identified
  load PARAMS.ini               apply the keys of an INI file (e.g. omni4-ident identify --out)
  dump                          the values in force as INI text (> robot.ini; a wheel's
                                own model key only where it differs from the scalar)
  clear-fault                   MODE_CLEAR_FAULT: FAULT / ESTOP -> IDLE once the cause is gone;
                                a refusal says why (e-stop still asserted, a fault's cause present)

Keys are the INI's section.key (control.kp, model.R, ...). Rules: live = in any mode, idle =
only while the bridges are not driven, restart = only in the INI. Exit status: 0 done
(clear-fault: out of FAULT / ESTOP, or nothing to clear), 1 refused by the robot or no answer,
2 usage or configuration error, 141 when stdout is closed early (omni4-param list | head:
quiet, as a tool killed by SIGPIPE). The secret can also come from $OMNI4_PARAM_SECRET (so it
does not show in the process list). clear-fault waits --timeout for a sample, then for the
verdict, and sends nothing but the clear.
example: omni4-param set control.kp 30 && omni4-param save
example: omni4-param clear-fault"""


def _build_parser():
    from ._cli import bus_tool_parser

    p = bus_tool_parser("omni4-param", "Read and change the parameters of a running omni4-fw "
                        "over LCM.", USAGE_EPILOG)
    p.add_argument("--secret", default=None, help="the robot's [params] secret")
    p.add_argument("--timeout", type=float, default=1.0, metavar="S",
                   help="wait for one answer [s] (default 1; 3 tries)")
    p.add_argument("--version", action="store_true", help="print the version and exit")
    p.add_argument("--adapted", action="store_true",
                   help="save only: the R_j and C in use (OMNI4_ADAPT) instead of the identified")
    p.add_argument("command", choices=["list", "get", "set", "save", "load", "dump",
                                       "clear-fault"], metavar="COMMAND")
    p.add_argument("args", nargs="*", metavar="ARG")
    return p


def _print_params(params, out):
    for p in params:
        rng = ""
        if p.type in (param_value_t.TYPE_DOUBLE, param_value_t.TYPE_INT) and \
                (p.min > -float("inf") or p.max < float("inf")):
            rng = f" in [{p.min:g}, {p.max:g}]"
        elif p.choices:
            rng = f" one of {p.choices}"
        unit = f" {p.unit}" if p.unit else ""
        out.write(f"{p.key} = {p.text}{unit}  ({p.change}{rng}; {p.doc})\n")


def main(argv=None):
    """omni4-param's entry point: the status (0 done, 1 refused or no answer, 2 usage); --version;
    a closed stdout (`omni4-param list | head`) ends it quietly with status 141."""
    from ._cli import run
    return run("omni4-param", _main, argv)


def _usage_error(args):
    """What is wrong with the command line, or None."""
    n = len(args.args)
    if args.command in ("list", "save", "dump", "clear-fault") and n:
        return f"{args.command} takes no arguments"
    if args.command == "get" and n < 1:
        return "get needs KEY"
    if args.command == "set" and (n < 2 or n % 2):
        return "set needs KEY VALUE [KEY VALUE ...]"
    if args.command == "load" and n != 1:
        return "load needs one PARAMS.ini"
    if not (args.timeout > 0):
        return "--timeout must be > 0"
    if args.adapted and args.command != "save":
        return "--adapted goes with save only"
    keys = args.args[0::2] if args.command == "set" else args.args
    for k in keys if args.command in ("get", "set") else ():
        if "." not in k:
            return f"'{k}' is not a section.key name (e.g. control.kp)"
    return None


def _main(argv=None):
    args = _build_parser().parse_args(argv)
    error = _usage_error(args)
    if error:
        return usage("omni4-param", error)
    if args.command == "clear-fault":
        return _clear_fault(args.lcm, args.timeout, sys.stdout)
    secret = args.secret if args.secret is not None else os.environ.get("OMNI4_PARAM_SECRET")
    text = None
    if args.command == "load":
        try:
            with open(args.args[0], encoding="utf-8") as f:
                text = f.read()
        except (OSError, UnicodeDecodeError) as e:
            return usage("omni4-param",
                         f"{args.args[0]}: cannot read: {getattr(e, 'strerror', None) or e}")
    try:
        client = ParamClient(args.lcm, secret=secret, timeout_s=args.timeout)
    except ParamError as e:
        return usage("omni4-param", str(e))
    out = sys.stdout
    try:
        if args.command == "list":
            _print_params(client.list(), out)
        elif args.command == "get":
            for p in client.get_many(args.args):
                out.write(f"{p.key} = {p.text}\n")
        elif args.command == "set":
            a = client.set(dict(zip(args.args[0::2], args.args[1::2])))
            _print_applied(a, out)
        elif args.command == "load":
            r = client._request(param_request_t.OP_LOAD, name=os.path.basename(args.args[0]),
                                text=text)
            _print_applied(Applied(r.seq, tuple(Param._from_msg(m) for m in r.params), r.message,
                                   r.request_id), out)
        elif args.command == "save":
            if args.adapted and not _set_adapted(client, args.lcm, out):
                return 1
            t0 = time.monotonic()
            r = client._request(param_request_t.OP_SAVE)
            # "saved; previous kept as X.bak" (or in place, or a new file); "saved" from an
            # older omni4-fw, which does not say
            what = r.message.partition("; ")[2]
            out.write(f"saved {r.path}{f' ({what})' if what else ''} in "
                      f"{(time.monotonic() - t0) * 1e3:.0f} ms\n")
        elif args.command == "dump":
            out.write(format_ini(client.list(), header=f"omni4 parameters in force, read from "
                                 f"{args.lcm} at {time.strftime('%Y-%m-%dT%H:%M:%S')}"))
    except ParamRefused as e:
        sys.stderr.write(f"omni4-param: {e}\n")
        return 2 if e.result == param_reply_t.RESULT_BAD_REQUEST else 1
    except ParamError as e:
        sys.stderr.write(f"omni4-param: {e}\n")
        return 1
    finally:
        client.close()
    return 0


def _clear_fault(url, timeout_s, out):
    """omni4-param clear-fault: what omni4.Robot.clear_fault() does, said in one line; sends
    nothing else (no IDLE: another client's drive outside FAULT goes on). 0 out of FAULT (or
    nothing to clear), 1 refused (why on stderr) or no controller, 2 a bad LCM URL."""
    from ._vocab import FAULTED_MODES, fault_names, mode_name
    from .robot import CommandRejected, Robot
    try:
        robot = Robot(url, limits=False)
    except (RuntimeError, ValueError) as e:
        return usage("omni4-param", str(e))
    try:
        before = robot.wait_motors(lambda m: True, timeout_s, what="an OMNI4_MOTORS sample")
        m = robot.clear_fault(timeout_s=timeout_s)
    except TimeoutError:
        sys.stderr.write(f"omni4-param: clear-fault: no OMNI4_MOTORS on {url} within "
                         f"{timeout_s:g} s (is omni4-fw running on this URL?)\n")
        return 1
    except CommandRejected as e:
        sys.stderr.write(f"omni4-param: clear-fault refused: {e.reason.split(': ', 1)[1]}\n")
        return 1
    finally:
        robot.close(stop=False)

    def state(s):
        names = " ".join(fault_names(s.faults)) or "no faults"
        return f"{mode_name(s.mode)}, {names}"
    if before.mode in FAULTED_MODES:
        out.write(f"cleared: {state(m)} (was {state(before)})\n")
    else:
        out.write(f"nothing to clear: {state(m)} (latched bits and warnings reset)\n")
    return 0


ADAPTED_REL_TOL = 1e-6   # a constant in use this close to the identified (relative) is no change


def latest_adapt(lc, timeout_s):
    """The first adapt_t heard on OMNI4_ADAPT of lc within timeout_s [s] (the controller sends
    one every 0.1 s, so the latest), or None."""
    from . import CHANNEL_ADAPT
    from .adapt_t import adapt_t
    got = []

    def on_adapt(_channel, data):
        try:
            got.append(adapt_t.decode(data))
        except ValueError:          # another type on the channel
            pass
    sub = lc.subscribe(CHANNEL_ADAPT, on_adapt)
    try:
        end = time.monotonic() + timeout_s
        while not got and time.monotonic() < end:
            lc.handle_timeout(max(1, int(min(0.05, end - time.monotonic()) * 1000)))
    finally:
        lc.unsubscribe(sub)
    return got[0] if got else None


def adapted_changes(m, model):
    """{key: text} to set for the constants in use of adapt_t m against the [model] in force
    (model: {"model.R_0": text, ...}): when an R_j in use differs from the [model]'s by more
    than ADAPTED_REL_TOL, every R_j in use (each wheel its own key, so that none follows the
    scalar) and the scalar R as their mean; each of Cv, Cvn, Cw in use that differs."""
    def differs(key, x):
        ref = float(model[key])
        return abs(x - ref) > ADAPTED_REL_TOL * abs(ref)
    out = {}
    if any(differs(f"model.R_{j}", m.R[j]) for j in range(4)):
        out = {f"model.R_{j}": f"{m.R[j]:.6f}" for j in range(4)}
        out["model.R"] = f"{sum(m.R) / 4:.6f}"
    for key, x in (("Cv", m.Cv), ("Cvn", m.Cvn), ("Cw", m.Cw)):
        if differs(f"model.{key}", x):
            out[f"model.{key}"] = f"{x:.6f}"
    return out


def _set_adapted(client, url, out):
    """save --adapted's first step: the constants in use of the latest OMNI4_ADAPT set where they
    differ from the [model] in force (one set); each printed with the value it replaces. False
    (said on stderr) when no adapt_t came."""
    wait_s = client.timeout_s * (client.retries + 1)
    m = latest_adapt(client._lc, wait_s)
    if m is None:
        sys.stderr.write(f"omni4-param: save --adapted: no OMNI4_ADAPT on {url} within "
                         f"{wait_s:g} s (an omni4-fw without the online estimation?)\n")
        return False
    keys = [f"model.{k}" for k in ("R", "R_0", "R_1", "R_2", "R_3", "Cv", "Cvn", "Cw")]
    model = {p.key: p.text for p in client.get_many(keys)}
    changes = adapted_changes(m, model)
    if not changes:
        out.write("adapted: the constants in use are the identified\n")
        return True
    a = client.set(changes)
    for key, text in changes.items():
        out.write(f"adapted: {key} = {text} (was {model[key]})\n")
    out.write(f"in force from tick {a.seq}\n")
    return True


def _print_applied(a, out):
    if a.seq < 0:
        out.write(f"{a.message}\n")
        return
    for p in a.params:
        out.write(f"{p.key} = {p.text}\n")
    out.write(f"in force from tick {a.seq}\n")


if __name__ == "__main__":
    sys.exit(main())
