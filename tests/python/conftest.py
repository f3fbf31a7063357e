"""Fixtures of the Python module's tests: the repository, and the CLI built from it (the
reference every "same as the CLI" test compares with)."""

import os
import pathlib
import subprocess

import pytest

REPO = pathlib.Path(__file__).resolve().parents[2]


@pytest.fixture(scope="session")
def repo():
    return REPO


@pytest.fixture(scope="session")
def cli_path():
    path = pathlib.Path(os.environ.get("ISOVIEW_CLI", REPO / "target" / "debug" / "isoview"))
    if not path.is_file():
        pytest.fail(f"{path}: the CLI is not built (tests/python/run builds it; or set "
                    "ISOVIEW_CLI)")
    return path


@pytest.fixture
def cli(cli_path):
    """Runs `isoview ARGS...` from the repository root; returns the CompletedProcess."""

    def run(*args, check=True):
        p = subprocess.run([str(cli_path), *map(str, args)], cwd=REPO, capture_output=True,
                           text=True)
        if check and p.returncode != 0:
            raise AssertionError(f"isoview {' '.join(map(str, args))}: exit {p.returncode}: "
                                 f"{p.stderr}")
        return p

    return run
