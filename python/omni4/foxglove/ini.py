"""The [model] section of a robot INI (docs/design.md: keys d r l Kv Kt R M J Bv Bvn Bw Cv Cvn Cw,
SI units, all or none; none = the paper's Table III, as in the firmware). Other sections are the
firmware's and are skipped. Errors are ConfigError("FILE:LINE: ...")."""
import ctypes
import sys
import math

from . import model


class ConfigError(Exception):
    pass


def table3():
    """The paper's Table III, read from model/ (model_params_table3)."""
    arr = (ctypes.c_double * len(model.PARAM_NAMES)).in_dll(model.lib(), "model_params_table3")
    return dict(zip(model.PARAM_NAMES, list(arr)))


def read_model(path):
    """[model] of the INI file at path -> dict of the 14 parameters."""
    try:
        with open(path, encoding="utf-8") as fh:
            lines = fh.read().splitlines()
    except (OSError, UnicodeDecodeError) as e:
        raise ConfigError(f"{path}: cannot read: {getattr(e, 'strerror', None) or e}") from None
    section = None
    found = {}
    first_line = None
    for no, raw in enumerate(lines, 1):
        line = raw.strip()
        for c in (" ;", "\t;", " #", "\t#"):  # inline comments, as inih
            if c in line:
                line = line[:line.index(c)].rstrip()
        if not line or line[0] in ";#":
            continue
        if line.startswith("["):
            if not line.endswith("]") or len(line) < 3:
                raise ConfigError(f"{path}:{no}: malformed section header '{raw.strip()}'")
            section = line[1:-1].strip()
            continue
        if "=" not in line and ":" not in line:
            raise ConfigError(f"{path}:{no}: expected 'key = value', got '{raw.strip()}'")
        if section is None:
            raise ConfigError(f"{path}:{no}: key outside a section")
        if section != "model":
            continue
        sep = "=" if "=" in line else ":"
        key, val = (s.strip() for s in line.split(sep, 1))
        if key not in model.PARAM_NAMES:
            raise ConfigError(f"{path}:{no}: unknown key '{key}' in [model] "
                              f"(expected {' '.join(model.PARAM_NAMES)})")
        if key in found:
            raise ConfigError(f"{path}:{no}: duplicate key '{key}' in [model]")
        try:
            x = float(val)
        except ValueError:
            raise ConfigError(f"{path}:{no}: [model] {key} = '{val}' is not a number") from None
        if not math.isfinite(x):
            raise ConfigError(f"{path}:{no}: [model] {key} = '{val}' is not finite")
        found[key] = x
        first_line = first_line or no
    if not found:
        return table3()
    missing = [k for k in model.PARAM_NAMES if k not in found]
    if missing:
        raise ConfigError(f"{path}:{first_line}: [model] lacks {' '.join(missing)} "
                          "(all 14 keys or none)")
    try:
        model.Predictor(found)
    except ValueError:
        raise ConfigError(f"{path}:{first_line}: [model] parameters are not physical "
                          "(a non-positive d r l Kv Kt R M J or a negative friction)") from None
    return found


def params_or_exit(prog, path):
    """--params of a command-line tool: the [model] of path (Table III if None); on a broken
    INI one line on stderr and exit status 2 (a configuration error)."""
    try:
        return read_model(path) if path else table3()
    except ConfigError as e:
        print(f"{prog}: {e}", file=sys.stderr)
        raise SystemExit(2) from None
