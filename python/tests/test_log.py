"""omni4.read_log against an independent reader (lcm.EventLog + the lcm-gen decoders) on logs
written by omni4-sim, and on broken logs: truncated, garbage, empty, split, unknown channels,
wrong fingerprints, corrupt headers, sync words inside payloads."""
import struct
import subprocess
from collections import defaultdict

import lcm
import numpy as np
import pytest

import omni4
from omni4 import log as omni4_log
from omni4 import LogError, read_log

SIM_TIMEOUT_S = 60   # omni4-sim --experiments takes ~0.5 s
PREFIX_BYTES = 5_000_001  # ~17 s of the experiments with the simulated truth (~37000 events)


def event_bounds(data):
    """Independent header walk (pure Python, no resync): [(start, end)] of the events of an
    intact log, and where the intact part ends."""
    out, pos = [], 0
    while pos + 28 <= len(data):
        sync, _num, _t, clen, dlen = struct.unpack_from(">IqqII", data, pos)
        assert sync == 0xEDA1DA01, f"no sync word at {pos}"
        end = pos + 28 + clen + dlen
        if end > len(data):
            break
        out.append((pos, end))
        pos = end
    return out, pos


@pytest.fixture(scope="module")
def logs(tmp_path_factory, omni4_bin):
    """A clean log (the first ~2 MB of omni4-sim --experiments, cut at an event boundary) and
    the same bytes cut inside an event."""
    d = tmp_path_factory.mktemp("logs")
    full = d / "full.lcmlog"
    r = subprocess.run([omni4_bin("omni4-sim"), "--experiments", "--speed", "max", "-q",
                        "--out", str(full)], capture_output=True, text=True,
                       timeout=SIM_TIMEOUT_S)
    assert r.returncode == 0, f"omni4-sim failed: {r.stderr}"
    data = full.read_bytes()[:PREFIX_BYTES]
    bounds, end = event_bounds(data)
    clean = d / "clean.lcmlog"
    clean.write_bytes(data[:end])
    cut = d / "cut.lcmlog"
    cut.write_bytes(data)
    return {"dir": d, "clean": clean, "cut": cut, "bounds": bounds, "bytes": data[:end]}


def eventlog_read(path):
    """The independent reader: lcm.EventLog and the generated decode, per channel a list of
    (log time, message); undecodable events and unknown channels counted."""
    out = defaultdict(list)
    unknown = defaultdict(list)
    bad = defaultdict(int)
    for ev in lcm.EventLog(str(path), "r"):
        cls = omni4.TYPES.get(ev.channel)
        if cls is None:
            unknown[ev.channel].append((ev.timestamp, ev.data))
            continue
        try:
            out[ev.channel].append((ev.timestamp, cls.decode(ev.data)))
        except (ValueError, struct.error):  # wrong fingerprint, payload cut short
            bad[ev.channel] += 1
    return out, unknown, bad


def assert_channel_equal(ch, ref):
    """Every field of every message equal (NaN equal to NaN), counts equal."""
    assert len(ch) == len(ref), f"{ch.name}: {len(ch)} read, {len(ref)} in the reference"
    assert np.array_equal(ch.event_utime, np.array([t for t, _ in ref], np.int64))
    for name in ch.type.__slots__:
        got = getattr(ch, name)
        want = [getattr(m, name) for _, m in ref]
        if got.dtype.kind == "U":
            assert got.tolist() == want, f"{ch.name}.{name}"
            continue
        want = np.array(want, dtype=got.dtype).reshape(got.shape)
        assert np.array_equal(got, want, equal_nan=got.dtype.kind == "f"), f"{ch.name}.{name}"


def assert_same_log(a, b):
    for name in omni4.TYPES:
        ca, cb = a.channels[name], b.channels[name]
        assert len(ca) == len(cb), name
        for f in ("event_utime",) + ca.fields:
            x, y = getattr(ca, f), getattr(cb, f)
            assert x.dtype == y.dtype and np.array_equal(x, y), f"{name}.{f}"


def write_log(path, events):
    """events: (log time [us], channel, payload bytes) through lcm.EventLog's writer."""
    w = lcm.EventLog(str(path), "w", overwrite=True)
    for t, ch, data in events:
        w.write_event(t, ch, data)
    w.close()


