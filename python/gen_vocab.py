"""The robot's vocabulary for the Python package and the docs, from core/include/omni4/core/vocab.def
(modes, fault bits, state flags, goal statuses and reasons) and drivers/include/omni4/drivers/backends.def (the backends): setup.py
writes omni4/_vocab.py with python_module() when the package is built, and
tests/host/check_vocab_doc.py compares docs/vocabulary.md with markdown().

Rows are one line each: `OMNI4_MODE(NAME, value, wire, drives, keep_alive, faulted, "doc")`,
`OMNI4_FAULT(NAME, bit, latching, "doc")`, `OMNI4_FLAG(NAME, bit, "doc")`,
`OMNI4_GOAL_STATUS(NAME, value, "doc")`, `OMNI4_GOAL_REASON(NAME, value, "doc")`,
`OMNI4_BACKEND(HAL, NAME, "word", "keys file", member, settings, state, "header", os, "provides")`. A row the generator cannot read stops the
build instead of going missing in Python."""
import os
import re

VOCAB_DEF = "core/include/omni4/core/vocab.def"
BACKENDS_DEF = "drivers/include/omni4/drivers/backends.def"
WIRES = ("CMD", "STATE", "BOTH")
_ROW = re.compile(r"^(OMNI4_[A-Z_]+)\((.*)\)\s*$")
_ARG = re.compile(r'\s*("(?:[^"\\]|\\.)*"|[^,]+?)\s*(?:,|$)')
_ARITY = {"OMNI4_MODE": 7, "OMNI4_FAULT": 4, "OMNI4_FLAG": 3, "OMNI4_BACKEND": 10,
          "OMNI4_GOAL_STATUS": 3, "OMNI4_GOAL_REASON": 3}


class VocabError(ValueError):
    """A row of a vocabulary file the generator cannot read (PATH:LINE: ...)."""


def _value(text, where):
    if text.startswith('"'):
        return text[1:-1].replace('\\"', '"').replace("\\\\", "\\")
    if re.fullmatch(r"[A-Z][A-Z0-9_]*|[a-z][a-z0-9_]*", text):
        return text
    try:
        return int(text, 0)
    except ValueError:
        raise VocabError(f"{where}: not a name, number or string: {text}") from None


def rows(text, path):
    """{macro: [tuple of values]} of one row file, in order (the #define lines are skipped)."""
    out = {m: [] for m in _ARITY}
    for no, line in enumerate(text.splitlines(), 1):
        if not line.startswith("OMNI4_"):
            continue
        m = _ROW.match(line)
        where = f"{path}:{no}"
        if m is None or m.group(1) not in _ARITY:
            raise VocabError(f"{where}: not a one-line OMNI4_MODE/FAULT/FLAG/GOAL_STATUS/GOAL_REASON/"
                              f"BACKEND row: {line}")
        args = [_value(a, where) for a in _ARG.findall(m.group(2))]
        if len(args) != _ARITY[m.group(1)]:
            raise VocabError(f"{where}: {m.group(1)} takes {_ARITY[m.group(1)]} columns, "
                             f"this row has {len(args)}: {line}")
        out[m.group(1)].append(tuple(args))
    return out


def _check(vocab, path):
    modes, faults = vocab["OMNI4_MODE"], vocab["OMNI4_FAULT"]
    for what, items in (("mode", [(n, v) for n, v, *_ in modes]),
                        ("fault", [(n, b) for n, b, *_ in faults]),
                        ("flag", [(n, b) for n, b, _ in vocab["OMNI4_FLAG"]]),
                        ("goal status", [(n, v) for n, v, _ in vocab["OMNI4_GOAL_STATUS"]]),
                        ("goal reason", [(n, v) for n, v, _ in vocab["OMNI4_GOAL_REASON"]])):
        names, values = [n for n, _ in items], [v for _, v in items]
        if len(set(names)) != len(names) or len(set(values)) != len(values):
            raise VocabError(f"{path}: a {what} name or value listed twice")
        if what in ("fault", "flag") and any(v <= 0 or v & (v - 1) for v in values):
            raise VocabError(f"{path}: a {what} value is not a single bit")
    for name, value, wire, *flags, _ in modes:
        if wire not in WIRES or not 0 <= value < 32 or any(f not in (0, 1) for f in flags):
            raise VocabError(f"{path}: mode {name}: wire CMD|STATE|BOTH, value 0..31, flags 0|1")


