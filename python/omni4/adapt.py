"""omni4.adapt: the adapted motor constants in words (adapt_t on OMNI4_ADAPT, the acceptances and
reverts on OMNI4_PARAM_CHANGED with source "adapt"; docs/design.md "Adapted motor constants"),
shared by omni4-status, the ROS diagnostics and ``omni4-param save --adapted``.

    from omni4 import adapt
    adapt.flag_names(m.flags)                       # ["ON", "FED", "ADAPTED"]
    adapt.identified_r({"R": "4.3", "R_2": "4.5"})  # [4.3, 4.3, 4.5, 4.3] [ohm]
    events = adapt.Events(); events.take(param_changed_msg)   # the last accept / revert
"""
from .adapt_t import adapt_t

WHEELS = 4
SOURCE = "adapt"                  # param_changed_t.source of an acceptance or a revert
EVENT_KEY = "adapt.event"         # its value: "accepted" | "reverted"
# (bit, name) of adapt_t.flags in bit order, from the type's own FLAG_* constants.
FLAGS = tuple(sorted((getattr(adapt_t, n), n[len("FLAG_"):]) for n in dir(adapt_t)
                     if n.startswith("FLAG_")))
# A status is a warning with these: an acceptance undone, or an estimate that was not finite.
WARN_FLAGS = adapt_t.FLAG_REVERTED | adapt_t.FLAG_RESTART


def flag_names(flags):
    """The names of the bits set in adapt_t.flags, in bit order (an unknown bit as
    UNKNOWN_0x..)."""
    names = [name for bit, name in FLAGS if flags & bit]
    known = 0
    for bit, _ in FLAGS:
        known |= bit
    rest = flags & ~known
    bit = 1
    while rest:
        if rest & bit:
            names.append(f"UNKNOWN_0x{bit:x}")
            rest &= ~bit
        bit <<= 1
    return names


def identified_r(model):
    """Each motor's identified R_j [ohm] from a [model] as {key: text} (keys "R", "R_0".. with or
    without "model."; a wheel without its own key has the scalar), or None when R is absent or
    not a number."""
    def pick(key):
        for k in (key, f"model.{key}"):
            if k in model:
                return model[k]
        return None
    try:
        scalar = float(pick("R"))
        out = [float(pick(f"R_{j}") or scalar) for j in range(WHEELS)]
    except (TypeError, ValueError):
        return None
    return out


def percent(in_use, identified):
    """(in_use / identified - 1) in % per motor; None for a motor without an identified R > 0."""
    return [100.0 * (u / i - 1.0) if i and i > 0 else None for u, i in zip(in_use, identified)]


class Events:
    """The last acceptance or revert of the online estimation, from param_changed_t messages
    with source "adapt" (other sources are ignored): .last is None or (event, seq, {j: (old,
    new) [ohm]}); .accepted and .reverted count them."""

    def __init__(self):
        self.last = None
        self.accepted = 0
        self.reverted = 0

    def take(self, m):
        """Note one param_changed_t; True when it was an acceptance or a revert."""
        if m.source != SOURCE:
            return False
        kv = dict(zip(m.keys, zip(m.old_values, m.values)))
        event = kv.get(EVENT_KEY, ("", ""))[1]
        if event not in ("accepted", "reverted"):
            return False
        changes = {}
        for j in range(WHEELS):
            pair = kv.get(f"adapt.R_{j}")
            try:
                changes[j] = (float(pair[0]), float(pair[1]))
            except (TypeError, ValueError, IndexError):
                continue
        self.last = (event, m.seq, changes)
        if event == "accepted":
            self.accepted += 1
        else:
            self.reverted += 1
        return True

    def describe(self):
        """The last event in words: "accepted at tick 1234: R_0 4.3111 -> 4.5000 ohm, ..." or
        "none seen"."""
        if self.last is None:
            return "none seen"
        event, seq, changes = self.last
        moved = ", ".join(f"R_{j} {a:.4f} -> {b:.4f}" for j, (a, b) in sorted(changes.items())
                          if a != b) or "no R moved"
        return f"{event} at tick {seq}: {moved} ohm"


def _r_vs_identified(m, identified):
    pct = percent(m.R, identified) if identified else [None] * WHEELS
    return " ".join(f"{r:.4f}" + (f" ({round(p, 1) + 0.0:+.1f} %)" if p is not None else "")
                    for r, p in zip(m.R, pct))


def summary_lines(m, identified, events):
    """omni4-status's lines for the last adapt_t m: the R in use per motor (and its change from
    the identified R in %, when known), the estimates, the supply, the Coulomb frictions in use,
    the flags by name and the last accept / revert."""
    return [
        f"adapted R in use [ohm] (vs identified): {_r_vs_identified(m, identified)}",
        "adapt estimate [ohm]: " + " ".join(f"{r:.4f}" for r in m.R_estimate),
        f"adapt supply [V]: {m.supply_v:.2f}; C in use: Cv {m.Cv:g} N, Cvn {m.Cvn:g} N, "
        f"Cw {m.Cw:g} N m",
        "adapt flags: " + (" ".join(flag_names(m.flags)) or "none"),
        f"adapt last event: {events.describe()} ({events.accepted} accepted, "
        f"{events.reverted} reverted seen)",
    ]


def diagnostic(m, identified, events, seen_flags, prefix="omni4"):
    """The "PREFIX: adapt" DiagnosticStatus as (level, name, message, [(key, value)]): STALE
    (3) without an adapt_t, WARN (1) when REVERTED or RESTART was set in any adapt_t of the
    period (seen_flags, their OR), else OK (0)."""
    name = f"{prefix}: adapt"
    if m is None:
        return (3, name, "no OMNI4_ADAPT in the last period", [])
    level = 1 if seen_flags & WARN_FLAGS else 0
    words = flag_names(m.flags | (seen_flags & WARN_FLAGS))
    pct = percent(m.R, identified) if identified else [None] * WHEELS
    values = []
    for j in range(WHEELS):
        values.append((f"R_{j} in use [ohm]", f"{m.R[j]:.6f}"))
        values.append((f"R_{j} vs identified [%]", "unknown" if pct[j] is None else
                       f"{pct[j]:+.2f}"))
        values.append((f"R_{j} estimate [ohm]", f"{m.R_estimate[j]:.6f}"))
    values += [("supply [V]", f"{m.supply_v:.3f}"), ("Cv in use [N]", f"{m.Cv:g}"),
               ("Cvn in use [N]", f"{m.Cvn:g}"), ("Cw in use [N m]", f"{m.Cw:g}"),
               ("track rms [m/s]", f"{m.track_rms:.5f}"), ("flags", " ".join(words) or "none"),
               ("last event", events.describe())]
    warn = [w for w in words if w in ("REVERTED", "RESTART")]
    msg = ("adapted" if m.flags & adapt_t.FLAG_ADAPTED else "identified") + " R in use" + \
        (f", {' '.join(warn)}" if warn else "")
    return (level, name, msg, values)
