"""The one JSON conversion: strict JSON out of numpy, NaN and infinities."""

import json
import math

import numpy as np
import pytest

from brdffit.jsonable import dumps, jsonable


def test_non_finite_become_null_everywhere():
    value = {
        "a": float("nan"),
        "b": np.float32("inf"),
        "c": [1.0, -math.inf, np.array([np.nan, 2.0])],
        "d": np.array([[1.0, np.inf], [3.0, 4.0]]),
        "e": (np.int64(3), np.bool_(True)),
    }
    out = jsonable(value)
    assert out == {
        "a": None,
        "b": None,
        "c": [1.0, None, [None, 2.0]],
        "d": [[1.0, None], [3.0, 4.0]],
        "e": [3, True],
    }
    assert json.loads(dumps(value)) == out


def test_plain_values_pass_unchanged():
    assert jsonable({"x": "text", "n": None, "i": 2, "f": 0.5}) == {
        "x": "text",
        "n": None,
        "i": 2,
        "f": 0.5,
    }


def test_dumps_is_strict():
    assert dumps(float("nan")) == "null"
    # A non-finite key is left as given by jsonable (keys are not converted); plain
    # json.dumps would write it as "NaN": brdffit's dumps refuses it instead.
    with pytest.raises(ValueError, match="not JSON compliant"):
        dumps({float("nan"): 1.0})
