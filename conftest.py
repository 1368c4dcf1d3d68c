import math
import os

import numpy as np

import pytest

import loopsolve

# the editor's web server needs the `edit` extra (starlette, uvicorn); without it its module is not collected
collect_ignore = []
try:
    import starlette  # noqa: F401
    import uvicorn  # noqa: F401
except ImportError:
    collect_ignore.append("loopsolve/editor/server.py")

try:  # property tests: a few examples locally, hundreds in CI (`CI` is set by .ci/run and CI services)
    from hypothesis import HealthCheck
    from hypothesis import settings as _hyp_settings

    _hyp_settings.register_profile("ci", max_examples=300, deadline=None, print_blob=True)
    _hyp_settings.register_profile("dev", deadline=None)
    # mutation testing (tools/mutation.sh) reruns the tests in one process, reproducibly and briefly
    _hyp_settings.register_profile("mutation", max_examples=10, deadline=None, derandomize=True, database=None,
                                   suppress_health_check=[HealthCheck.differing_executors])
    _PROFILE = os.environ.get("HYPOTHESIS_PROFILE") or (
        "mutation" if "MUTANT_UNDER_TEST" in os.environ else "ci" if os.environ.get("CI") else "dev")
    _hyp_settings.load_profile(_PROFILE)
except ImportError:  # pragma: no cover - hypothesis is in the `test` extra
    _hyp_settings = None


def pytest_collection_modifyitems(config, items):
    """The profile's ``max_examples`` wins over a test's own: raised in CI, lowered for mutation runs."""
    if _hyp_settings is None or _PROFILE not in ("ci", "mutation"):
        return
    wanted = _hyp_settings.default
    for item in items:
        fn = getattr(item, "obj", None)
        fn = getattr(fn, "__func__", fn)
        own = getattr(fn, "_hypothesis_internal_use_settings", None)
        if own is None or own.max_examples == wanted.max_examples:
            continue
        if _PROFILE == "ci" and own.max_examples > wanted.max_examples:
            continue
        fn._hypothesis_internal_use_settings = _hyp_settings(
            own, max_examples=wanted.max_examples, derandomize=wanted.derandomize, database=wanted.database,
            suppress_health_check=wanted.suppress_health_check)


@pytest.fixture(autouse=True)
def _doctest_namespace(doctest_namespace):
    doctest_namespace["ls"] = loopsolve
    doctest_namespace["np"] = np
    doctest_namespace["math"] = math


@pytest.fixture(autouse=True, scope="session")
def _private_cache(tmp_path_factory):
    """Tests compile into a private cache so they never depend on (or pollute) the user's."""

    old = os.environ.get("LOOPSOLVE_CACHE_DIR")
    os.environ["LOOPSOLVE_CACHE_DIR"] = str(tmp_path_factory.mktemp("cache"))
    # Forget modules compiled earlier in this process (mutation testing forks test sessions from
    # a process that already ran the suite; a stale in-memory module would hide a mutant).
    from loopsolve.symbolic import compiled

    compiled._MEMO.clear()
    yield
    if old is None:
        os.environ.pop("LOOPSOLVE_CACHE_DIR", None)
    else:
        os.environ["LOOPSOLVE_CACHE_DIR"] = old
