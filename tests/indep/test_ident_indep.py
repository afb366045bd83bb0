#!/usr/bin/env python3
"""Identify robots of the independent plant from foreign-layout logs and check against the truth.

For every layout and robot: write the log (write_logs.py), run
  BIN_DIR/omni4-ident identify --robot base.ini --out params.ini LOG   [--velocity camera]
  BIN_DIR/omni4-ident validate --params params.ini --json v.json LOG   [--velocity camera]
once with the encoder velocities (default) and once with --velocity camera. Bounds (never
loosened): Kv R J Bv Bvn Bw Cv Cvn Cw each within 2 % of the truth; per axis e_max and sigma of the
validation within the paper's Table IV (final). A log that omni4-ident refuses, or an option it
rejects, is a failure with its message. Prints the worst error per parameter and layout, the worst
validation figures beside Table IV, the failures, and 'ident_indep: N passed, M failed'
(one case = robot x layout x velocity source). Exit status 1 if any bound is missed.

Real sensors (layout `sensors`, or --sensors for any layout): the same bounds. The table gets a
row per base layout of the `sensors` layout. Where the logs carry current offsets, identify also
writes --csv DIR; if DIR/current_offsets.csv (columns log, motor, offset_a, se_a) exists, every
motor's estimate must be within 3 SE + 1 mA of the offset in the log's sidecar
(robotK_LAYOUT.sensors.json); if omni4-ident does not write that file, the comparison is skipped
and the summary says so.

Per-wheel drives (--wheel-spread R,KV,RADIUS in per cent, e.g. 5,5,1): the robots' motors and
wheels differ (plant.robot_params); then also each motor's R_j, Kv_j and Kt_j within 1 % and each
wheel's radius relative to the mean within 0.3 % of the truth (wheel_checks.py).

Stricter bounds for real sensors (--validation-fraction ENC,CAM, e.g. 0.25,0.5): the validation
e_max and sigma must be within that fraction of Table IV. With the camera, the bound is never
below what the TRUE parameters give on the same log times 1.1: validate runs with the truth too,
and the camera's own noise (1 cm, 3 deg at 25 Hz) sets a floor no model can go under.
--encoder-floor: the encoders' bound gets the same floor (a sample after a lost one, whose
interval is not known, can set e_max with the true parameters too). The floor itself, the true
parameters' validation, must be within Table IV: an exact model reproduces the log at least as
well as the paper's final one (a validation that ran its plant on the wrong layout gave 2.4 m/s,
and with the floor beside it passed).

Other wheel layouts (--wheels, --angles, --dist as write_logs.py): identify gets the layout from a
robot file (the base INI and the truth's layout keys, --layout-from robot) or from the log's
OMNI4_ROBOT (--layout-from log); validate from the identified parameters' layout keys (or the
log's). The body stays hidden either way.
--camera-params se: a camera-source parameter passes within 2 % or within 3 of the standard
errors identify reports for it (params.csv, final): off by more than 2 % only where the tool
says the data do not pin it that well.
"""
import argparse
import collections
import concurrent.futures as cf
import csv
import json
import os
import subprocess
import sys
import tempfile
import time

HERE = os.path.dirname(os.path.abspath(__file__))
sys.path.insert(0, HERE)
import layouts      # noqa: E402
import wheel_checks  # noqa: E402
import write_logs   # noqa: E402

PARAMS = ("Kv", "R", "J", "Bv", "Bvn", "Bw", "Cv", "Cvn", "Cw")
PARAM_TOL_PCT = 2.0
#: --camera-params se: a parameter over 2 % must be within this many of its reported SEs
PARAM_TOL_SE = 3.0
#: the paper's Table IV (final model): per axis (e_max, sigma) [m/s, m/s, rad/s]
TABLE_IV = {"v": (0.061, 0.024), "vn": (0.068, 0.026), "w": (2.504, 0.732)}
SOURCES = ("encoder", "camera")
#: relative cost of a layout's generation (ticks), to start the slow ones first
COST = {"rate2k": 2.0, "rate500": 0.5}
TOOL_TIMEOUT_S = 300
#: current offset estimates must be within this many SE plus OFFSET_TOL_A of the truth
OFFSET_TOL_SE, OFFSET_TOL_A = 3.0, 0.001
OFFSETS_CSV = "current_offsets.csv"


