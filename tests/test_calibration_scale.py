"""calibration.scale: k = W / N (Chen 2018, section 2.2) and a given scale."""

import math

import numpy as np
import pytest
from hypothesis import given, settings
from hypothesis import strategies as st

from calibration import InputError
from calibration.scale import given_scale, pixel_point, ruler_scale


def test_spec_example_ruler():
    # SPEC.md: a 0.5 m ruler from (80, 482) to (205, 482) spans 125 px.
    s = ruler_scale(0.5, (80, 482), (205, 482))
    assert s.span_px == 125.0
    assert s.m_per_px == 0.004
    assert s.px_per_m == pytest.approx(250.0)
    assert s.method == "ruler"
    assert s.to_dict() == {"method": "ruler", "m_per_px": 0.004, "length_m": 0.5,
                           "from_px": [80.0, 482.0], "to_px": [205.0, 482.0],
                           "span_px": 125.0}


def test_diagonal_ruler_uses_euclidean_distance():
    # A 3-4-5 triangle: 50 px, not 30 or 40.
    s = ruler_scale(1.0, "10,20", "40,60")
    assert s.span_px == 50.0
    assert s.m_per_px == 0.02


@settings(max_examples=100, deadline=None)
@given(length=st.floats(1e-3, 100.0), a=st.tuples(st.floats(-5e3, 5e3), st.floats(-5e3, 5e3)),
       angle=st.floats(0, 2 * math.pi), span=st.floats(1.0, 5e3))
def test_scale_times_span_is_length(length, a, angle, span):
    b = (a[0] + span * math.cos(angle), a[1] + span * math.sin(angle))
    s = ruler_scale(length, a, b)
    assert s.m_per_px * s.span_px == pytest.approx(length, rel=1e-12)
    assert s.span_px == pytest.approx(span, rel=1e-9, abs=1e-9)


def test_given_scale():
    s = given_scale(0.004)
    assert s.m_per_px == 0.004 and s.method == "given"
    assert given_scale(np.float32(0.5)).m_per_px == 0.5
    assert s.to_dict() == {"method": "given", "m_per_px": 0.004}


@pytest.mark.parametrize("args,message", [
    ((0.5, (80, 482), (80, 482)), "spans 0 pixels"),
    ((0.0, (0, 0), (1, 0)), "length_m must be > 0, got 0.0"),
    ((-1, (0, 0), (1, 0)), "length_m must be > 0, got -1"),
    ((float("nan"), (0, 0), (1, 0)), "length_m must be finite"),
    (("0.5", (0, 0), (1, 0)), "length_m must be a number, got '0.5'"),
    ((True, (0, 0), (1, 0)), "length_m must be a number"),
    ((0.5, (0, 0, 1), (1, 0)), "from_px must be two numbers"),
    ((0.5, (0, 0), "1;x"), "to_px must be two numbers"),
    ((0.5, (0, float("inf")), (1, 0)), "from_px must be finite"),
    ((0.5, 3, (1, 0)), "from_px must be two numbers"),
])
def test_bad_ruler(args, message):
    with pytest.raises(InputError, match=message):
        ruler_scale(*args)


@pytest.mark.parametrize("value,message", [
    (0, "m_per_px must be > 0, got 0"), (-0.1, "> 0"), (float("inf"), "finite"),
    ("a", "must be a number"), (None, "must be a number")])
def test_bad_given_scale(value, message):
    with pytest.raises(InputError, match=message):
        given_scale(value)


def test_pixel_point_forms():
    assert pixel_point("80,482") == (80.0, 482.0)
    assert pixel_point(" 80.5 , -3 ") == (80.5, -3.0)
    assert pixel_point([1, 2]) == (1.0, 2.0)
    assert pixel_point(np.array([1.5, 2.5])) == (1.5, 2.5)
    with pytest.raises(InputError, match="--from must be two numbers"):
        pixel_point("80", "--from")
