"""Fixtures shared by the output and cache tests (a tiny file system that can be filled up) and by
the tracker tests (both engines)."""

import os
import subprocess
import sys
from pathlib import Path

import pytest

# Tests take helpers from one another by module name (``from test_modes import watt_sixbar``):
# every tests/<package>/ folder is on sys.path, as tests/ itself is (test file names are unique).
for _folder in sorted(Path(__file__).parent.iterdir()):
    if _folder.is_dir() and _folder.name not in ("data", "__pycache__") and str(_folder) not in sys.path:
        sys.path.insert(0, str(_folder))


@pytest.fixture
def tiny_fs(tmp_path):
    """A 64 KiB tmpfs (needs root); skipped with the reason where mounting is not permitted."""
    mnt = tmp_path / "tiny"
    mnt.mkdir()
    proc = subprocess.run(["mount", "-t", "tmpfs", "-o", "size=64k", "tmpfs", str(mnt)], capture_output=True,
                          text=True)
    if proc.returncode != 0:
        pytest.skip(f"cannot mount a small tmpfs to simulate a full disk: {proc.stderr.strip() or 'not root'}")
    try:
        yield mnt
    finally:
        subprocess.run(["umount", "-l", str(mnt)], check=False)


def fill_disk(directory) -> None:
    """Write zeros to ``directory/filler`` until the file system is full."""
    fd = os.open(directory / "filler", os.O_WRONLY | os.O_CREAT, 0o600)
    try:
        while True:
            os.write(fd, b"\0" * 1024)
    except OSError:
        pass
    finally:
        os.close(fd)


@pytest.fixture
def filler():
    """:func:`fill_disk`, for tests that write their files before the disk fills."""
    return fill_disk


@pytest.fixture
def full_fs(tiny_fs):
    """The tiny tmpfs, already full."""
    fill_disk(tiny_fs)
    return tiny_fs


@pytest.fixture(scope="module", params=["python", "numba"])
def both_engines(request):
    """Every test of a module that uses it (``pytestmark = pytest.mark.usefixtures("both_engines")``)
    runs twice: with the pure-Python tracer and with the compiled fast lane (``LOOPSOLVE_ENGINE``)."""
    if request.param == "numba":
        pytest.importorskip("numba")
    old = os.environ.get("LOOPSOLVE_ENGINE")
    os.environ["LOOPSOLVE_ENGINE"] = request.param
    try:
        yield request.param
    finally:
        if old is None:
            os.environ.pop("LOOPSOLVE_ENGINE", None)
        else:
            os.environ["LOOPSOLVE_ENGINE"] = old