def gen_task(layout, seed, robots, out_dir, lcm_python, sensors=None, wheels=None,
             geometry=None, layout_from="robot"):
    """Worker: write the logs of some robots of one layout; returns (layout, list of log
    dicts, seconds). geometry: the wheel layout (write_logs.parse_geometry), None the paper's;
    layout_from "robot": each robot gets a robot file with it (robot_file), "log": the logs
    carry OMNI4_ROBOT and identify gets the base INI alone."""
    t = time.time()
    res = write_logs.generate(layout, seed, robots, os.path.join(out_dir, layout),
                              lcm_python=lcm_python, progress=None, sensors=sensors,
                              wheels=wheels, geometry=geometry, robot_msg=layout_from == "log")
    if geometry is not None and layout_from == "robot":
        for entry in res:
            entry["base"] = robot_file(entry["base"], entry["truth"])
    return layout, res, time.time() - t


#: the [model] keys of a wheel layout: the robot's geometry, measured as d, r, l and M are
LAYOUT_KEYS = ("wheels", "wheel_angle_", "d_")


def robot_file(base, truth):
    """The robot file of a robot with its own wheel layout: the base INI (d r l M) and the
    layout's keys (wheels, wheel_angle_j, d_j) as the truth INI gives them (the layout is the
    robot's measured geometry; the body stays hidden). Returns its path (robotK_robot.ini)."""
    path = base.replace("_base.ini", "_robot.ini")
    with open(truth) as f:
        keys = [ln for ln in f if ln.split("=")[0].strip().startswith(LAYOUT_KEYS)
                and ln.split("=")[0].strip() != "d"]
    with open(base) as f, open(path, "w") as out:
        out.write(f.read().rstrip("\n") + "\n" + "".join(keys))
    return path


def gen_chunks(names, robots, jobs):
    """(layout, robots) generation tasks: one per layout and loop rate (the `sensors` layout
    mixes rates), the largest split in halves while there are fewer tasks than workers."""
    chunks = [(n, g) for n in names for g in write_logs.rate_groups(n, robots)]
    while len(chunks) < jobs:
        big = max(range(len(chunks)), key=lambda j: len(chunks[j][1]))
        name, group = chunks[big]
        if len(group) < 2:
            break
        half = len(group) // 2
        chunks[big:big + 1] = [(name, group[:half]), (name, group[half:])]
    return chunks


def check_offsets(csv_dir, entry):
    """Compare identify's current offset estimates (csv_dir/current_offsets.csv) with the log's
    sidecar. Returns dict: status 'skipped' (no such file) or 'checked', worst (largest
    |est - true| / (3 SE + 1 mA)), worst_ma, fail (list of messages)."""
    path = os.path.join(csv_dir, OFFSETS_CSV)
    out = {"status": "skipped", "worst": None, "worst_ma": None, "fail": []}
    if not os.path.exists(path):
        return out
    out["status"] = "checked"
    with open(entry["sensors"]) as f:
        truth = json.load(f)["current_offset_a"]
    name = os.path.basename(entry["log"])
    est = {}
    try:
        with open(path, newline="") as f:
            rows = list(csv.DictReader(f))
        for row in rows:
            if os.path.basename(row["log"].strip()) == name:
                est[int(row["motor"])] = (float(row["offset_a"]), float(row["se_a"]))
    except (OSError, KeyError, ValueError, TypeError, AttributeError) as e:
        out["fail"].append(f"{OFFSETS_CSV} unreadable (columns log,motor,offset_a,se_a): {e}")
        return out
    for j, true_a in enumerate(truth):
        if j not in est:
            out["fail"].append(f"{OFFSETS_CSV} has no offset of motor {j} for {name}")
            continue
        val, se = est[j]
        bound = OFFSET_TOL_SE * se + OFFSET_TOL_A
        ratio = abs(val - true_a) / bound if bound > 0 else float("inf")
        if out["worst"] is None or not ratio <= out["worst"]:
            out["worst"], out["worst_ma"] = ratio, 1e3 * abs(val - true_a)
        if not ratio <= 1.0:
            out["fail"].append(f"current offset motor {j}: {1e3 * val:+.2f} +- {1e3 * se:.2f} mA,"
                               f" true {1e3 * true_a:+.2f} mA (over 3 SE + 1 mA)")
    return out


