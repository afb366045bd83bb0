"""The report's per-wheel section: each motor's R_j and Kv_j, each wheel's radius relative to
the mean and r_j, with standard errors and the truth where omni4-ident was given one (wheels.csv
of `omni4-ident identify --csv`)."""
import csv
import os

QUANTITIES = (("R", "R_j [ohm]", "{:.4f}"), ("Kv", "Kv_j = Kt_j [V s/rad]", "{:.5f}"),
              ("rho", "r_j / mean r", "{:.5f}"), ("r", "r_j [m]", "{:.6f}"))


def read_wheels(csv_dir):
    """{(wheel, quantity): (value or None, se or None, true or None)}; {} without the file."""
    path = os.path.join(csv_dir, "wheels.csv")
    if not os.path.exists(path):
        return {}

    def num(s):
        return float(s) if s not in ("", "nan") else None
    with open(path, newline="") as f:
        return {(int(r["wheel"]), r["quantity"]): (num(r["value"]), num(r["se"]), num(r["true"]))
                for r in csv.DictReader(f)}


def cell(v, fmt):
    value, se, true = v
    if value is None:
        return "-"
    s = fmt.format(value) + (f" ± {se:.2g}" if se is not None else "")
    if true:
        s += f" ({100 * (value / true - 1):+.2f} %)"
    return s


def wheels_section(csv_dir):
    """Markdown lines (empty without wheels.csv)."""
    w = read_wheels(csv_dir)
    if not w:
        return []
    lines = ["## Per wheel", "",
             "| wheel | " + " | ".join(q[1] for q in QUANTITIES) + " |",
             "|---" * (len(QUANTITIES) + 1) + "|"]
    for j in range(4):
        cells = [cell(w.get((j, q), (None, None, None)), fmt) for q, _, fmt in QUANTITIES]
        lines.append(f"| {j} | " + " | ".join(cells) + " |")
    return lines + ["", "± standard error; (error to the truth) where one was given. R_j, Kv_j: "
                    "each motor's own fit of eq 22; radii: relative to their mean from the "
                    "wheels' rigid-body consistency (r_j only where the radii differ). "
                    "params.ini holds wheel keys only where the motors or the radii differ "
                    "(omni4-ident's printout gives the tests).", ""]
