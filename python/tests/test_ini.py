"""omni4.ini: the one robot INI reader of the package, strict as omni4-fw's loader."""
import pathlib

import pytest

from omni4 import ini

CASES = pathlib.Path(__file__).resolve().parents[2] / "tests" / "config" / "ini_cases.txt"


def shared_cases():
    """tests/config/ini_cases.txt, the table omni4-fw's loader runs too (test_config): one
    (table line, accept, line, text expected, INI text) per case."""
    out, case = [], None
    for no, raw in enumerate(CASES.read_text().splitlines(True), 1):
        if raw.startswith("=== "):
            words = raw.split(maxsplit=3)
            accept = words[1] == "accept"
            rest = raw.rstrip("\n").split(" ", 2 if accept else 3)
            case = [no, accept, 0 if accept else int(words[2]),
                    rest[-1] if len(rest) > (2 if accept else 3) else "", ""]
            out.append(case)
        elif case is not None:
            case[4] += raw
    return [pytest.param(*c, id=f"ini_cases.txt:{c[0]}") for c in out]


@pytest.mark.parametrize("at, accept, line, expected, text", shared_cases())
def test_shared_ini_cases(tmp_path, at, accept, line, expected, text):
    p = write(tmp_path, text, name="case.ini")
    if accept:
        f = ini.read(p)
        if expected:  # "section.key value"
            dotted, value = expected.split(" ", 1)
            section, key = dotted.split(".")
            assert f.section(section).get(key) == value, at
        return
    with pytest.raises(ini.ConfigError) as e:
        ini.read(p)
    where = f"{p}:{line}: "
    assert str(e.value).startswith(where) and expected in str(e.value)[len(where):], at


def write(tmp_path, text, name="robot.ini", mode="w"):
    p = tmp_path / name
    p.write_bytes(text) if mode == "wb" else p.write_text(text)
    return str(p)


def test_sections_keys_lines_and_comments(tmp_path):
    p = write(tmp_path, "; robot\n\n[model]\nKv = 0.0259 ; inline\nR: 4.3 ; also inline\n"
                        "# comment\n[lcm]\nurl = udpm://239.255.76.67:7000?ttl=0\n")
    f = ini.read(p)
    assert f.sections == {"model": {"Kv": "0.0259", "R": "4.3"},
                          "lcm": {"url": "udpm://239.255.76.67:7000?ttl=0"}}
    assert (f.line("model"), f.line("model", "Kv"), f.line("model", "R"), f.line("lcm", "url")) \
        == (3, 4, 5, 8)
    assert f.where("model", "R") == f"{p}:5" and f.where("model", "kv") == p  # keys keep case
    assert f.section("none") == {} and f.section("model") is not f.sections["model"]


@pytest.mark.parametrize("text, msg", [
    ("[a]\nk = 1\nk = 2\n", ":3: duplicate key 'k' in [a]"),
    ("[a]\nk = 1\n[b]\n[a]\nj = 2\n", ":4: duplicate section [a]"),
    ("[a\nk = 1\n", ":1: malformed section header '[a'"),
    ("[a]\nk = 1\n[b\n", ":3: malformed section header '[b'"),
    ("k = 1\n[a]\n", ":1: key outside a section: 'k = 1'"),
    ("[a]\nk = 1\njust words\n", ":3: syntax error (expected [section] or key = value): "
                                 "'just words'"),
])
def test_errors_are_one_line_with_file_and_line(tmp_path, text, msg):
    p = write(tmp_path, text)
    with pytest.raises(ini.ConfigError) as e:
        ini.read(p)
    assert str(e.value) == p + msg


def test_unreadable_files(tmp_path):
    with pytest.raises(ini.ConfigError, match=r"none\.ini: cannot read: No such file"):
        ini.read(str(tmp_path / "none.ini"))
    p = write(tmp_path, b"[a]\nk = \xff\n", mode="wb")
    with pytest.raises(ini.ConfigError, match="robot.ini: cannot read: .*utf-8"):
        ini.read(p)
    with pytest.raises(ini.ConfigError, match="cannot read"):
        ini.read(str(tmp_path))


def test_a_utf8_bom_is_skipped_as_inih_does(tmp_path):
    f = ini.read(write(tmp_path, b"\xef\xbb\xbf[lcm]\nurl = x\n", mode="wb"))
    assert f.sections == {"lcm": {"url": "x"}} and f.line("lcm") == 1
    with pytest.raises(ini.ConfigError, match=r":2: duplicate section \[lcm\]$"):
        ini.read(write(tmp_path, b"\xef\xbb\xbf[lcm]\n[lcm]\n", mode="wb"))


def test_no_default_section_and_no_interpolation(tmp_path):
    f = ini.read(write(tmp_path, "[DEFAULT]\nk = 1\n[a]\nj = %(k)s 100%\n"))
    assert f.sections == {"DEFAULT": {"k": "1"}, "a": {"j": "%(k)s 100%"}}