def test_every_field_equals_eventlog_decode(logs):
    log = read_log(logs["clean"])
    ref, unknown, bad = eventlog_read(logs["clean"])
    # Besides the four typed channels, omni4-sim logs the controller's current-offset
    # calibrations (param_changed_t, source "calibration"), which read_log counts.
    assert set(unknown) == {omni4.CHANNEL_PARAM_CHANGED} and not bad
    assert log.unknown_counts == {k: len(v) for k, v in unknown.items()}
    for _, data in unknown[omni4.CHANNEL_PARAM_CHANGED]:
        m = omni4.param_changed_t.decode(data)
        assert (m.source, m.request_id, m.path) == ("calibration", 0, "")
        assert m.keys[:5] == [f"calibration.current_offset_a{j}" for j in range(4)] + \
            ["calibration.samples"]
    for name in omni4.TYPES:
        assert_channel_equal(log.channels[name], ref[name])
    assert log.events == len(logs["bounds"]) == sum(len(v) for v in ref.values()) + \
        sum(len(v) for v in unknown.values())
    assert log.bytes_skipped == 0 and log.files[0].tail_bytes == 0
    assert log.seq_gaps == 0 and log.seq_duplicates == 0
    # The prefix holds what the comparison needs to mean something.
    assert len(log.motors) > 15000 and len(log.pose) > 300 and len(log.cmd) > 300
    assert set(log.experiment.kind) == {"steady_rotation", "end"}
    assert {2, 3} <= set(log.motors.mode.tolist())
    assert np.abs(log.motors.wheel_speed).max() > 10
    # Units and widths of the documented fields.
    assert log.motors.voltage.shape == (len(log.motors), 4)
    assert log.motors.voltage.dtype == np.float32 and log.motors.utime.dtype == np.int64
    assert log.cmd.velocity.shape == (len(log.cmd), 3) and log.pose.x.dtype == np.float64


def test_truncated_event_reads_what_is_complete(logs, tmp_path):
    data = logs["bytes"]
    starts = [s for s, _ in logs["bounds"]]
    # Cut inside a header, inside a channel name, inside a payload, one byte short of the end.
    for cut in (starts[-1] + 10, starts[-1] + 30, starts[-2] + 60, len(data) - 1):
        p = tmp_path / f"cut{cut}.lcmlog"
        p.write_bytes(data[:cut])
        log = read_log(p)
        ref, unknown, _ = eventlog_read(p)
        complete = [b for b in logs["bounds"] if b[1] <= cut]
        assert log.events == len(complete) == sum(len(v) for v in ref.values()) + \
            sum(len(v) for v in unknown.values()), cut
        assert log.files[0].tail_bytes == log.bytes_skipped == cut - complete[-1][1]
        assert_channel_equal(log.motors, ref[omni4.CHANNEL_MOTORS])
        assert f"{cut - complete[-1][1]} in a truncated tail" in log.summary()


def test_cut_log_of_the_fixture_reports_its_tail(logs):
    log = read_log(logs["cut"])
    assert log.bytes_skipped == PREFIX_BYTES - len(logs["bytes"]) > 0


def test_garbage_file_is_a_clear_error(tmp_path):
    p = tmp_path / "garbage.lcmlog"
    p.write_bytes(np.random.default_rng(1).integers(0, 256, 200_000, np.uint8).tobytes())
    with pytest.raises(LogError, match=r"garbage.lcmlog: no intact LCM event \(no LCM sync"):
        read_log(p)


def test_empty_file_is_a_clear_error(tmp_path):
    p = tmp_path / "empty.lcmlog"
    p.write_bytes(b"")
    with pytest.raises(LogError, match=r"empty.lcmlog: no intact LCM event \(empty\)"):
        read_log(p)


def test_missing_file_names_its_path(tmp_path):
    with pytest.raises(FileNotFoundError, match="nothere.lcmlog"):
        read_log(tmp_path / "nothere.lcmlog")


def test_split_log_reads_as_one_stream(logs):
    """Parts written as omni4-record --split-mb writes them (a new event log per part, event
    numbers from 0 again): FILE.00, FILE.01, FILE.02."""
    events = [(ev.timestamp, ev.channel, ev.data) for ev in lcm.EventLog(str(logs["clean"]))]
    base = logs["dir"] / "split.lcmlog"
    k = len(events) // 3
    parts = [events[:k], events[k:2 * k], events[2 * k:]]
    for i, part in enumerate(parts):
        write_log(f"{base}.{i:02d}", part)
    whole = read_log(logs["clean"])
    assert omni4_log.split_parts(str(base)) == [f"{base}.{i:02d}" for i in range(3)]
    for log in (read_log([f"{base}.{i:02d}" for i in range(3)]), read_log(base)):
        assert [f.events for f in log.files] == [len(p) for p in parts]
        assert_same_log(log, whole)
        assert log.seq_gaps == 0 and log.seq_duplicates == 0
    # Parts in the wrong order: the same samples, and the reordering shows.
    swapped = read_log([f"{base}.01", f"{base}.00", f"{base}.02"])
    assert len(swapped.motors) == len(whole.motors) and swapped.seq_duplicates == 1
    # An empty last part (the recorder stopped right after opening it) is no error.
    open(f"{base}.03", "wb").close()
    log = read_log(base)
    assert log.files[-1].events == 0 and len(log.motors) == len(whole.motors)