def _tool(cmd):
    """Run omni4-ident; returns (status, one-line message): status 'ok', 'refused' (non-zero
    exit or time-out) or 'not started' (the binary could not be executed)."""
    try:
        r = subprocess.run(cmd, capture_output=True, text=True, timeout=TOOL_TIMEOUT_S)
    except subprocess.TimeoutExpired:
        return "refused", f"timed out after {TOOL_TIMEOUT_S} s"
    except OSError as e:
        return "not started", f"omni4-ident could not be started: {e}"
    if r.returncode != 0:
        lines = [ln for ln in (r.stderr + r.stdout).splitlines() if ln.strip()]
        msg = next((ln for ln in lines if "omni4-ident" in ln or "rror" in ln or "not expected"
                    in ln), lines[0] if lines else "")
        return "refused", f"exit {r.returncode}: {msg.strip()}"
    return "ok", ""


def check_layout_csv(csv_dir, truth_ini):
    """identify's layout.csv (what the report draws) against the truth's layout keys: the same
    wheels, angles and distances (to 1e-9); no file for the paper's layout. Failure lines."""
    truth = write_logs.read_ini(truth_ini)
    n = int(truth.get("wheels", 4))
    want = [(j, truth.get(f"wheel_angle_{j}", 90.0 * j), truth.get(f"d_{j}", truth["d"]))
            for j in range(n)]
    paper = n == 4 and all(a == 90.0 * j and d == want[0][2] for j, a, d in want)
    path = os.path.join(csv_dir, "layout.csv")
    if not os.path.exists(path):
        return [] if paper else ["identify wrote no layout.csv for a layout not the paper's"]
    with open(path, newline="") as f:
        got = [(int(r["wheel"]), float(r["angle_deg"]), float(r["d_m"]))
               for r in csv.DictReader(f)]
    ok = len(got) == len(want) and all(
        g[0] == w[0] and abs(g[1] - w[1]) < 1e-9 and abs(g[2] - w[2]) < 1e-9
        for g, w in zip(got, want))
    return [] if ok and not paper else [f"layout.csv {got} is not the robot's layout {want}"]


def final_se(csv_dir):
    """{param: final standard error} from identify's params.csv ({} if unreadable)."""
    try:
        with open(os.path.join(csv_dir, "params.csv"), newline="") as f:
            return {r["param"]: float(r["se"]) for r in csv.DictReader(f)
                    if r["method"] == "final" and r["se"]}
    except (OSError, KeyError, ValueError):
        return {}


def validation_of(tool, params, vjson, log, vel):
    """Runs validate; returns ({axis: (e_max, sigma)}, None) or (None, failure message)."""
    status, msg = _tool([tool, "validate", "--params", params, "--json", vjson, log] + vel)
    if status != "ok":
        return None, (msg if status == "not started" else f"validate refused: {msg}")
    try:
        with open(vjson) as f:
            val = json.load(f)
        return {ax: (float(val[ax]["e_max"]), float(val[ax]["sigma"])) for ax in TABLE_IV}, None
    except (OSError, ValueError, KeyError, TypeError) as e:
        return None, f"validation JSON unreadable: {e}"


