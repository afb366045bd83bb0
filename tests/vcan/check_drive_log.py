"""The independent decoder of the vcan tier: every frame of a candump log of the VESC or ODrive
bus, decoded with cantools and our DBC (drivers/can/vesc.dbc, odrive.dbc), against what the
controller logged over the same stretch (OMNI4_MOTORS of the lcm-logger log).

- every frame decodes to a message of the DBC with the DLC it declares (RTR: a Get_ request);
- the controller's commands, one group per tick, match the voltages it logged for that tick
  (VESC duty: u / the drive's last input voltage, clamped to +-0.95; ODrive torque:
  Kt (u - Kv l w) / R at the tick's logged wheel speed w; disabled: the release command);
- the wheel speeds and currents it logged are those of a report it had received: one of drive
  j's STATUS_1 (VESC) / encoder estimate and Iq (ODrive) on the bus in the 3 ticks before.
Within the DBC's resolution (VESC: one scale step, the encoder's float rounding can take it
past half of one; ODrive floats: binary32 rounding).
usage: check_drive_log.py vesc|odrive DBC CANDUMP LCMLOG INI CONFIG_KEYS_BINARY"""
import bisect
import configparser
import json
import math
import struct
import subprocess
import sys

import cantools
import lcm

from omni4 import motors_t

EFF, RTR = 0x80000000, 0x40000000
DUTY_MAX = 0.95  # docs/vesc.md: the VESC needs a margin below 100 %
MAX_SKIP = 60  # logged ticks a bus tick may be ahead of the one before it
WINDOW_TICKS = 3  # ticks back on the bus a report the controller used may be
# ... and as far back after the loop was starved: a backend's read then catches up with its
# queue 4 ms' worth at a time (VESC_MAX_READ_CATCHUP, ODRIVE_MAX_READ_CATCHUP), so the reports
# it holds may be a few tens of ticks old for a few reads; such matches are counted and printed
WINDOW_LATE = 40
LATE = {"reports": 0}
# The controller logs its currents less the current-sense offsets it measured at rest
# (docs/faults.md); the simulated drives' are below 1 mA.
OFFSET_A = 1e-3


def f32(x):
    return struct.unpack("<f", struct.pack("<f", x))[0]


def settings(ini, keys_binary):
    """The key table's defaults with the INI's values over them: {(section, key): str}."""
    out = {}
    text = subprocess.run([keys_binary, "--json"], check=True, capture_output=True, text=True,
                          timeout=60).stdout
    for line in text.splitlines():
        k = json.loads(line)
        out[(k["section"], k["key"])] = k["default"]
    cp = configparser.ConfigParser(inline_comment_prefixes=(";", "#"))
    cp.optionxform = str
    cp.read(ini)
    for j in range(4):  # a wheel key absent from the INI is its scalar (design.md)
        for k in ("r", "Kv", "Kt", "R"):
            if not cp.has_option("model", f"{k}_{j}"):
                out.pop(("model", f"{k}_{j}"), None)
    for sec in cp.sections():
        for key, value in cp.items(sec):
            out[(sec, key)] = value
    for j in range(4):
        for k in ("r", "Kv", "Kt", "R"):
            out.setdefault(("model", f"{k}_{j}"), out[("model", k)])
    return out


def read_candump(path):
    """([(id with flags, data bytes or None for RTR)] in bus order, frames candump dropped).
    Only the frames before candump's first drop (a DROPCOUNT line): after it the ticks'
    groups and the reports' history are no longer whole."""
    frames = []
    for line in open(path):
        if line.startswith("DROPCOUNT"):
            return frames, int(line.split()[2])
        ident, data = line.split()[2].split("#")
        fid = int(ident, 16) | (EFF if len(ident) == 8 else 0)
        if data.startswith("R"):
            frames.append((fid | RTR, None))
        else:
            frames.append((fid, bytes.fromhex(data)))
    return frames, 0


