"""The Python constants of lcmtypes/include/omni4/lcmtypes/channels.h (the only place the channel names,
the end mark and the default LCM URL are written): setup.py writes omni4/_channels.py with
python_module() when the package is built, and the tests check the generator itself.

Every `#define OMNI4_NAME "text"` of the header becomes NAME = "text" (its trailing /* comment */
kept as a comment); the include guard is the only other #define allowed, so a constant the
generator cannot carry over (a number, a macro, an escape sequence) stops the build instead of
going missing in Python."""
import re

_STRING_DEFINE = re.compile(
    r'#\s*define\s+OMNI4_([A-Z][A-Z0-9_]*)\s+"([^"\\]*)"\s*(?:/\*\s*(.*?)\s*\*/)?\s*$')
_DEFINE = re.compile(r"#\s*define\b")
_IFNDEF = re.compile(r"#\s*ifndef\s+(\w+)\s*$")


class HeaderError(ValueError):
    """A line of the header the generator cannot turn into a Python constant (PATH:LINE: ...)."""


def constants(text, path="channels.h"):
    """[(NAME, text, comment or "")] of the header's string #defines, in header order."""
    out, seen, guard = [], set(), None
    for no, line in enumerate(text.splitlines(), 1):
        line = line.strip()
        g = _IFNDEF.match(line)
        if g and guard is None:
            guard = g.group(1)
        if not _DEFINE.match(line) or re.fullmatch(rf"#\s*define\s+{guard}", line):
            continue
        m = _STRING_DEFINE.match(line)
        if m is None:
            raise HeaderError(f"{path}:{no}: not `#define OMNI4_NAME \"text\"`, which the "
                              f"Python package could not carry over: {line}")
        name, value, comment = m.groups()
        if name in seen:
            raise HeaderError(f"{path}:{no}: OMNI4_{name} defined twice")
        seen.add(name)
        out.append((name, value, comment or ""))
    if not out:
        raise HeaderError(f"{path}: no `#define OMNI4_NAME \"text\"` in it")
    return out


def python_module(text, path="channels.h"):
    """The source of omni4/_channels.py for the header text (path names it in errors)."""
    lines = [f'"""Generated from lcmtypes/include/omni4/lcmtypes/channels.h by python/setup.py when the '
             'package is built:\nedit the header, not this file."""']
    consts = constants(text, path)
    for name, value, comment in consts:
        lines.append(f"{name} = {value!r}" + (f"  # {comment}" if comment else ""))
    lines.append("")
    lines.append("__all__ = [" + ", ".join(repr(n) for n, _, _ in consts) + "]")
    return "\n".join(lines) + "\n"