def ident_task(bin_dir, layout, entry, source, assert_params=True, val_fraction=1.0,
               wheel_tol=None, floor_sources=("camera",)):
    """Worker: identify + validate one log with one velocity source; returns a result dict.

    assert_params True: 2 % bound; "se": 2 % or 3 reported SE; False: the parameter errors are
    reported in the table, not counted as failures (validation bounds and refusals still are).
    val_fraction: validation bound as a fraction of Table IV (camera: never below 1.1 x the
    true parameters' figures on the same log)."""
    tool = os.path.join(bin_dir, "omni4-ident")
    stem = os.path.splitext(entry["log"])[0] + f"_{source}"
    params, vjson = stem + "_params.ini", stem + "_validate.json"
    vel = ["--velocity", "camera"] if source == "camera" else []
    out = {"layout": layout, "robot": entry["robot"], "source": source, "log": entry["log"],
           "base_layout": entry["base_layout"], "errors": {}, "validation": None,
           "offsets": None, "fail": []}
    csv_dir = stem + "_csv"
    status, msg = _tool([tool, "identify", "--robot", entry["base"], "--out", params,
                         entry["log"]] + vel + (["--csv", csv_dir] if csv_dir else []))
    if status == "not started":
        out["fail"].append(msg)
        return out
    if status != "ok" or not os.path.exists(params):
        out["fail"].append(f"identify refused the log: {msg or 'no params file'}")
        return out
    out["fail"] += check_layout_csv(csv_dir, entry["truth"])
    if "offsets" in entry["effects"]:
        out["offsets"] = check_offsets(csv_dir, entry)
        out["fail"] += out["offsets"]["fail"]
    se = final_se(csv_dir)
    est, truth = write_logs.read_ini(params), write_logs.read_ini(entry["truth"])
    for k in PARAMS:
        if k not in est:
            out["fail"].append(f"params.ini lacks {k}")
            continue
        e = 100.0 * (est[k] - truth[k]) / truth[k]
        out["errors"][k] = e
        if abs(e) <= PARAM_TOL_PCT or not assert_params:
            continue
        if assert_params == "se":
            z = abs(est[k] - truth[k]) / se[k] if se.get(k, 0) > 0 else float("inf")
            out.setdefault("z", {})[k] = z
            if z <= PARAM_TOL_SE:
                continue
            out["fail"].append(f"{k} off by {e:+.2f} % ({z:.1f} reported SE)")
        else:
            out["fail"].append(f"{k} off by {e:+.2f} %")
    werr, wfail = wheel_checks.wheel_errors(est, truth, wheel_tol)
    out["errors"].update(werr)
    out["fail"] += wfail
    out["validation"], msg = validation_of(tool, params, vjson, entry["log"], vel)
    if msg:
        out["fail"].append(msg)
        return out
    floor = None
    if source in floor_sources and val_fraction < 1.0:
        floor, msg = validation_of(tool, entry["truth"], stem + "_truth_validate.json",
                                   entry["log"], vel)
        if msg:
            out["fail"].append("validation with the true parameters: " + msg)
            return out
        out["validation_truth"] = floor
        for ax, (emax, sig) in floor.items():  # the true parameters reproduce the log
            if not (emax <= TABLE_IV[ax][0] and sig <= TABLE_IV[ax][1]):
                out["fail"].append(f"validate with the true parameters {ax}: e_max {emax:.4g}, "
                                   f"sigma {sig:.4g} beyond Table IV's {TABLE_IV[ax][0]:.4g}, "
                                   f"{TABLE_IV[ax][1]:.4g}")
    for ax, (emax, sig) in out["validation"].items():
        bmax, bsig = (val_fraction * b for b in TABLE_IV[ax])
        if floor:
            bmax, bsig = max(bmax, 1.1 * floor[ax][0]), max(bsig, 1.1 * floor[ax][1])
        if not emax <= bmax:
            out["fail"].append(f"validate {ax}: e_max {emax:.4g} > {bmax:.4g}")
        if not sig <= bsig:
            out["fail"].append(f"validate {ax}: sigma {sig:.4g} > {bsig:.4g}")
    return out


def run_all(a, work):
    """Generate all layouts and identify every log, `a.jobs` processes; returns results."""
    results, say = [], (lambda s: None) if a.quiet else (lambda s: print(s, flush=True))
    pending, per_log, gen_left = collections.Counter(), collections.Counter(), collections.Counter()
    order = sorted(a.layouts, key=lambda n: -COST.get(n, 1.0))
    robots = list(range(a.robots))
    with cf.ProcessPoolExecutor(max_workers=a.jobs) as pool:
        futs = {}
        for n, group in gen_chunks(order, robots, a.jobs):
            gen_left[n] += 1
            futs[pool.submit(gen_task, n, a.seed, group, work, a.pythonpath, a.sensors,
                             a.wheels, a.geometry, a.layout_from)] = "gen"
        while futs:
            done, _ = cf.wait(futs, return_when=cf.FIRST_COMPLETED)
            for fut in done:
                what = futs.pop(fut)
                if what == "gen":
                    try:
                        layout, entries, secs = fut.result()
                    except write_logs.LogError as e:
                        print(f"ident_indep: cannot write logs: {e}", file=sys.stderr)
                        raise SystemExit(2)
                    gen_left[layout] -= 1
                    say(f"ident_indep: {layout}: {len(entries)} logs written in {secs:.1f} s")
                    for entry in entries:
                        for src in SOURCES:
                            pending[layout] += 1
                            per_log[entry["log"]] += 1
                            check = True if src != "camera" else {
                                "assert": True, "report": False, "se": "se"}[a.camera_params]
                            frac = a.val_fraction[SOURCES.index(src)]
                            futs[pool.submit(ident_task, a.bin_dir, layout, entry, src, check,
                                             frac, a.wheel_tol, a.floor_sources)] = entry
                else:
                    r = fut.result()
                    results.append(r)
                    pending[r["layout"]] -= 1
                    if pending[r["layout"]] == 0 and gen_left[r["layout"]] == 0:
                        bad = sum(1 for x in results if x["layout"] == r["layout"] and x["fail"])
                        n = sum(1 for x in results if x["layout"] == r["layout"])
                        say(f"ident_indep: {r['layout']}: identified, {bad} of {n} cases failed")
                    per_log[r["log"]] -= 1
                    if per_log[r["log"]] == 0 and not a.keep:
                        os.remove(r["log"])           # saves disk: a layout's logs are ~2 GB
    return results


