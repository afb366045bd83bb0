"""Shared fixtures of the package's tests."""
import os

import pytest


@pytest.fixture(scope="session")
def omni4_bin():
    """omni4_bin(NAME): the path of a program of the build in $OMNI4_BIN (CTest sets it to
    <build>/bin); skips the test when OMNI4_BIN is unset, fails when the program is missing."""
    d = os.environ.get("OMNI4_BIN")
    if not d:
        pytest.skip("OMNI4_BIN (the build's bin folder) is not set")

    def path(name):
        p = os.path.join(d, name)
        assert os.access(p, os.X_OK), f"{p}: not built"
        return p
    return path