def decode_all(proto, db, frames):
    """[(kind, node, {signal: value})] per frame; raises on a frame the DBC does not know."""
    out = []
    for fid, data in frames:
        if proto == "vesc":
            assert fid & EFF and not fid & RTR, f"{fid:08X}: VESC frames are extended data"
            key, node = fid & ~0xFF & ~RTR, fid & 0xFF
        else:
            assert not fid & EFF, f"{fid:X}: ODrive frames are standard"
            key, node = fid & 0x1F, (fid & 0x7FF) >> 5
        msg = db.get_message_by_frame_id(key)
        if data is None:
            assert msg.senders == ["ODRIVE"], f"{fid:X}: a remote frame of a command"
            out.append((msg.name + "?", node, {}))
            continue
        if msg.name == "PROCESS_SHORT_BUFFER" and len(data) == 7:
            data += b"\0"  # the fault code request: the reply's last byte absent
        assert len(data) == msg.length, f"{fid:X}: DLC {len(data)}, the DBC says {msg.length}"
        out.append((msg.name, node, msg.decode(data, decode_choices=False)))
    return out


def read_log(path):
    samples = {}
    for ev in lcm.EventLog(path, "r"):
        if ev.channel == "OMNI4_MOTORS":
            m = motors_t.decode(ev.data)
            samples[m.seq] = m
    return samples


class Bus:
    """The decoded frames as the controller's ticks (command groups) and each wheel's reports."""

    def __init__(self, proto, decoded, addr):
        self.proto, self.addr = proto, addr
        cmd_kinds = {"vesc": ("SET_DUTY", "SET_CURRENT"), "odrive": ("Set_Input_Torque",)}[proto]
        self.ticks = []  # [(frame index of the group's first command, {wheel: (kind, values)})]
        self.reports = {}  # (kind, wheel) -> [(frame index, values)]
        for k, (kind, node, sig) in enumerate(decoded):
            if node not in addr:
                continue
            j = addr.index(node)
            if kind in cmd_kinds:
                if j == 0:
                    self.ticks.append((k, {}))
                if self.ticks:
                    self.ticks[-1][1][j] = (kind, sig)
            else:
                self.reports.setdefault((kind, j), []).append((k, sig))
        self.index = {key: [k for k, _ in rs] for key, rs in self.reports.items()}

    def candidates(self, kind, j, i, w=WINDOW_TICKS):
        """Reports of wheel j that tick i may have read: the last one before tick i - W's
        commands and every one after them, before tick i's (W = WINDOW_TICKS: a frame is on
        candump's log when the kernel's receive backlog delivers it, which a starved VM does
        after the controller's later sends and reads). None when the log holds none before
        tick i - W's (what the controller held then is not on it: not judged)."""
        if i < w:
            return None
        lo, hi = self.ticks[i - w][0], self.ticks[i][0]
        rs = self.reports.get((kind, j), [])
        idx = self.index[(kind, j)] if rs else []
        a, b = bisect.bisect_left(idx, lo), bisect.bisect_left(idx, hi)
        return [r for _, r in rs[a - 1:b]] if a > 0 else None


def expected_command(proto, s, m, j, supply):
    """The command the controller should have sent for sample m's voltage on wheel j."""
    u = m.voltage[j]
    if proto == "vesc":
        if supply is None:
            return None
        return max(-DUTY_MAX, min(DUTY_MAX, f32(u / supply)))
    w = s[("model", f"Kv_{j}")], s[("model", f"R_{j}")], s[("model", f"Kt_{j}")]
    kv, r, kt = (float(x) for x in w)
    cur = f32((u - kv * float(s[("model", "l")]) * m.wheel_speed[j]) / r)
    return f32(f32(kt) * cur)