def read(root):
    """The vocabulary of the repository at root: {macro: rows} of both files."""
    out = {}
    for rel in (VOCAB_DEF, BACKENDS_DEF):
        path = os.path.join(root, rel)
        with open(path, encoding="utf-8") as f:
            for k, v in rows(f.read(), path).items():
                out.setdefault(k, []).extend(v)
    _check(out, VOCAB_DEF)
    return out


def python_module(root=None, vocab=None):
    """The source of omni4/_vocab.py for the repository at root (or an already read vocab)."""
    v = vocab if vocab is not None else read(root)
    modes, faults, flags = v["OMNI4_MODE"], v["OMNI4_FAULT"], v["OMNI4_FLAG"]
    lines = ['"""Generated from core/include/omni4/core/vocab.def and drivers/include/omni4/drivers/backends.def '
             'by\npython/setup.py when the package is built: edit those, not this file."""',
             "# name -> value of every mode; which ones command_t / motors_t carry, drive the "
             "bridges,\n# need keep-alive, are fault states.",
             "MODES = {" + ", ".join(f"{n!r}: {val}" for n, val, *_ in modes) + "}",
             "MODE_DOCS = {" + ", ".join(f"{val}: {d!r}" for _, val, *_, d in modes) + "}"]

    def pick(col):
        return "(" + "".join(f"{r[1]}, " for r in modes if col(r)) + ")"
    lines += [f"COMMAND_MODES = {pick(lambda r: r[2] in ('CMD', 'BOTH'))}",
              f"REPORTED_MODES = {pick(lambda r: r[2] in ('STATE', 'BOTH'))}",
              f"DRIVEN_MODES = {pick(lambda r: r[3])}",
              f"KEPT_ALIVE_MODES = {pick(lambda r: r[4])}",
              f"FAULTED_MODES = {pick(lambda r: r[5])}",
              "# name -> bit of every fault / state bit of motors_t.faults; the latching ones.",
              "FAULTS = {" + ", ".join(f"{n!r}: 0x{b:04x}" for n, b, *_ in faults) + "}",
              "FAULT_DOCS = {" + ", ".join(f"0x{b:04x}: {d!r}" for _, b, _, d in faults) + "}",
              f"LATCHING = 0x{sum(b for _, b, lat, _ in faults if lat):04x}",
              "# name -> bit of the estimator's state_t.flags.",
              "FLAGS = {" + ", ".join(f"{n!r}: 0x{b:02x}" for n, b, _ in flags) + "}",
              "# value -> name of goal_status_t.status; value -> (name, meaning) of its reason.",
              "GOAL_STATUSES = {" + ", ".join(f"{val}: {n!r}" for n, val, _ in v["OMNI4_GOAL_STATUS"])
              + "}",
              "GOAL_REASONS = {" + ", ".join(f"{val}: ({n!r}, {d!r})"
                                             for n, val, d in v["OMNI4_GOAL_REASON"]) + "}",
              "# (hal, INI word, keys file, what it provides) of every backend, in the enums' order.",
              "BACKENDS = (" + "".join(f"{_backend(r)!r}, " for r in v["OMNI4_BACKEND"]) + ")",
              "",
              _FUNCTIONS]
    return "\n".join(lines)


