"""omni4.foxglove: the robot in Foxglove, live (omni4-bridge, a Foxglove WebSocket server fed
from LCM) and from logs (omni4-mcap, LCM event logs to MCAP), with the model's prediction beside
the encoders' velocity. Topics and schemas: docs/design.md, "Foxglove topics"."""
import sys


def _missing_extra():
    """The name of a package of the 'foxglove' extra that is not installed, or None."""
    for name in ("foxglove", "orjson"):
        try:
            __import__(name)
        except ImportError:
            return name
    return None


def _run(prog, module):
    """--version (also without the extra) and a quiet status 141 on a closed stdout."""
    from .._cli import run

    def main(argv):
        missing = _missing_extra()
        if missing:
            print(f"{prog}: needs the Python package '{missing}' (pip install "
                  f"'./python[foxglove]')", file=sys.stderr)
            return 2
        from importlib import import_module
        return import_module(f"omni4.foxglove.{module}").main(argv)
    return run(prog, main)


def bridge_main():
    """Entry point of omni4-bridge: one line and status 2 without the foxglove extra."""
    return _run("omni4-bridge", "bridge")


def export_main():
    """Entry point of omni4-mcap: one line and status 2 without the foxglove extra."""
    return _run("omni4-mcap", "export")
