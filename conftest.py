import math

import numpy as np
import pytest

import loopsolve


@pytest.fixture(autouse=True)
def _doctest_namespace(doctest_namespace):
    doctest_namespace["ls"] = loopsolve
    doctest_namespace["np"] = np
    doctest_namespace["math"] = math


@pytest.fixture(autouse=True, scope="session")
def _private_cache(tmp_path_factory):
    """Tests compile into a private cache so they never depend on (or pollute) the user's."""
    import os

    old = os.environ.get("LOOPSOLVE_CACHE_DIR")
    os.environ["LOOPSOLVE_CACHE_DIR"] = str(tmp_path_factory.mktemp("cache"))
    yield
    if old is None:
        os.environ.pop("LOOPSOLVE_CACHE_DIR", None)
    else:
        os.environ["LOOPSOLVE_CACHE_DIR"] = old
