"""Generates the LCM message modules (omni4/command_t.py, ...) from ../lcmtypes/*.lcm at build
time, so the .lcm files stay the only definition. lcm-gen is taken from $LCM_GEN, then PATH
(Debian's liblcm-bin or the lcm wheel both provide it)."""
import glob
import os
import shutil
import subprocess
import tempfile

from setuptools import setup
from setuptools.command.build_py import build_py

HERE = os.path.dirname(os.path.abspath(__file__))
LCM_DIR = os.path.join(HERE, "..", "lcmtypes")


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


setup(cmdclass={"build_py": BuildWithLcmTypes})
