"""What importing the package does to the process."""

import os
import subprocess
import sys


def _wait_policy(environment: dict[str, str]) -> str:
    code = "import os, sassi_bench; print(os.environ['OMP_WAIT_POLICY'])"
    done = subprocess.run(
        [sys.executable, "-c", code], env=environment, capture_output=True, text=True, check=True
    )
    return done.stdout.strip()


def test_openmp_threads_wait_passively_unless_the_user_says_otherwise():
    environment = {k: v for k, v in os.environ.items() if k != "OMP_WAIT_POLICY"}
    assert _wait_policy(environment) == "PASSIVE"
    assert _wait_policy({**environment, "OMP_WAIT_POLICY": "ACTIVE"}) == "ACTIVE"