def command_ok(proto, cmd, want, m, j):
    kind, sig = cmd
    if proto == "vesc" and kind == "SET_CURRENT":  # the release: disabled, 0 V logged
        return sig["current"] == 0 and m.voltage[j] == 0
    if proto == "vesc":
        return want is not None and abs(sig["duty"] - want) <= 1e-5  # the scale's step
    got = sig["input_torque"]
    return (got == 0 and m.voltage[j] == 0) or abs(got - want) <= 2e-6 * abs(want) + 1e-9


def commands_ok(bus, s, i, m):
    """Tick i's four commands are those of sample m's voltages (None: not judged)."""
    cmds = bus.ticks[i][1]
    if sorted(cmds) != [0, 1, 2, 3]:
        return False
    ok = True
    for j in range(4):
        if bus.proto == "vesc":
            sup = bus.candidates("STATUS_5", j, i)
            if sup is None:
                return None  # the input voltage it divided by is not on the log
            sup = [r["input_voltage"] for r in sup] or [None]
            ok &= any(command_ok("vesc", cmds[j], expected_command("vesc", s, m, j, v), m, j)
                      for v in sup)
        else:
            ok &= command_ok("odrive", cmds[j], expected_command("odrive", s, m, j, None), m, j)
    return ok


def matches(cands, same):
    """True when a report of cands is the logged one; None when not judged (no history)."""
    return None if cands is None else any(same(r) for r in cands)


def matches_late(bus, kind, j, i, same):
    """matches() within WINDOW_TICKS, else within WINDOW_LATE (counted in LATE)."""
    r = matches(bus.candidates(kind, j, i), same)
    if r is False and matches(bus.candidates(kind, j, i, WINDOW_LATE), same):
        LATE["reports"] += 1
        return True
    return r


def reports_ok(bus, s, i, m):
    """Sample m's wheel speeds and currents are those of reports tick i may have read: a list
    of True / False / None (not judged) per wheel and kind."""
    pp, gear = int(s[("vesc", "pole_pairs")]), float(s[("model", "l")])
    out = []
    for j in range(4):
        if bus.proto == "vesc":
            res = 2 * math.pi / 60 / pp / gear  # one ERPM at the wheel [rad/s]
            out.append(matches_late(bus, "STATUS_1", j, i, lambda r: abs(
                m.wheel_speed[j] - r["erpm"] / pp * 2 * math.pi / 60 / gear) <= res
                and abs(m.current[j] - r["current"]) <= 0.1 + OFFSET_A))
            continue
        out.append(matches_late(bus, "Get_Encoder_Estimates", j, i, lambda r: abs(
            m.wheel_speed[j] - f32(r["vel_estimate"] * 2 * math.pi / gear))
            <= 1e-6 * abs(m.wheel_speed[j]) + 1e-9))
        out.append(matches_late(bus, "Get_Iq", j, i,
                                lambda r: abs(m.current[j] - r["iq_measured"]) <= OFFSET_A))
    return out


def tick_ok(bus, s, i, m):
    return commands_ok(bus, s, i, m), reports_ok(bus, s, i, m)


def align(bus, samples, s):
    """The offset o (tick i is sample o + i) under which most ticks' commands match: the
    offsets that pair the middle tick, scored over every tick."""
    n = len(bus.ticks)
    mid = n // 2
    cands = [q - mid for q, m in samples.items() if commands_ok(bus, s, mid, m)]
    best, best_n = None, -1
    for o in cands:
        hits = sum(1 for i in range(1, n) if o + i in samples
                   and commands_ok(bus, s, i, samples[o + i]))
        if hits > best_n:
            best, best_n = o, hits
    return best


