"""The robot's INI keys for the Python package, from the layers' key lists (the `*_keys.def` rows
that config/ assembles into the one key table, in the table's order): setup.py writes
omni4/_keys.py with python_module() when the package is built.

Each row starts `OMNI4_KEY(KIND, "section", "key", ...`; the generator takes kind, section and
key (defaults, ranges and rules stay C's: omni4-config-keys --json renders them). A row the
generator cannot read stops the build instead of going missing in Python."""
import os
import re

import gen_vocab  # beside this file

# The layers' key lists before the backends' (repository-relative).
LAYER_FILES = ("core/include/omni4/core/ctl_keys.def", "core/include/omni4/core/est_keys.def",
               "config/include/omni4/config/fw_keys.def")
KINDS = {"DBL": "double", "INT": "int", "BOOL": "bool", "STR": "string", "ENUM": "choice"}
_ROW = re.compile(r'^OMNI4_KEY\(\s*([A-Z]+)\s*,\s*"([a-z_]+)"\s*,\s*"([A-Za-z0-9_]+)"\s*,')


class KeyListError(ValueError):
    """A row of a key list the generator cannot read (PATH:LINE: ...)."""


def rows(text, path):
    """[(section, key, kind)] of one key list, in order."""
    out = []
    for no, line in enumerate(text.splitlines(), 1):
        if not line.startswith("OMNI4_KEY"):
            continue
        m = _ROW.match(line)
        if m is None or m.group(1) not in KINDS:
            raise KeyListError(f"{path}:{no}: not `OMNI4_KEY(KIND, \"section\", \"key\", ...`: "
                               f"{line}")
        out.append((m.group(2), m.group(3), KINDS[m.group(1)]))
    return out


def def_files(root):
    """The key lists in the order config/src/config.c includes them: the layers', then each
    backend's (backends.def's keys column, in its rows' order)."""
    backends = gen_vocab.read(root)["OMNI4_BACKEND"]
    return LAYER_FILES + tuple(f"drivers/include/omni4/drivers/{keys}" for _, _, _, keys, *_ in backends
                               if keys)


def all_rows(root):
    """Every key of the table, in its order; duplicates are an error."""
    out, seen = [], set()
    for rel in def_files(root):
        path = os.path.join(root, rel)
        with open(path, encoding="utf-8") as f:
            for row in rows(f.read(), path):
                if row[:2] in seen:
                    raise KeyListError(f"{path}: {row[0]}.{row[1]} listed twice")
                seen.add(row[:2])
                out.append(row)
    return out


def python_module(root):
    """The source of omni4/_keys.py for the repository at root."""
    keys = all_rows(root)
    lines = ['"""Generated from the key lists (*_keys.def) by python/setup.py when the package is '
             'built:\nedit those, not this file."""',
             "# (section, key, type) of every INI key, in the key table's order.",
             "KEYS = ("]
    lines += [f"    ({s!r}, {k!r}, {t!r})," for s, k, t in keys]
    lines += [")", "# The scalar [model] keys (the paper's model), in model_params_names order.",
              "# The layout's keys (wheels, wheel_angle_j, d_j; absent = the paper's layout).",
              "MODEL_LAYOUT_KEYS = tuple(k for s, k, _ in KEYS if s == 'model' and "
              "(k == 'wheels' or k.startswith(('wheel_angle_', 'd_'))))",
              "MODEL_KEYS = tuple(k for s, k, _ in KEYS if s == 'model' and '_' not in k and "
              "k not in MODEL_LAYOUT_KEYS)",
              "# Each drive's own r, Kv, Kt, R (r_0 .. R_3; optional, absent = the scalar).",
              "MODEL_WHEEL_KEYS = tuple(k for s, k, _ in KEYS if s == 'model' and '_' in k and "
              "k not in MODEL_LAYOUT_KEYS)", "",
              "__all__ = ['KEYS', 'MODEL_KEYS', 'MODEL_WHEEL_KEYS', 'MODEL_LAYOUT_KEYS']"]
    return "\n".join(lines) + "\n"
