"""masonry.geometry: the per-tick float forms equal the numpy ones."""

from __future__ import annotations

import numpy as np
import pytest
from hypothesis import given
from hypothesis import strategies as st

from masonry.geometry import R_world_body, body_to_world_floats

angles = st.tuples(st.floats(-0.6, 0.6), st.floats(-0.6, 0.6), st.floats(-3.2, 3.2))
vectors = st.tuples(*[st.floats(-2.0, 2.0)] * 3)


@given(angles, vectors)
def test_body_to_world_floats_is_the_rotation_matrix_product(attitude, v) -> None:
    got = body_to_world_floats(attitude, v)
    expected = (R_world_body(*attitude) @ np.array(v)).tolist()
    assert got == pytest.approx(expected, rel=1e-12, abs=1e-12)
    assert all(type(x) is float for x in got)