def test_unknown_channel_is_kept_raw_or_counted(logs, tmp_path):
    events = [(ev.timestamp, ev.channel, ev.data) for ev in lcm.EventLog(str(logs["clean"]))]
    extra = [(events[i][0], "OTHER_SENSOR", bytes([i % 256]) * (i % 50)) for i in range(0, 900, 9)]
    mixed = sorted(events + extra, key=lambda e: e[0])
    p = tmp_path / "mixed.lcmlog"
    write_log(p, mixed)
    log = read_log(p)
    _, unknown, _ = eventlog_read(p)
    base = read_log(logs["clean"]).unknown_counts  # the calibration notices
    assert log.unknown_counts == {"OTHER_SENSOR": len(extra), **base}
    assert log.unknown["OTHER_SENSOR"] == unknown["OTHER_SENSOR"]
    assert_same_log(log, read_log(logs["clean"]))
    counted = read_log(p, keep_unknown=False)
    assert counted.unknown == {"OTHER_SENSOR": [], **{k: [] for k in base}}
    assert counted.unknown_counts == {"OTHER_SENSOR": len(extra), **base}
    assert "OTHER_SENSOR: 100 (no omni4 type)" in log.summary()


def test_wrong_fingerprint_and_size_are_counted_not_decoded(logs, tmp_path):
    events = [(ev.timestamp, ev.channel, ev.data) for ev in lcm.EventLog(str(logs["clean"]))]
    good = next(e for e in events if e[1] == omni4.CHANNEL_MOTORS)
    flipped = bytes([good[2][0] ^ 0x80]) + good[2][1:]   # motors-sized, fingerprint changed
    pose = omni4.pose_t().encode()                         # another type on OMNI4_MOTORS
    longer = good[2] + b"\0"                               # a field added to the .lcm
    mark = omni4.experiment_t()
    mark.kind = "step"
    bad_mark = mark.encode()[:-3]                          # experiment_t cut short
    extra = [(good[0], omni4.CHANNEL_MOTORS, flipped), (good[0], omni4.CHANNEL_MOTORS, pose),
             (good[0], omni4.CHANNEL_MOTORS, longer),
             (good[0], omni4.CHANNEL_EXPERIMENT, bad_mark)]
    p = tmp_path / "fp.lcmlog"
    write_log(p, events[:100] + extra + events[100:])
    log = read_log(p)
    ref, _, bad = eventlog_read(p)
    assert log.motors.skipped == {"wrong_size": 2, "wrong_fingerprint": 1}
    assert log.experiment.skipped == {"wrong_fingerprint": 0, "undecodable": 1}
    # lcm-gen's decoder refuses the fingerprints and the short mark, and reads the longer one.
    assert bad == {omni4.CHANNEL_MOTORS: 2, omni4.CHANNEL_EXPERIMENT: 1}
    assert_channel_equal(log.pose, ref[omni4.CHANNEL_POSE])
    assert_same_log(log, read_log(logs["clean"]))
    assert f"OMNI4_MOTORS: {len(log.motors)} (skipped: 1 wrong_fingerprint, 2 wrong_size)" \
        in log.summary()


def test_corrupt_header_skips_that_event_only(logs, tmp_path):
    data = bytearray(logs["bytes"])
    bounds = logs["bounds"]
    k = len(bounds) // 2
    s, e = bounds[k]
    data[s:s + 4] = b"\xde\xad\xbe\xef"         # sync word of event k destroyed
    s2, e2 = bounds[k + 50]
    data[s2 + 20:s2 + 24] = struct.pack(">i", 100000)  # channel length beyond 256
    p = tmp_path / "corrupt.lcmlog"
    p.write_bytes(bytes(data))
    log = read_log(p)
    assert log.events == len(bounds) - 2
    assert log.bytes_skipped == (e - s) + (e2 - s2) and log.files[0].tail_bytes == 0


