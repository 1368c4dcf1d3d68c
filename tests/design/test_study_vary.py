"""``--vary`` values that are not designs: each message quotes the text and says what to write.

(Mutation survivor of issue 18: a message replaced by ``None`` passed every test.)
"""

from __future__ import annotations

import pytest

from loopsolve.design.designs import parse_vary
from loopsolve.errors import ModelError


@pytest.mark.parametrize("text, says", [
    ("r2=1:2:3:4", "a range is START:STOP:COUNT (or LOW:HIGH for a sample)"),
    ("r2", "expected NAME=START:STOP:COUNT, NAME=LOW:HIGH or NAME=V1,V2,..."),
    ("=1,2", "expected NAME=START:STOP:COUNT, NAME=LOW:HIGH or NAME=V1,V2,..."),
])
def test_malformed_vary_messages(text, says):
    with pytest.raises(ModelError) as info:
        parse_vary(text)
    assert str(info.value) == f"--vary {text!r}: {says}"


def test_well_formed_vary():
    assert parse_vary("r2=20:40:3") == ("r2", [20.0, 30.0, 40.0])
    assert parse_vary("r4=40:50") == ("r4", (40.0, 50.0))