def fmt(v, bound=None, width=7, prec=2):
    """Table cell: value, '*' if above bound, '-' if missing."""
    if v is None:
        return "-".rjust(width)
    mark = "*" if bound is not None and not v <= bound else " "
    return f"{v:{width - 1}.{prec}f}{mark}"


def table_rows(results, names):
    """(label, results) rows: one per layout, and below a layout that mixes base layouts (the
    `sensors` layout) one per base layout, labelled ' :BASE'."""
    rows = []
    for n in names:
        rs = [r for r in results if r["layout"] == n]
        rows.append((n, rs))
        bases = sorted({r["base_layout"] for r in rs} - {n}, key=layouts.LAYOUTS.index)
        if bases:
            rows += [(f" :{b}", [r for r in rs if r["base_layout"] == b]) for b in bases]
    return rows


def print_tables(results, names, wheel_tol=None):
    """Worst |error| % per parameter / layout / source; worst validation beside Table IV."""
    rows = table_rows(results, names)
    w = max([11] + [len(label) for label, _ in rows])
    print(f"\nworst |error| % of the identified parameters (bound {PARAM_TOL_PCT:.0f} %, "
          "* = over; refused = identify refused the log)")
    cols = dict.fromkeys(PARAMS, PARAM_TOL_PCT)
    if any(k in r["errors"] for r in results for k in wheel_checks.WHEEL_TOL_PCT):
        cols.update(wheel_tol or wheel_checks.WHEEL_TOL_PCT)
    head = f"{'velocity':8} {'layout':{w}}" + "".join(f"{k:>8}" for k in cols) + "  refused"
    for src in SOURCES:
        print(head)
        for label, lrs in rows:
            rs = [r for r in lrs if r["source"] == src]
            cells = []
            for k, bound in cols.items():
                vals = [abs(r["errors"][k]) for r in rs if k in r["errors"]]
                cells.append(fmt(max(vals) if vals else None, bound, 8))
            refused = sum(1 for r in rs if any("identify refused" in f for f in r["fail"]))
            print(f"{src:8} {label:{w}}" + "".join(cells) + f"  {refused}/{len(rs)}")
    print("\nworst validation e_max / sigma per axis (paper's Table IV final in the header; "
          "* = over; no-val = validation not available: identify or validate refused)")
    head = f"{'velocity':8} {'layout':{w}}" + "".join(
        f"  {ax + ' e_max':>9} {'sigma':>7}" for ax in TABLE_IV) + "  no-val"
    iv = f"{'Table IV':{w + 9}}" + "".join(f"  {TABLE_IV[ax][0]:9.3f} {TABLE_IV[ax][1]:7.3f}"
                                          for ax in TABLE_IV)
    for src in SOURCES:
        print(head)
        print(iv)
        for label, lrs in rows:
            rs = [r for r in lrs if r["source"] == src]
            vals = [r["validation"] for r in rs if r["validation"]]
            cells = ""
            for ax in TABLE_IV:
                emax = max((v[ax][0] for v in vals), default=None)
                sig = max((v[ax][1] for v in vals), default=None)
                cells += "  " + fmt(emax, TABLE_IV[ax][0], 9, 4) + " " + fmt(sig, TABLE_IV[ax][1],
                                                                          7, 4)
            print(f"{src:8} {label:{w}}{cells}  {len(rs) - len(vals)}/{len(rs)}")


