"""The adapted motor constants shown and saved, live: omni4-fw (sim backend, udpm on a URL of its
own, ttl=0) whose simulated motors 0 and 2 differ from its [model] (R +20 % and -10 %), driven
until the online estimation has accepted estimates (OMNI4_ADAPT with ADAPTED), then at rest.
omni4-status shows each R in use against the identified R of the [model] (4.7 ohm) in %, the
flags and the last acceptance; `omni4-param save` writes the identified R (unchanged
behaviour), `omni4-param save --adapted` the R in use of the latest adapt_t (and their mean as
the scalar), and the R in use stays what it was."""
import re
import signal
import subprocess
import threading
import time

import lcm
import pytest
from conftest import lcm_test_url
from livefw import EXIT_TIMEOUT_S, SCALE, Firmware, tool

import omni4

R_MODEL = 4.7                    # [ohm] the [model] R of this controller (identified)
R_ERROR = {0: 0.2, 2: -0.1}      # [sim] motor_R_error_j: the simulated motors' R is R (1 + e)
# A failure bound for the estimation to accept (here ~2 s of driving): generous so that a loaded
# machine cannot reach it; a passing test never waits it out.
ADAPT_TIMEOUT_S = 60 * SCALE
DRIVE = ((0.5, 0.0, 0.0), (0.0, 0.5, 0.0), (-0.5, 0.0, 0.0), (0.0, 0.0, 3.0))  # 1.5 s each
MODEL = dict(d=0.089, r=0.0325, l=5, Kv=0.0259, Kt=0.0259, R=R_MODEL, M=2.34, J=0.0228,
             Bv=0.4978, Bvn=0.6763, Bw=0.0141, Cv=1.8738, Cvn=2.2198, Cw=0.1385)


class AdaptBus:
    """The last adapt_t of a URL and the acceptances seen (param_changed_t source adapt), read
    in a thread of its own."""

    def __init__(self, url):
        self.lc = lcm.LCM(url)
        self.last, self.accepted_seqs = None, []
        self.lock = threading.Lock()
        self.lc.subscribe(omni4.CHANNEL_ADAPT, self._on_adapt)
        self.lc.subscribe(omni4.CHANNEL_PARAM_CHANGED, self._on_changed)
        self.done = threading.Event()
        self.thread = threading.Thread(target=self._run, daemon=True)
        self.thread.start()

    def _on_adapt(self, _channel, data):
        with self.lock:
            self.last = omni4.adapt_t.decode(data)

    def _on_changed(self, _channel, data):
        m = omni4.param_changed_t.decode(data)
        if m.source == "adapt" and dict(zip(m.keys, m.values)).get("adapt.event") == "accepted":
            with self.lock:
                self.accepted_seqs.append(m.seq)

    def _run(self):
        while not self.done.is_set():
            self.lc.handle_timeout(50)

    def fresh(self, timeout_s):
        """The first adapt_t sent after this call, or None."""
        with self.lock:
            before = self.last.seq if self.last is not None else -1
        end = time.monotonic() + timeout_s
        while time.monotonic() < end:
            with self.lock:
                if self.last is not None and self.last.seq > before:
                    return self.last
            time.sleep(0.02)
        return None

    def close(self):
        self.done.set()
        self.thread.join(timeout=2)


@pytest.fixture(scope="module")
def adapted(omni4_bin, tmp_path_factory):
    """(url, robot INI path, AdaptBus) of a controller that adapted its R and is at rest."""
    url = lcm_test_url()
    tmp = tmp_path_factory.mktemp("adapt")
    model = "[model]\n" + "".join(f"{k} = {v}\n" for k, v in MODEL.items())
    sim = "[sim]\n" + "".join(f"motor_R_error_{j} = {e}\n" for j, e in R_ERROR.items())
    fw = Firmware(omni4_bin("omni4-fw"), tmp, url, model + sim)
    bus = AdaptBus(url)
    robot = omni4.Robot(url)
    # omni4-status --watch from before the drive: it sees the acceptances as they come
    watch = subprocess.Popen(tool("omni4-status") + ["--lcm", url, "--listen", "0.5", "--watch"],
                             stdout=subprocess.PIPE, stderr=subprocess.PIPE, text=True)
    try:
        t0 = time.monotonic()
        while time.monotonic() - t0 < ADAPT_TIMEOUT_S:
            robot.velocity(*DRIVE[int((time.monotonic() - t0) / 1.5) % len(DRIVE)])
            time.sleep(0.05)
            with bus.lock:
                done = bus.last is not None and bus.last.flags & omni4.adapt_t.FLAG_ADAPTED \
                    and not bus.last.flags & omni4.adapt_t.FLAG_WATCH
            if done:
                break
        else:
            pytest.fail(f"no acceptance after {ADAPT_TIMEOUT_S:g} s of driving")
        robot.stop()
        robot.close()
        ini = next(p for p in tmp.iterdir() if p.suffix == ".ini")
        yield url, ini, bus, watch
    finally:
        if watch.poll() is None:
            watch.kill()
        watch.wait(timeout=EXIT_TIMEOUT_S)
        bus.close()
        fw.stop()