_FUNCTIONS = '''MODE_NAMES = {v: n for n, v in MODES.items()}
FAULT_BITS = sorted((b, n) for n, b in FAULTS.items())


def mode_name(mode):
    """The mode's name; UNKNOWN_<value> for a value that names no mode."""
    return MODE_NAMES.get(mode, f"UNKNOWN_{mode}")


def fault_names(bits):
    """The FAULT_* names (without the prefix) of the set bits, in bit order; the bits that name
    no fault as one UNKNOWN_0x.. entry."""
    names = [n for b, n in FAULT_BITS if bits & b]
    rest = bits & ~sum(b for b, _ in FAULT_BITS)
    return names + ([f"UNKNOWN_0x{rest:x}"] if rest else [])


def backend_words(hal):
    """The INI words of one HAL's backends ("motor", "lines"), in the enum's order."""
    return tuple(w for h, w, _, _ in BACKENDS if h == hal)


__all__ = ["MODES", "MODE_DOCS", "MODE_NAMES", "COMMAND_MODES", "REPORTED_MODES", "DRIVEN_MODES",
           "KEPT_ALIVE_MODES", "FAULTED_MODES", "FAULTS", "FAULT_DOCS", "FAULT_BITS", "LATCHING",
           "FLAGS", "GOAL_STATUSES", "GOAL_REASONS", "BACKENDS", "mode_name", "fault_names",
           "backend_words"]
'''


def _backend(row):
    """(hal, INI word, keys file, provides) of a backend row: the hal as its INI key."""
    return (row[0].lower(), row[2], row[3], row[-1])


def _yes(flag):
    return "yes" if flag else ""


def markdown(root=None, vocab=None):
    """The tables of docs/vocabulary.md (between its markers), from the row files."""
    v = vocab if vocab is not None else read(root)
    out = ["### Modes (`command_t.mode`, `motors_t.mode`)", "",
           "| mode | value | carried by | drives the bridges | needs keep-alive | fault state | "
           "what it does |", "|---|---|---|---|---|---|---|"]
    carried = {"CMD": "command_t", "STATE": "motors_t", "BOTH": "command_t, motors_t"}
    for name, val, wire, drives, keep, faulted, doc in v["OMNI4_MODE"]:
        out.append(f"| {name} | {val} | {carried[wire]} | {_yes(drives)} | {_yes(keep)} | "
                   f"{_yes(faulted)} | {doc} |")
    out += ["", "### Fault and state bits (`motors_t.faults`)", "",
            "| bit | name | latching | meaning |", "|---|---|---|---|"]
    out += [f"| 0x{b:04x} | {n} | {_yes(lat)} | {d.replace('|', chr(92) + '|')} |"
            for n, b, lat, d in v["OMNI4_FAULT"]]
    out += ["", "### Estimator flags (`state_t.flags`)", "", "| bit | name | meaning |",
            "|---|---|---|"]
    out += [f"| 0x{b:02x} | {n} | {d} |" for n, b, d in v["OMNI4_FLAG"]]
    out += ["", "### Goal statuses (`goal_status_t.status`)", "", "| value | name | meaning |",
            "|---|---|---|"]
    out += [f"| {val} | {n} | {d} |" for n, val, d in v["OMNI4_GOAL_STATUS"]]
    out += ["", "### Goal reasons (`goal_status_t.reason`)", "", "| value | name | meaning |",
            "|---|---|---|"]
    out += [f"| {val} | {n} | {d.replace('|', chr(92) + '|') or '–'} |"
            for n, val, d in v["OMNI4_GOAL_REASON"]]
    out += ["", "### Backends (`[hal] motor`, `[hal] lines`)", "",
            "| `[hal]` key | INI word | its keys | provides |", "|---|---|---|---|"]
    out += [f"| `{h}` | `{w}` | {f'`{k}`' if k else '–'} | {p} |"
            for h, w, k, p in map(_backend, v["OMNI4_BACKEND"])]
    return "\n".join(out) + "\n"
