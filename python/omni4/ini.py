"""The robot INI (docs/configuration.md) for the Python tools: the one reader of the package.

configparser, as strict as omni4-fw's loader (config/): a repeated key is an error (and so is a
repeated section, in any position), keys keep their case (Kv, R), ';' and '#' start a comment on
a line of its own, ';' also after white space in a line (as in inih: a '#' there is part of the
value), no interpolation, no DEFAULT section. tests/config/ini_cases.txt is the table of cases
both readers run. What the keys mean is the caller's
business (omni4.foxglove.model reads [model]). Every error is one line, ConfigError("FILE:LINE:
..."), FILE alone when no line is to blame."""
import configparser
import re


class ConfigError(ValueError):
    """A robot INI that cannot be read or is malformed; the message is FILE[:LINE]: what."""


class Ini:
    """A read INI: sections[name][key] -> value text, and the line of each section and key."""

    def __init__(self, path, sections, lines):
        self.path = path
        self.sections = sections
        self._lines = lines

    def section(self, name):
        """{key: value} of section name ({} if the file has none)."""
        return dict(self.sections.get(name, {}))

    def line(self, section, key=None):
        """Line number of [section] (key None) or of its key; None if not in the file."""
        return self._lines.get((section, key))

    def where(self, section, key=None):
        """'FILE:LINE' of [section] or of its key for an error message ('FILE' if not there)."""
        no = self.line(section, key)
        return f"{self.path}:{no}" if no else str(self.path)


def _parser():
    p = configparser.ConfigParser(strict=True, interpolation=None, delimiters=("=", ":"),
                                  comment_prefixes=(";", "#"), inline_comment_prefixes=(";",),
                                  empty_lines_in_values=False, default_section="\0")
    p.optionxform = str  # keys are case-sensitive, as in the C loader
    return p


def _one_line(path, e, lines):
    """configparser's multi-line errors as one FILE:LINE line."""
    if isinstance(e, configparser.DuplicateOptionError):
        return f"{path}:{e.lineno}: duplicate key '{e.option}' in [{e.section}]"
    if isinstance(e, configparser.DuplicateSectionError):
        return f"{path}:{e.lineno}: duplicate section [{e.section}]"
    if isinstance(e, configparser.MissingSectionHeaderError):
        no = e.lineno
    else:  # ParsingError: the first line it could not parse
        no = e.errors[0][0]
    text = lines[no - 1].strip()
    if text.startswith("["):
        return f"{path}:{no}: malformed section header '{text}'"
    if isinstance(e, configparser.MissingSectionHeaderError):
        return f"{path}:{no}: key outside a section: '{text}'"
    return f"{path}:{no}: syntax error (expected [section] or key = value): '{text}'"


def _first_error(text, e):
    """The error of the earliest line: configparser raises a repeated section or key at once
    but a syntax error only at the end, so a repeat after a syntax error would hide it. The
    lines before the repeat, read again, have that syntax error if there is one."""
    if not isinstance(e, (configparser.DuplicateSectionError, configparser.DuplicateOptionError)):
        return e
    try:
        _parser().read_string("".join(text.splitlines(True)[:e.lineno - 1]))
    except configparser.ParsingError as earlier:
        return earlier
    except configparser.Error:
        pass
    return e


def _continuation(lines):
    """inih's continuation line: after a key, before the next [section], a line that starts with
    white space and is neither blank nor a comment (blank and comment lines between do not end
    the key). The C loader takes it as the key given again; configparser as part of the value,
    or after a blank or comment line as a new key. (line, section, key) of the first, or None."""
    section = key = None
    for no, raw in enumerate(lines, 1):
        text = raw.strip()
        if not text or text[0] in ";#":
            continue
        if key is not None and raw[0] in " \t":
            return no, section, key
        if text[0] == "[":
            section, key = text[1:].split("]", 1)[0], None
            continue
        m = re.match(r"([^=:]*?)\s*[=:]", text)
        if m and section is not None:
            key = m.group(1)
    return None


def _parse(path, text, lines):
    """text parsed by configparser (strict); ConfigError at its first error."""
    p = _parser()
    try:
        p.read_string(text, source=str(path))
    except configparser.Error as e:
        raise ConfigError(_one_line(path, _first_error(text, e), lines)) from None
    return p


def read(path):
    """The INI file at path as an Ini; ConfigError when it cannot be read or is malformed."""
    try:
        with open(path, encoding="utf-8-sig") as fh:  # a BOM skipped, as inih does
            text = fh.read()
    except (OSError, UnicodeDecodeError) as e:
        raise ConfigError(f"{path}: cannot read: {getattr(e, 'strerror', None) or e}") from None
    lines = text.splitlines()
    cont = _continuation(lines)
    if cont:  # an error before it is the first; else the key given again, as C says
        no, section, key = cont
        _parse(path, "".join(text.splitlines(True)[:no - 1]), lines)
        raise ConfigError(f"{path}:{no}: duplicate key '{key}' in [{section}]")
    p = _parse(path, text, lines)
    sections = {s: dict(p.items(s)) for s in p.sections()}
    return Ini(path, sections, _key_lines(p, lines))


def _key_lines(p, lines):
    """{(section, None): line, (section, key): line} by the parser's own patterns (the file is
    known to be well-formed: each key line starts a key of the section above it)."""
    out, section = {}, None
    for no, raw in enumerate(lines, 1):
        if not raw.strip() or raw.lstrip()[0] in ";#" or re.match(r"\s", raw):
            continue  # blank, comment, or a value's continuation line
        m = p.SECTCRE.match(raw)
        if m:
            section = m.group("header")
            out[(section, None)] = no
            continue
        m = p._optcre.match(raw)
        if m and section is not None:
            out.setdefault((section, p.optionxform(m.group("option").rstrip())), no)
    return out
