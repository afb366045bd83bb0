"""Per-wheel bounds of an identified [model] against the independent plant's truth.

Each motor's R_j and Kv_j (and Kt_j, = Kv_j) within 1 % of the truth; each wheel's radius
relative to the mean radius (r_j / mean r, the part the wheels' rigid-body consistency pins; the
mean is the measured r) within 0.3 % of the truth's. A wheel without its own key has the
scalar's value (the INI contract). Applies to robots whose truth has wheel keys.
"""
import plant

#: column -> bound [%] (the per-wheel identification's bounds; a caller may pass its own)
WHEEL_TOL_PCT = {"R_j": 1.0, "Kv_j": 1.0, "r_j/r": 0.3}


def parse_tol(text):
    """'2.5,0.7,0.015' -> {R_j, Kv_j, r_j/r: per cent}; raises ValueError."""
    try:
        v = [float(x) for x in str(text).split(",")]
    except ValueError:
        v = []
    if len(v) != 3 or not all(x > 0 for x in v):
        raise ValueError(f"--wheel-tol {text!r}: expected three positive per cents R,KV,RADIUS")
    return dict(zip(WHEEL_TOL_PCT, v))


def wheel_value(model, q, j):
    """Wheel j's value of q in a [model] dict: its own key, else the scalar."""
    return model.get(plant.wheel_key(q, j), model[q])


def relative_radii(model):
    """r_j / mean r (4,) of a [model] dict."""
    r = [wheel_value(model, "r", j) for j in range(4)]
    mean = sum(r) / 4.0
    return [v / mean for v in r]


def wheel_errors(est, truth, tol=None):
    """Worst |error| % per column and the failures (list of messages) of an identified [model]
    against the truth, bounds tol (default WHEEL_TOL_PCT); ({}, []) for a truth without wheel
    keys."""
    if not plant.has_wheels(truth):
        return {}, []
    tol = tol or WHEEL_TOL_PCT
    worst, fail = {k: 0.0 for k in WHEEL_TOL_PCT}, []
    for j in range(4):
        for q, col in (("R", "R_j"), ("Kv", "Kv_j"), ("Kt", "Kv_j")):
            t = wheel_value(truth, q, j)
            e = 100.0 * (wheel_value(est, q, j) - t) / t
            worst[col] = max(worst[col], abs(e))
            if not abs(e) <= tol[col]:
                fail.append(f"{q}_{j} off by {e:+.2f} % (bound {tol[col]:g} %)")
    for j, (e_rel, t_rel) in enumerate(zip(relative_radii(est), relative_radii(truth))):
        e = 100.0 * (e_rel - t_rel) / t_rel
        worst["r_j/r"] = max(worst["r_j/r"], abs(e))
        if not abs(e) <= tol["r_j/r"]:
            fail.append(f"r_{j} / mean r off by {e:+.4f} % (bound {tol['r_j/r']:g} %)")
    return worst, fail
