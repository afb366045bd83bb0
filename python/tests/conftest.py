"""Shared fixtures of the package's tests, and the LCM URL of a test."""
import os
import random

import pytest

# The tests' udpm ports: never LCM's and omni4's default 7667 (a robot on the default URL on
# this machine never meets a test), nor bench/'s 7700-7899. tests/hil/bounded_wait.sh
# (test_lcm_url) and tests/firmware/livebus.py draw from the same range.
TEST_PORTS = (7900, 10999)


def lcm_test_url():
    """A udpm URL of the caller's own (ttl=0, a random port of TEST_PORTS): every live test
    puts its programs on one (`--lcm URL`, `[lcm] url` in its INI); `from conftest import
    lcm_test_url`."""
    return f"udpm://239.255.76.67:{random.randint(*TEST_PORTS)}?ttl=0"


@pytest.fixture
def lcm_url():
    """lcm_test_url() for one test."""
    return lcm_test_url()


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