def _r_line(text):
    m = re.search(r"^adapted R in use \[ohm\] \(vs identified\): (.*)$", text, re.M)
    assert m, text
    got = re.findall(r"([0-9.]+) \(([+-][0-9.]+) %\)", m.group(1))
    assert len(got) == 4, m.group(0)
    return [(float(r), float(p)) for r, p in got]


@pytest.mark.live
def test_status_watch_names_the_last_acceptance(adapted):
    """omni4-status --watch, running from before the drive: a block names an acceptance the
    test saw on OMNI4_PARAM_CHANGED (by its tick), with ACCEPTED counted; Ctrl-C ends it."""
    _, _, bus, watch = adapted
    out, found = "", None
    while found is None:
        line = watch.stdout.readline()
        assert line, f"omni4-status --watch ended after {out!r}"
        out += line
        found = re.match(r"^adapt last event: accepted at tick (\d+): R_0 [0-9.]+ -> [0-9.]+.* "
                         r"\((\d+) accepted, (\d+) reverted seen\)$", line)
    watch.send_signal(signal.SIGINT)
    assert watch.wait(timeout=EXIT_TIMEOUT_S) == 0
    assert int(found.group(1)) in bus.accepted_seqs, (found.group(0), bus.accepted_seqs)
    assert int(found.group(2)) >= 1


@pytest.mark.live
def test_status_shows_the_r_in_use_against_the_identified(adapted):
    url, _, bus, _ = adapted
    r = subprocess.run(tool("omni4-status") + ["--lcm", url, "--listen", "1"],
                       capture_output=True, text=True, timeout=EXIT_TIMEOUT_S)
    print(r.stdout, r.stderr)
    assert r.returncode == 0, r.stderr
    a = bus.fresh(5 * SCALE)
    assert a is not None
    for j, (r_ohm, pct) in enumerate(_r_line(r.stdout)):
        assert abs(r_ohm - a.R[j]) <= 0.5e-4                       # printed to 0.1 mohm
        assert abs(pct - 100 * (a.R[j] / R_MODEL - 1)) <= 0.05 + 1e-9   # to 0.1 %
        # The estimation learns the simulated motor's R (1 + e); 2-3x its measured 1.3 %.
        assert abs(a.R[j] / (R_MODEL * (1 + R_ERROR.get(j, 0.0))) - 1) < 0.04, (j, a.R[j])
    assert re.search(r"^adapt flags: ON .*ADAPTED", r.stdout, re.M), r.stdout
    # a one-shot status at rest saw no acceptance while it listened, and says so
    assert re.search(r"^adapt last event: none seen \(0 accepted, 0 reverted seen\)$",
                     r.stdout, re.M), r.stdout
    assert re.search(r"^adapt supply \[V\]: [0-9.]+; C in use: Cv 1.8738 N, Cvn 2.2198 N, "
                     r"Cw 0.1385 N m$", r.stdout, re.M), r.stdout


def _ini_model(path):
    return dict(omni4.ini.read(str(path)).section("model"))


@pytest.mark.live
def test_param_save_writes_the_adapted_r_only_when_asked(adapted):
    url, ini, bus, _ = adapted
    r = subprocess.run(tool("omni4-param") + ["--lcm", url, "save"], capture_output=True,
                       text=True, timeout=EXIT_TIMEOUT_S)
    assert r.returncode == 0, r.stderr
    m = _ini_model(ini)
    assert float(m["r"]) == 0.0325 and float(m["R"]) == R_MODEL, m   # the identified R
    assert all(float(m.get(f"R_{j}", R_MODEL)) == R_MODEL for j in range(4)), m
    a = bus.fresh(5 * SCALE)
    r = subprocess.run(tool("omni4-param") + ["--lcm", url, "save", "--adapted"],
                       capture_output=True, text=True, timeout=EXIT_TIMEOUT_S)
    print(r.stdout, r.stderr)
    assert r.returncode == 0, r.stderr
    assert re.search(r"^adapted: model.R_0 = [0-9.]+ \(was 4.7\)$", r.stdout, re.M), r.stdout
    assert re.search(r"^saved .* in \d+ ms$", r.stdout, re.M), r.stdout
    m = _ini_model(ini)
    for j in range(4):
        # wheels 1 and 3 kept the identified value (no acceptance moved them)
        assert abs(float(m.get(f"R_{j}", m["R"])) - a.R[j]) <= 1e-6, (j, m, list(a.R))
    assert abs(float(m["R"]) - sum(a.R) / 4) <= 1e-6, m
    assert float(m["Cv"]) == MODEL["Cv"], m                       # C in use: the identified
    after = bus.fresh(5 * SCALE)                                  # the R in use did not move
    assert after is not None and list(after.R) == pytest.approx(list(a.R), rel=1e-6)
