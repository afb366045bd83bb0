"""The tally the test scripts of tests/host share: check() prints one line, ok or FAIL, and
keeps each failure in `failures`; run() runs a program within a bound and raises RuntimeError
naming it and its last words when it fails. Standard library only."""
import subprocess

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