def print_offsets(results):
    """One paragraph on the current offset estimates of the logs that carry offsets."""
    rs = [r for r in results if r["offsets"] is not None]
    if not rs:
        return
    checked = [r for r in rs if r["offsets"]["status"] == "checked"]
    skipped = len(rs) - len(checked)
    print(f"\ncurrent offsets (logs with offsets: {len(rs)} cases):")
    if checked:
        worst = max(checked, key=lambda r: r["offsets"]["worst"] or 0.0)
        bad = sum(1 for r in checked if r["offsets"]["fail"])
        o = worst["offsets"]
        print(f"  compared with the sidecar in {len(checked)} cases, {bad} failed; worst "
              f"|est - true| {o['worst_ma']:.2f} mA = {o['worst']:.2f} x (3 SE + 1 mA) "
              f"(robot{worst['robot']} {worst['layout']} {worst['source']})"
              if o["worst"] is not None else
              f"  compared in {len(checked)} cases, {bad} failed (no estimates)")
    if skipped:
        print(f"  skipped in {skipped} cases: omni4-ident identify --csv wrote no {OFFSETS_CSV}")


def print_failures(results, quiet):
    """Failure reasons grouped by message, with the layouts and sources they occurred in."""
    groups = collections.defaultdict(list)
    for r in results:
        for f in r["fail"]:
            if " off by " in f and "(bound " in f:
                key = f.split(" off by ")[0] + " over its bound"
            elif " off by " in f:
                key = f.split(" off by ")[0] + f" more than {PARAM_TOL_PCT:.0f} % off"
            elif f.startswith("validate ") and (" e_max " in f or " sigma " in f):
                key = f.split(":")[0] + f":{f.split(':')[1].split()[0]} over Table IV"
            elif f.startswith("current offset motor "):
                key = "current offset estimate over 3 SE + 1 mA from the truth"
            else:
                key = f
            groups[key].append(r)
    if not groups:
        return
    print("\nfailures (grouped; count = cases):")
    for key, rs in sorted(groups.items(), key=lambda kv: -len(kv[1])):
        where = collections.Counter(f"{r['layout']}/{r['source']}" for r in rs)
        print(f"  {len(rs):4}  {key}")
        print("        in " + ", ".join(f"{w} {c}" for w, c in sorted(where.items())))
    if not quiet:
        print("\nfirst failing case per layout and source:")
        seen = set()
        for r in sorted(results, key=lambda r: (r["layout"], r["source"], r["robot"])):
            if r["fail"] and (r["layout"], r["source"]) not in seen:
                seen.add((r["layout"], r["source"]))
                print(f"  robot{r['robot']} {r['layout']} {r['source']}: " + "; ".join(r["fail"]))


