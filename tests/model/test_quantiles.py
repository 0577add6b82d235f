"""A draw's quantile: the same through a changed request, a fresh one by place."""

from __future__ import annotations

import hashlib
import math
import struct
import subprocess
import sys
from statistics import NormalDist

import numpy as np
import pytest

from beatlog.model.quantiles import (
    FreshQuantiles,
    Place,
    Quantile,
    array_value,
    scalar_quantile,
    scalar_value,
)

KEY = b"a log"


@pytest.mark.parametrize(
    ("kind", "value", "params"),
    [
        ("random", 0.25, ()),
        ("uniform", 1.2, (0.8, 1.6)),
        ("gauss", -1.5, (0.0, 3.0)),
        ("randint", 4, (1, 6)),
        ("choice", 2, (3,)),
    ],
)
def test_the_same_request_with_the_recorded_quantile_gives_the_recorded_value(
    kind: str, value: float, params: tuple[float, ...]
) -> None:
    quantile = scalar_quantile(kind, value, params)

    assert quantile is not None
    assert scalar_value(kind, params, quantile) == value


def test_a_retuned_range_keeps_the_quantile() -> None:
    quantile = scalar_quantile("uniform", 1.25, (1.0, 2.0))
    assert quantile == Quantile(0.25)

    assert scalar_value("uniform", (2.0, 6.0), quantile) == 3.0


def test_a_retuned_deviation_scales_the_same_deviate() -> None:
    quantile = scalar_quantile("gauss", -1.5, (0.0, 3.0))
    assert quantile is not None

    assert quantile.z == -0.5
    assert scalar_value("gauss", (0.0, 2.0), quantile) == -1.0


def test_an_integer_keeps_its_share_of_the_range() -> None:
    low = scalar_quantile("randint", 1, (1, 6))
    high = scalar_quantile("randint", 6, (1, 6))
    assert low is not None
    assert high is not None

    assert scalar_value("randint", (1, 12), low) == 2  # the middle of 1..2, the first sixth
    assert scalar_value("randint", (1, 12), high) == 12
    assert scalar_value("choice", (2,), high) == 1


def test_a_kind_change_maps_by_quantile() -> None:
    median = scalar_quantile("uniform", 5.0, (0.0, 10.0))
    assert median is not None

    assert scalar_value("gauss", (3.0, 1.0), median) == pytest.approx(3.0)
    assert scalar_value("randint", (0, 9), median) == 5


@pytest.mark.parametrize("value", [-7.5, -1e-300, -0.0, 0.0, 0.3, 2.9999, 1e300, math.inf])
def test_a_normal_draws_quantile_is_the_normal_distributions_cdf_bit_for_bit(
    value: float,
) -> None:
    quantile = scalar_quantile("gauss", value, (0.0, 3.0))
    assert quantile is not None

    z = value / 3.0
    expected = NormalDist().cdf(z) if math.isfinite(z) else 0.5
    assert struct.pack("<d", quantile.u) == struct.pack("<d", min(expected, 1.0 - 2.0**-53))


def test_a_format_1_draw_has_no_known_quantile() -> None:
    assert scalar_quantile("uniform", 0.3, ()) is None
    assert scalar_quantile("uniform_array", [], ()) is None


def test_a_request_with_no_values_raises_as_a_generator_would() -> None:
    with pytest.raises(ValueError, match=r"randint\(5, 3\) has no values"):
        scalar_value("randint", (5, 3), Quantile(0.5))


@pytest.mark.parametrize("key", [b"", KEY, bytes(range(100))], ids=["empty", "short", "long"])
def test_a_places_seed_is_its_keyed_blake2b_whichever_way_it_is_asked(key: bytes) -> None:
    place = Place(cycle=517, behavior="escape", call=2)
    keyed = hashlib.blake2b(b"517\x00escape\x002", key=key[:64], digest_size=8).digest()
    fresh = FreshQuantiles(key)

    assert fresh.seed(place) == keyed
    assert fresh.quantile(place).u == (int.from_bytes(keyed, "little") >> 11) * 2.0**-53


def test_fresh_quantile_is_keyed_by_the_log_and_the_place() -> None:
    place = Place(cycle=517, behavior="escape", call=0)

    quantiles = {
        FreshQuantiles(KEY).quantile(place),
        FreshQuantiles(KEY).quantile(place._replace(cycle=518)),
        FreshQuantiles(KEY).quantile(place._replace(behavior="wander")),
        FreshQuantiles(KEY).quantile(place._replace(call=1)),
        FreshQuantiles(b"another log").quantile(place),
    }

    assert len(quantiles) == 5
    assert FreshQuantiles(KEY).quantile(place) == FreshQuantiles(KEY).quantile(
        Place(517, "escape", 0)
    )
    assert all(0.0 <= quantile.u < 1.0 for quantile in quantiles)


@pytest.mark.parametrize("hash_seed", ["0", "1", "random"])
def test_fresh_quantile_is_the_same_under_any_hash_seed(hash_seed: str) -> None:
    code = (
        "from beatlog.model.quantiles import FreshQuantiles, Place;"
        "print(repr(FreshQuantiles(b'a log').quantile(Place(517, 'escape', 0)).u))"
    )
    run = subprocess.run(
        [sys.executable, "-c", code],
        capture_output=True,
        text=True,
        check=True,
        env={"PYTHONHASHSEED": hash_seed, "PATH": ""},
    )

    assert float(run.stdout) == FreshQuantiles(KEY).quantile(Place(517, "escape", 0)).u


def test_an_array_keeps_its_quantile_element_by_element_and_grows_fresh() -> None:
    old = np.array([1.0, 2.0, 3.0])
    seed = FreshQuantiles(KEY).seed(Place(3, "scan", 0))

    same = array_value(
        "uniform_array", (0.0, 4.0, [3]), ("uniform_array", (0.0, 4.0, [3]), old), seed
    )
    wider = array_value(
        "uniform_array", (0.0, 8.0, [3]), ("uniform_array", (0.0, 4.0, [3]), old), seed
    )
    grown = array_value(
        "uniform_array", (0.0, 4.0, [5]), ("uniform_array", (0.0, 4.0, [3]), old), seed
    )

    assert same.tolist() == [1.0, 2.0, 3.0]
    assert wider.tolist() == [2.0, 4.0, 6.0]
    assert grown[:3].tolist() == [1.0, 2.0, 3.0]
    assert grown.shape == (5,)
    assert (
        grown[3:].tolist() == array_value("uniform_array", (0.0, 4.0, [5]), None, seed)[3:].tolist()
    )


def test_a_normal_array_scales_its_deviates() -> None:
    old = np.array([-1.0, 0.5])
    seed = FreshQuantiles(KEY).seed(Place(3, "scan", 0))

    value = array_value(
        "normal_array", (1.0, 2.0, [2]), ("normal_array", (0.0, 1.0, [2]), old), seed
    )

    assert value.tolist() == [-1.0, 2.0]


def test_an_integer_array_keeps_its_share_of_the_range() -> None:
    old = np.array([0, 9], dtype="<i8")
    seed = FreshQuantiles(KEY).seed(Place(3, "scan", 0))

    value = array_value("integers_array", (0, 20, [2]), ("integers_array", (0, 10, [2]), old), seed)

    assert value.tolist() == [1, 19]
    assert value.dtype == np.dtype("<i8")
    assert not math.isnan(float(value.sum()))
