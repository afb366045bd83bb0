"""Generates, at build time, what the package takes from the rest of the repository so that each
fact stays written once: the LCM message modules (omni4/command_t.py, ...) from
../lcmtypes/*.lcm with lcm-gen, and the channel names and default LCM URL (omni4/_channels.py)
from ../lcmtypes/include/omni4/lcmtypes/channels.h (gen_channels.py), and the INI key list (omni4/_keys.py)
from the layers' *_keys.def (gen_keys.py), and the modes, fault bits, flags and backends
(omni4/_vocab.py) from core/'s vocab.def and drivers/' backends.def (gen_vocab.py).

lcm-gen is taken from $LCM_GEN, then beside the Python that builds (the lcm wheel of the
environment the package goes into), then PATH (Debian's liblcm-bin). It must be 1.4 or newer:
omni4/_layout.py reads the wire layout from the __typenames__ and __dimensions__ that newer
lcm-gen writes into every class."""
import glob
import os
import shutil
import subprocess
import sys
import tempfile

from setuptools import Extension, setup
from setuptools.command.build_py import build_py

HERE = os.path.dirname(os.path.abspath(__file__))
LCM_DIR = os.path.join(HERE, "..", "lcmtypes")
CHANNELS_H = os.path.join(LCM_DIR, "include", "omni4", "lcmtypes", "channels.h")
MODEL_DIR = os.path.join(HERE, "..", "model")
CORE_INCLUDE = os.path.join(HERE, "..", "core", "include")  # omni4/core/vocab.h (mode_drives)

sys.path.insert(0, HERE)
import gen_channels  # noqa: E402  (beside this file; not part of the package)
import gen_keys  # noqa: E402
import gen_vocab  # noqa: E402


def find_lcm_gen():
    beside_python = os.path.join(os.path.dirname(sys.executable), "lcm-gen")
    for cand in (os.environ.get("LCM_GEN"), beside_python, shutil.which("lcm-gen")):
        if cand and os.access(cand, os.X_OK):
            return cand
    raise SystemExit("omni4: lcm-gen not found (pip install 'lcm>=1.4', or set LCM_GEN)")


class BuildWithLcmTypes(build_py):
    def run(self):
        super().run()
        lcm_files = sorted(glob.glob(os.path.join(LCM_DIR, "*.lcm")))
        if not lcm_files or not os.path.exists(CHANNELS_H):
            raise SystemExit(f"omni4: no .lcm files or channels.h in {LCM_DIR} "
                             "(build from the repository)")
        out = os.path.join(self.build_lib, "omni4")
        os.makedirs(out, exist_ok=True)
        lcm_gen = find_lcm_gen()
        with tempfile.TemporaryDirectory() as tmp:
            subprocess.run([lcm_gen, "--python", "--ppath", tmp, *lcm_files], check=True, timeout=60)
            # lcm-gen's own omni4/__init__.py is replaced by the package's.
            for src in glob.glob(os.path.join(tmp, "omni4", "*_t.py")):
                with open(src, encoding="utf-8") as f:
                    if "__typenames__" not in f.read():
                        raise SystemExit(f"omni4: {lcm_gen} writes no __typenames__ (older than "
                                         "1.4): pip install 'lcm>=1.4', or set LCM_GEN")
                shutil.copy(src, out)
        with open(CHANNELS_H, encoding="utf-8") as f:
            try:
                source = gen_channels.python_module(f.read(), CHANNELS_H)
            except gen_channels.HeaderError as e:
                raise SystemExit(f"omni4: {e}") from None
        with open(os.path.join(out, "_channels.py"), "w", encoding="utf-8") as f:
            f.write(source)
        for name, gen in (("_keys.py", gen_keys.python_module),
                          ("_vocab.py", gen_vocab.python_module)):
            try:
                source = gen(os.path.join(HERE, ".."))
            except (OSError, gen_keys.KeyListError, gen_vocab.VocabError) as e:
                raise SystemExit(f"omni4: {e}") from None
            with open(os.path.join(out, name), "w", encoding="utf-8") as f:
                f.write(source)


# The robot model (model/src/*.c, C11, no Python API) and the prediction shim of omni4.foxglove
# as one plain shared library that omni4.foxglove.model loads with ctypes: the bridge and the
# MCAP export run the project's own model, not a re-derivation in Python. (setuptools wants
# source paths relative to this directory.)
MODEL_LIB = Extension(
    "omni4.foxglove._omni4model",
    sources=[os.path.relpath(f, HERE) for f in sorted(glob.glob(os.path.join(MODEL_DIR, "src", "*.c")))]
    + ["omni4/foxglove/_predict.c"],
    include_dirs=[os.path.relpath(os.path.join(MODEL_DIR, "include"), HERE),
                  os.path.relpath(CORE_INCLUDE, HERE)],
    extra_compile_args=["-std=c11", "-O2"],
    libraries=["m"],
)

# The event-log walk of omni4.read_log (omni4/_logwalk.c), loaded with ctypes by omni4/log.py.
LOG_LIB = Extension(
    "omni4._omni4log",
    sources=["omni4/_logwalk.c"],
    extra_compile_args=["-std=c11", "-O2"],
)

setup(cmdclass={"build_py": BuildWithLcmTypes}, ext_modules=[MODEL_LIB, LOG_LIB])
