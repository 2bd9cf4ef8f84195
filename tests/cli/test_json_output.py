"""Every ``--json`` is strict JSON: non-finite figures as null, numpy values as numbers."""

import json
import math

import numpy as np

from dreamprint_gui.cli.output import emit_json, strict_json


def test_non_finite_figures_are_null_and_numpy_values_plain():
    obj = {"a": math.nan, "b": [np.float32(1.5), np.inf], "c": np.arange(3), 4: (np.int64(2),)}
    assert strict_json(obj) == {"a": None, "b": [1.5, None], "c": [0, 1, 2], "4": [2]}


def test_emit_json_writes_what_a_strict_reader_takes(capsys):
    emit_json({"dE": float("nan"), "t": float("inf"), "n": np.int32(7)})
    out = capsys.readouterr().out

    def refuse(name):
        raise ValueError(name)

    assert json.loads(out, parse_constant=refuse) == {"dE": None, "t": None, "n": 7}
