"""Values are stored column-major per instance and read back as NumPy."""

import numpy as np
import pytest

import yasps
from yasps.frontend.values import from_column_major, to_column_major


def test_layout_is_column_major_per_instance():
    rows, cols = 2, 3
    values = np.arange(12.0).reshape(2, rows, cols)
    flat = to_column_major(values, 2, rows, cols, "x")
    # instance 1, entry (row 1, col 2) -> 1*6 + 2*2 + 1
    assert flat[6 + 2 * 2 + 1] == values[1, 1, 2]
    assert flat[:6].tolist() == [0.0, 3.0, 1.0, 4.0, 2.0, 5.0]
    np.testing.assert_array_equal(from_column_major(flat, rows, cols), values)


@pytest.mark.parametrize("shape", [(4, 3, 3), (4, 9), (36,)])
def test_accepted_shapes_agree(shape):
    values = np.random.default_rng(1).random((4, 3, 3))
    s = yasps.scene("s")
    prim = s.addMesh("m").addPrimitive("p", numInstances=4)
    a = prim.addAttribute("a", rows=3, cols=3)
    a.updateValue(values.reshape(shape))
    np.testing.assert_array_equal(a.value, values)


def test_single_instance_takes_a_matrix_and_lists():
    s = yasps.scene("s")
    body = s.addMesh("m").addPrimitive("body", numInstances=1)
    A = body.addAttribute("A", rows=3, cols=3)
    A.updateValue(np.eye(3) * 2)
    np.testing.assert_array_equal(A.value[0], np.eye(3) * 2)
    t = body.addAttribute("t", rows=3, cols=1)
    t.updateValue([1, 2, 3])
    assert t.value.dtype == np.float64
    assert t.value.reshape(-1).tolist() == [1.0, 2.0, 3.0]
