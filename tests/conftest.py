"""Fixtures shared by the output and cache tests (a tiny file system that can be filled up), by
the tracker tests (both engines) and by the browser tests (one headless-Chromium recipe).

Test files import nothing from one another: what several of them share (models, references,
page and LaTeX helpers) is in the ``tests/support/`` package, imported as ``support.<module>``.
That works because pytest imports this file in its default ``prepend`` import mode, which puts
its folder, tests/, first on ``sys.path``.
"""

import os
import subprocess

import pytest


def _tmpfs(mnt, options: str, what: str):
    """A tmpfs mounted at ``mnt`` with ``options`` (needs root); skipped with the reason where mounting is not
    permitted, unmounted afterwards."""
    mnt.mkdir()
    proc = subprocess.run(["mount", "-t", "tmpfs", "-o", options, "tmpfs", str(mnt)], capture_output=True,
                          text=True)
    if proc.returncode != 0:
        pytest.skip(f"cannot mount {what}: {proc.stderr.strip() or 'not root'}")
    try:
        yield mnt
    finally:
        subprocess.run(["umount", "-l", str(mnt)], check=False)


@pytest.fixture
def tiny_fs(tmp_path):
    """A 64 KiB tmpfs (needs root); skipped with the reason where mounting is not permitted."""
    yield from _tmpfs(tmp_path / "tiny", "size=64k", "a small tmpfs to simulate a full disk")


@pytest.fixture
def read_only_fs(tmp_path):
    """A read-only tmpfs (needs root); skipped with the reason where mounting is not permitted."""
    yield from _tmpfs(tmp_path / "ro", "ro,size=64k", "a read-only tmpfs")


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


# ------------------------------------------------------------------ headless Chromium, one recipe
_BASE_ARGS = ("--headless=new", "--no-sandbox", "--disable-gpu", "--disable-quic", "--no-first-run",
              "--disable-background-networking", "--disable-component-update", "--disable-sync",
              "--disable-extensions")


@pytest.fixture(scope="session")
def chromium(tmp_path_factory):
    """Start headless Chromium (Debian's ``chromium`` and ``chromium-driver``, driven by selenium).

    ``with chromium(window=(1280, 860), offline=True, performance=True) as driver:`` gives a driver
    with its own empty profile, the browser's console log kept (``performance``: the network log
    too, to prove a page made no request), and with ``offline`` the network switched off through
    the DevTools protocol. Without the browser, the driver or selenium the test is skipped, or
    fails when ``LOOPSOLVE_REQUIRE_BROWSER`` is set (CI sets it).
    """
    import contextlib
    import shutil

    @contextlib.contextmanager
    def start(*, window=(1280, 860), offline=False, performance=False, file_access=False, script_timeout=None):
        binary = shutil.which("chromium") or shutil.which("chromium-browser")
        driver_path = shutil.which("chromedriver")
        missing = [name for name, found in (("chromium", binary), ("chromedriver", driver_path)) if not found]
        try:
            from selenium import webdriver
            from selenium.webdriver.chrome.service import Service
        except ImportError:
            missing.append("selenium (pip install 'loopsolve[test]')")
        if missing:
            if os.environ.get("LOOPSOLVE_REQUIRE_BROWSER"):
                pytest.fail(f"{', '.join(missing)} not found but LOOPSOLVE_REQUIRE_BROWSER is set")
            pytest.skip(f"{', '.join(missing)} not found (apt install chromium chromium-driver); "
                        "set LOOPSOLVE_REQUIRE_BROWSER=1 to make this a failure")
        opts = webdriver.ChromeOptions()
        opts.binary_location = binary
        extra = ["--allow-file-access-from-files"] if file_access else []
        for arg in (*_BASE_ARGS, *extra, f"--window-size={window[0]},{window[1]}",
                    f"--user-data-dir={tmp_path_factory.mktemp('chromium-profile')}"):
            opts.add_argument(arg)
        opts.set_capability("goog:loggingPrefs", {"browser": "ALL", **({"performance": "ALL"} if performance else {})})
        driver = webdriver.Chrome(service=Service(driver_path), options=opts)
        try:
            if script_timeout is not None:
                driver.set_script_timeout(script_timeout)
            if offline:
                driver.execute_cdp_cmd("Network.enable", {})
                driver.execute_cdp_cmd("Network.emulateNetworkConditions", {
                    "offline": True, "latency": 0, "downloadThroughput": -1, "uploadThroughput": -1})
            yield driver
        finally:
            driver.quit()

    return start