def test_garbage_before_a_log_and_sync_words_inside_payloads(logs, tmp_path):
    """A sync word followed by a plausible header inside a payload is not an event (the walk
    continues after the enclosing event), and leading garbage is skipped up to the first
    event."""
    fake_header = struct.pack(">IqqII", 0xEDA1DA01, 0, 0, 4, 8) + b"FAKE" + b"\0" * 8
    events = [(ev.timestamp, ev.channel, ev.data) for ev in lcm.EventLog(str(logs["clean"]))]
    extra = [(events[0][0], "BLOB", b"x" * k + fake_header) for k in range(5)]
    p = tmp_path / "blob.lcmlog"
    write_log(p, extra + events)
    junk = bytes(range(7, 250))
    p.write_bytes(junk + p.read_bytes())
    log = read_log(p)
    base = read_log(logs["clean"]).unknown_counts  # the calibration notices
    assert log.unknown_counts == {"BLOB": 5, **base} and "FAKE" not in log.unknown_counts
    assert log.bytes_skipped == len(junk) and log.files[0].tail_bytes == 0
    assert_same_log(log, read_log(logs["clean"]))


def test_fixed_size_path_equals_message_by_message_decode(logs):
    log = read_log(logs["clean"])
    buf, spans = omni4_log._load([str(logs["clean"])])
    off, clen, dlen, _t, _s, _tail = omni4_log._walk(buf, *spans[0])
    ids = omni4_log._channel_ids(buf, off, clen, list(omni4.TYPES))
    for name, cls in omni4.TYPES.items():
        if cls not in omni4_log._FAST:
            continue
        i = list(omni4.TYPES).index(name)
        doff = (off + 28 + clen)[ids == i]
        slow, keep, skipped = omni4_log._decode_each(buf, cls, doff, dlen[ids == i])
        assert len(keep) == len(log.channels[name]) and not any(skipped.values())
        for f, v in slow.items():
            assert np.array_equal(v.astype(getattr(log.channels[name], f).dtype),
                                  getattr(log.channels[name], f), equal_nan=True), f


def test_fixed_size_types_take_the_structured_view():
    assert set(omni4_log._FAST) == {omni4.motors_t, omni4.pose_t, omni4.command_t,
                                     omni4.state_t, omni4.sim_truth_t, omni4.goal_status_t,
                                     omni4.sim_plant_t, omni4.adapt_t, omni4.robot_t}


def test_same_motors_as_eventlog_decode(logs):
    """read_log against lcm.EventLog iteration + motors_t.decode on the same log: the same
    OMNI4_MOTORS samples, field by field. (How much faster it is, is bench/read_log.py's figure,
    printed by bench/run beside this peer: a test does not time it.)"""
    log = read_log(logs["clean"])
    peer = [omni4.motors_t.decode(ev.data) for ev in lcm.EventLog(str(logs["clean"]))
            if ev.channel == omni4.CHANNEL_MOTORS]
    assert len(peer) == len(log.motors) > 0
    cols = log.motors
    assert np.array_equal(cols.seq, [m.seq for m in peer])
    assert np.array_equal(cols.utime, [m.utime for m in peer])
    for f in ("voltage", "current", "wheel_speed"):
        assert np.array_equal(getattr(cols, f), np.array([getattr(m, f) for m in peer],
                                                         dtype=getattr(cols, f).dtype)), f


def test_a_variable_length_type_in_types_is_decoded_into_object_columns(tmp_path, monkeypatch):
    """A type with variable-length arrays and nested types (param_reply_t), were it put in
    omni4.TYPES: numbers and strings as typed arrays, the ragged field as objects."""
    monkeypatch.setitem(omni4.TYPES, "TEST_REPLY", omni4.param_reply_t)
    events = []
    for k in range(3):
        r = omni4.param_reply_t()
        r.utime, r.request_id, r.message = 1000 + k, 7 + k, f"reply {k}"
        r.params = []
        for j in range(k):
            v = omni4.param_value_t()
            v.key = f"control.k{j}"
            r.params.append(v)
        r.n = len(r.params)
        events.append((1000 + k, "TEST_REPLY", r.encode()))
    p = tmp_path / "reply.lcmlog"
    write_log(p, events)
    ch = read_log(p).channels["TEST_REPLY"]
    assert len(ch) == 3 and ch.utime.tolist() == [1000, 1001, 1002]
    assert ch.message.tolist() == ["reply 0", "reply 1", "reply 2"]
    assert ch.params.dtype == object and [len(x) for x in ch.params] == [0, 1, 2]
    assert ch.params[2][1].key == "control.k1"
