"""Generates the LCM message modules (omni4/command_t.py, ...) from ../lcmtypes/*.lcm at build
time, so the .lcm files stay the only definition. lcm-gen is taken from $LCM_GEN, then PATH
(Debian's liblcm-bin or the lcm wheel both provide it)."""
import glob
import os
import shutil
import subprocess
import tempfile

from setuptools import Extension, setup
from setuptools.command.build_py import build_py

HERE = os.path.dirname(os.path.abspath(__file__))
LCM_DIR = os.path.join(HERE, "..", "lcmtypes")
MODEL_DIR = os.path.join(HERE, "..", "model")


class BuildWithLcmTypes(build_py):
    def run(self):
        super().run()
        lcm_files = sorted(glob.glob(os.path.join(LCM_DIR, "*.lcm")))
        if not lcm_files:
            raise SystemExit(f"omni4: no .lcm files in {LCM_DIR} (build from the repository)")
        lcm_gen = os.environ.get("LCM_GEN") or shutil.which("lcm-gen")
        if not lcm_gen:
            raise SystemExit("omni4: lcm-gen not found (apt-get install liblcm-bin, or set LCM_GEN)")
        with tempfile.TemporaryDirectory() as tmp:
            subprocess.run([lcm_gen, "--python", "--ppath", tmp, *lcm_files], check=True, timeout=60)
            out = os.path.join(self.build_lib, "omni4")
            os.makedirs(out, exist_ok=True)
            # lcm-gen's own omni4/__init__.py is replaced by the package's.
            for src in glob.glob(os.path.join(tmp, "omni4", "*_t.py")):
                shutil.copy(src, out)


# The robot model (model/src/*.c, C11, no Python API) and the prediction shim of omni4.foxglove
# as one plain shared library that omni4.foxglove.model loads with ctypes: the bridge and the
# MCAP export run the project's own model, not a re-derivation in Python. (setuptools wants
# source paths relative to this directory.)
MODEL_LIB = Extension(
    "omni4.foxglove._omni4model",
    sources=[os.path.relpath(f, HERE) for f in sorted(glob.glob(os.path.join(MODEL_DIR, "src", "*.c")))]
    + ["omni4/foxglove/_predict.c"],
    include_dirs=[os.path.relpath(os.path.join(MODEL_DIR, "include"), HERE)],
    extra_compile_args=["-std=c11", "-O2"],
    libraries=["m"],
)

setup(cmdclass={"build_py": BuildWithLcmTypes}, ext_modules=[MODEL_LIB])
