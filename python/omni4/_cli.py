"""What every command of the package shares: --version, usage errors as one line, and a quiet
end on a closed pipe.

`omni4-param list | head -1`: when the reader goes away, the next write raises BrokenPipeError.
The command then ends as a C tool killed by SIGPIPE looks to the shell: no message, status 141
(128 + SIGPIPE), so `set -o pipefail` scripts see the output was cut, as with `yes | head`.
"""
import argparse
import os
import subprocess
import sys

from . import DEFAULT_LCM_URL, __version__

EXIT_BROKEN_PIPE = 141   # 128 + SIGPIPE: what the shell reports for a tool killed by it


class ArgumentParser(argparse.ArgumentParser):
    """A usage error is one line, `prog: message (try --help)`, and status 2."""

    def error(self, message):
        self.exit(usage(self.prog, message))


def add_lcm_option(parser, what="the robot's LCM URL"):
    """--lcm URL, by default DEFAULT_LCM_URL (omni4/channels.h), as every tool on the bus has it."""
    parser.add_argument("--lcm", default=DEFAULT_LCM_URL, metavar="URL",
                        help=f"{what} (default {DEFAULT_LCM_URL})")


def bus_tool_parser(prog, description, epilog):
    """The parser of a tool on the robot's bus: one-line usage errors, the epilog kept as
    written, and --lcm."""
    p = ArgumentParser(prog=prog, description=description, epilog=epilog,
                       formatter_class=argparse.RawDescriptionHelpFormatter)
    add_lcm_option(p)
    return p


def usage(prog, message):
    """A usage error found after parsing, as ArgumentParser.error words it: one line; returns
    the status 2."""
    sys.stderr.write(f"{prog}: {message} (try --help)\n")
    return 2


def version():
    """The package's version, with `git describe` appended when the package runs from a git
    checkout that has it (e.g. "0.1.0 (git v0.1-12-gabc1234-dirty)"); else the version alone."""
    here = os.path.dirname(os.path.abspath(__file__))
    try:
        r = subprocess.run(["git", "-C", here, "describe", "--always", "--dirty", "--tags"],
                           capture_output=True, text=True, timeout=2)
        if r.returncode == 0 and r.stdout.strip() and \
                os.path.exists(os.path.join(here, "..", "pyproject.toml")):
            return f"{__version__} (git {r.stdout.strip()})"
    except (OSError, subprocess.SubprocessError):
        pass
    return __version__


def print_version(prog):
    sys.stdout.write(f"{prog} {version()}\n")
    sys.stdout.flush()


def run(prog, main, argv=None):
    """main(argv) -> status, with `--version` answered first and a closed stdout (or stderr)
    ending the command quietly with EXIT_BROKEN_PIPE."""
    args = sys.argv[1:] if argv is None else list(argv)
    try:
        options = args[:args.index("--")] if "--" in args else args
        if "--version" in options:
            print_version(prog)
            return 0
        status = main(argv)
        sys.stdout.flush()
        return status
    except BrokenPipeError:
        # Python would flush stdout again at exit and print a second error: point it at
        # /dev/null first (the Python documentation's recipe, "Note on SIGPIPE").
        try:
            devnull = os.open(os.devnull, os.O_WRONLY)
            os.dup2(devnull, sys.stdout.fileno())
        except (OSError, ValueError):
            pass
        return EXIT_BROKEN_PIPE
