"""The tally the test scripts of tests/host share: check() prints one line, ok or FAIL, and
keeps each failure in `failures`; run() runs a program within a bound and raises RuntimeError
naming it and its last words when it fails; read_ini(), write() and workdir() for their files.
Standard library only."""
import configparser
import contextlib
import os
import subprocess
import tempfile

TIMEOUT_S = 120
failures = []


def check(ok, what):
    print(("ok   " if ok else "FAIL ") + what)
    if not ok:
        failures.append(what)


def run(cmd, cwd, timeout_s=TIMEOUT_S):
    p = subprocess.run(cmd, cwd=cwd, capture_output=True, text=True, timeout=timeout_s)
    if p.returncode != 0:
        raise RuntimeError(f"{' '.join(cmd)}: exit {p.returncode}: {p.stderr.strip()[-400:]}")
    return p.stdout


def read_ini(path, section):
    """{key: float} of one section of an INI file ({} if it has no such section)."""
    c = configparser.ConfigParser(inline_comment_prefixes=(";",))
    c.optionxform = str
    c.read(path)
    return {k: float(v) for k, v in c[section].items()} if c.has_section(section) else {}


def write(d, name, text):
    with open(os.path.join(d, name), "w") as f:
        f.write(text)


@contextlib.contextmanager
def workdir(keep):
    """A temporary folder for a script's files, or the folder `keep` (made, and kept)."""
    with tempfile.TemporaryDirectory() as tmp:
        d = os.path.abspath(keep) if keep else tmp
        os.makedirs(d, exist_ok=True)
        yield d