def main(argv=None):
    ap = argparse.ArgumentParser(
        description=__doc__, formatter_class=argparse.RawDescriptionHelpFormatter,
        epilog="example:\n  .venv/bin/python tests/indep/test_ident_indep.py build/bin "
               "build/lcmtypes/gen/python --robots 4 --layouts runner,hand --keep /tmp/indep\n"
               f"layouts: {', '.join(layouts.LAYOUTS)} (all: all but sensors)")
    ap.add_argument("bin_dir", help="folder with omni4-ident")
    ap.add_argument("pythonpath", help="folder with the lcm-gen Python package omni4")
    ap.add_argument("--robots", type=int, default=20, help="robots per layout (default 20)")
    ap.add_argument("--layouts", default="all", help="comma-separated layouts (default all)")
    ap.add_argument("--jobs", type=int, default=2, help="parallel processes (default 2)")
    ap.add_argument("--seed", type=int, default=1, help="seed of robots and noise (default 1)")
    ap.add_argument("--keep", metavar="DIR", help="write logs, params and JSON here and keep them")
    ap.add_argument("--quiet", action="store_true", help="no progress lines, no per-case detail")
    ap.add_argument("--sensors", metavar="EFFECT[,EFFECT]",
                    help="real-sensor effects for every layout: offsets, eccentricity, jitter, "
                         "latency, losses, all or none (default: all for the sensors layout, "
                         "none otherwise)")
    ap.add_argument("--wheel-spread", metavar="R,KV,RADIUS", default="0,0,0",
                    help="per-wheel drives (write_logs.py --wheel-spread, per cent), e.g. 5,5,1;"
                         " then each R_j, Kv_j, Kt_j within 1 %% and r_j / mean r within 0.3 %% "
                         "(default 0,0,0: four equal drives)")
    ap.add_argument("--wheel-tol", metavar="R,KV,RADIUS",
                    help="bounds [%%] of each R_j, Kv_j (= Kt_j) and r_j / mean r (default "
                         "1,1,0.3)")
    ap.add_argument("--wheels", dest="wheels_n", type=int, choices=(3, 4),
                    help="the robots' wheels (write_logs.py --wheels; default 4)")
    ap.add_argument("--angles", metavar="A0,A1,..",
                    help="the wheels' angles [deg] (write_logs.py --angles; default the paper's)")
    ap.add_argument("--dist", metavar="D|D0,D1,..",
                    help="the wheels' distances [m] (write_logs.py --dist; default d); with "
                         "any of --wheels, --angles, --dist, identify gets the layout from a "
                         "robot file (base INI + the layout's keys)")
    ap.add_argument("--encoder-floor", action="store_true",
                    help="the encoder validation bound, like the camera's, never below 1.1 x "
                         "the true parameters' figures on the same log (a lost sample's "
                         "neighbour can set e_max whatever the model)")
    ap.add_argument("--layout-from", choices=("robot", "log"), default="robot",
                    help="where identify finds the wheel layout: a robot file (robot, default) "
                         "or the log's OMNI4_ROBOT (log)")
    ap.add_argument("--camera-params", choices=("assert", "se", "report"), default="assert",
                    help="with --velocity camera, assert the 2 %% parameter bound (default), "
                         "2 %% or 3 reported SE (se), or only report the errors (validation "
                         "is asserted either way)")
    ap.add_argument("--validation-fraction", metavar="ENC,CAM", default="1,1",
                    help="validation bounds as fractions of Table IV for the encoder and the "
                         "camera source (default 1,1; camera never below 1.1 x the true "
                         "parameters' figures when under 1)")
    a = ap.parse_args(argv)
    try:
        a.layouts = write_logs.parse_layouts(a.layouts.split(","))
        a.sensors = None if a.sensors is None else write_logs.parse_sensors(a.sensors)
        a.wheels = write_logs.parse_wheels(a.wheel_spread)
        a.geometry = write_logs.parse_geometry(a.wheels_n, a.angles, a.dist)
        a.floor_sources = ("camera", "encoder") if a.encoder_floor else ("camera",)
        a.wheel_tol = (wheel_checks.parse_tol(a.wheel_tol) if a.wheel_tol
                       else dict(wheel_checks.WHEEL_TOL_PCT))
        a.val_fraction = [float(x) for x in a.validation_fraction.split(",")]
        if len(a.val_fraction) != 2 or not all(0 < x <= 1 for x in a.val_fraction):
            raise ValueError("--validation-fraction takes two fractions in (0, 1]: ENC,CAM")
        if a.robots < 1 or a.jobs < 1:
            raise ValueError("--robots and --jobs must be at least 1")
        tool = os.path.join(a.bin_dir, "omni4-ident")
        if not os.access(tool, os.X_OK):
            raise ValueError(f"{tool} not found or not executable")
        write_logs.import_types(a.pythonpath)
    except (ValueError, write_logs.LogError) as e:
        print(f"ident_indep: {e}", file=sys.stderr)
        return 2
    t0 = time.time()
    if a.keep:
        os.makedirs(a.keep, exist_ok=True)
        results = run_all(a, os.path.abspath(a.keep))
    else:
        with tempfile.TemporaryDirectory(prefix="ident_indep_") as work:
            results = run_all(a, work)
    print("\nsensors: " + "; ".join(
        f"{n} {','.join(write_logs.effects_for(n, a.sensors)) or 'ideal'}" for n in a.layouts))
    if a.wheels:
        print("drives: each motor's R, Kv off by up to +-{:g} %, +-{:g} %, radii +-{:g} % (mean "
              "unchanged)".format(*(100 * v for v in a.wheels)))
    if a.geometry is not None:
        print(f"wheel layout: --wheels {a.wheels_n or 4} --angles {a.angles} --dist {a.dist}, "
              f"given to identify by the {a.layout_from}")
    print_tables(results, a.layouts, a.wheel_tol)
    print_offsets(results)
    print_failures(results, a.quiet)
    failed = sum(1 for r in results if r["fail"])
    print(f"\n{len(a.layouts)} layouts x {a.robots} robots x {len(SOURCES)} velocity sources in "
          f"{time.time() - t0:.0f} s")
    print(f"ident_indep: {len(results) - failed} passed, {failed} failed")
    return 1 if failed else 0


if __name__ == "__main__":
    sys.exit(main())
