#!/usr/bin/env python3
"""The report's wheel layout (host-tools/plots/report_layout.py) against the layout it was given.

usage: report_layout_check.py

A CSV folder with layout.csv of three wheels at 60/180/300 deg and 0.09/0.1/0.085 m (as
omni4-ident identify --csv writes it for a layout other than the paper's): report.md's
"Wheel layout" table holds each wheel's angle and distance, layout.png is written and shown;
a folder without layout.csv (the paper's layout) gets no layout section and no figure. A
layout.csv with a value that is not a number ends the report with a non-zero status.
Prints one line per check; exit status 0 when all pass, 1 otherwise.
"""
import os
import re
import subprocess
import sys
import tempfile

from script_checks import check, failures  # (this script's folder)

ROOT = os.path.join(os.path.dirname(os.path.abspath(__file__)), "..", "..")
REPORT = os.path.join(ROOT, "host-tools", "plots", "omni4_report.py")
LAYOUT = [(0, 60.0, 0.09), (1, 180.0, 0.1), (2, 300.0, 0.085)]


def report(csv_dir, out_dir, layout=None):
    os.makedirs(csv_dir, exist_ok=True)
    if layout is not None:
        with open(os.path.join(csv_dir, "layout.csv"), "w") as f:
            f.write("wheel,angle_deg,d_m\n" + "".join(f"{j},{a},{d}\n" for j, a, d in layout))
    return subprocess.run([sys.executable, REPORT, csv_dir, out_dir], capture_output=True,
                          text=True, timeout=120)


def main():
    with tempfile.TemporaryDirectory(prefix="report_layout_") as tmp:
        p = report(os.path.join(tmp, "three"), os.path.join(tmp, "out3"), LAYOUT)
        check(p.returncode == 0, f"report of a three-wheel layout: exit {p.returncode} "
              f"{p.stderr.strip()[-300:]}")
        md = open(os.path.join(tmp, "out3", "report.md")).read() if p.returncode == 0 else ""
        rows = re.findall(r"^\| (\d) \| ([-0-9.e]+) \| ([-0-9.e]+) \|$", md, re.M)
        got = [(int(j), float(a), float(d)) for j, a, d in rows]
        check(got == LAYOUT, f"the layout table {got} is the given layout {LAYOUT}")
        png = os.path.join(tmp, "out3", "layout.png")
        check(os.path.exists(png) and os.path.getsize(png) > 2000 and "(layout.png)" in md,
              "layout.png written and shown in report.md")
        p = report(os.path.join(tmp, "paper"), os.path.join(tmp, "outp"))
        md = open(os.path.join(tmp, "outp", "report.md")).read() if p.returncode == 0 else ""
        check(p.returncode == 0 and "Wheel layout" not in md and
              not os.path.exists(os.path.join(tmp, "outp", "layout.png")),
              "no layout.csv (the paper's layout): no layout section, no figure")
        p = report(os.path.join(tmp, "bad"), os.path.join(tmp, "outb"), [(0, "x", 0.09)])
        check(p.returncode != 0 and "layout.csv line 2" in p.stderr and
              len(p.stderr.strip().splitlines()) == 1,
              f"a layout angle that is not a number: exit {p.returncode}, one line: "
              f"{p.stderr.strip()[-200:]}")
    return 1 if failures else 0


if __name__ == "__main__":
    sys.exit(main())