def pair(bus, samples, s, o):
    """{tick: seq}: from the middle tick (seq o + mid) outwards, each tick to the nearest
    following (preceding) logged tick whose commands it carries, at most MAX_SKIP ticks on.
    A tick whose frames never reached the bus (the emulated kernel drops frames when a starved
    VM's receive backlog is full: send() has succeeded) or a sample the logger lost is skipped;
    the skips are counted and printed."""
    n, mid = len(bus.ticks), len(bus.ticks) // 2
    out = {mid: o + mid}
    for step, rng in ((1, range(mid + 1, n - 1)), (-1, range(mid - 1, 0, -1))):
        q = o + mid
        for i in rng:
            if bus.proto == "vesc" and any(bus.candidates("STATUS_5", j, i) is None
                                           for j in range(4)):
                continue  # the input voltage it divided by is not on the log: not judged
            if sorted(bus.ticks[i][1]) != [0, 1, 2, 3]:
                continue  # a tick whose frames are not all on candump's log: counted apart
            near = [q + step * k for k in range(1, MAX_SKIP + 1) if q + step * k in samples]
            if not near:
                continue  # beyond the controller's log
            hit = [r for r in near if commands_ok(bus, s, i, samples[r])]
            out[i] = hit[0] if hit else None  # None: no logged tick carries these commands
            q = hit[0] if hit else q
    return out


def main():
    proto, dbc, candump, log, ini, keys = sys.argv[1:7]
    s = settings(ini, keys)
    frames, dropped = read_candump(candump)
    decoded = decode_all(proto, cantools.database.load_file(dbc), frames)
    addr = [int(s[(proto, ("id_" if proto == "vesc" else "node_") + str(j))]) for j in range(4)]
    bus = Bus(proto, decoded, addr)
    samples = read_log(log)
    kinds = sorted({k for k, _, _ in decoded})
    print(f"  {proto}: {len(frames)} frames decoded with {dbc.split('/')[-1]} "
          + (f"(then candump dropped {dropped}: the rest not judged) " if dropped else "")
          + f"({', '.join(kinds)}), {len(bus.ticks)} command ticks, {len(samples)} logged samples")
    o = align(bus, samples, s) if samples and len(bus.ticks) > 2 else None
    pairs = pair(bus, samples, s, o) if o is not None else {}
    # the last group may be cut by candump's frame count: not judged
    paired = sorted(i for i, q in pairs.items() if q is not None)
    unpaired = sorted(i for i, q in pairs.items() if q is None)
    res = [tick_ok(bus, s, i, samples[pairs[i]]) for i in paired]
    c_bad = [paired[k] for k, r in enumerate(res) if r[0] is False] + unpaired
    c_judged = sum(1 for r in res if r[0] is not None) + len(unpaired)
    r_bad = [paired[k] for k, r in enumerate(res) if False in r[1]]
    judged = sum(1 for r in res for x in r[1] if x is not None)
    skipped = sum(pairs[b] - pairs[a] - 1 for a, b in zip(paired, paired[1:]))
    partial = sum(1 for _, cmds in bus.ticks[1:-1] if sorted(cmds) != [0, 1, 2, 3])
    # a tick with a command missing from candump's log: a figure of the emulated bus, judged
    # only by their share
    ok = (c_judged >= 20 and not c_bad and not r_bad and judged >= 20
          and partial <= 0.01 * len(bus.ticks))
    seqs = f"seq {pairs[paired[0]]}..{pairs[paired[-1]]}" if paired else "none"
    print(f"{'ok' if ok else 'FAIL'}: {proto} bus against the controller's log: {len(paired)} "
          f"ticks paired ({seqs}; {skipped} logged ticks not on the bus or not logged; "
          f"{partial} ticks with a command missing from candump's log): "
          f"{c_judged} ticks' commands judged, differing in {len(c_bad)}; {judged} wheel "
          f"reports judged, differing in {len(r_bad)} ticks, {LATE['reports']} matched only "
          f"{WINDOW_TICKS + 1}-{WINDOW_LATE} ticks back (a starved loop's catch-up)"
          + (f" (first ticks {c_bad[:3]} {r_bad[:3]})" if c_bad or r_bad else ""))
    sys.exit(0 if ok else 1)


if __name__ == "__main__":
    main()
