"""The type stubs match the compiled module (mypy's stubtest)."""

import subprocess
import sys

import pytest

pytest.importorskip("mypy")


def test_stubs_match_the_compiled_module():
    result = subprocess.run(
        [sys.executable, "-m", "mypy.stubtest", "remembrane._core"],
        capture_output=True,
        text=True,
    )
    assert result.returncode == 0, result.stdout + result.stderr


def test_the_package_type_checks():
    result = subprocess.run(
        [sys.executable, "-m", "mypy", "--ignore-missing-imports", "-p", "remembrane"],
        capture_output=True,
        text=True,
    )
    assert result.returncode == 0, result.stdout + result.stderr
