"""math3d: tf2 LinearMath conventions, scalar and batched versions agree."""
from __future__ import annotations

import math

import numpy as np
import pytest
from scipy.spatial.transform import Rotation

from zentf.core import math3d as m


def test_set_rpy_convention_matches_fixed_axes_zyx() -> None:
    assert m.quaternion_from_rpy(0, 0, 0.5) == pytest.approx((0, 0, math.sin(0.25), math.cos(0.25)))
    rng = np.random.default_rng(1)
    for r, p, y in rng.uniform(-3, 3, (50, 3)):
        q = m.quaternion_from_rpy(r, p, y)
        ref = Rotation.from_euler("xyz", [r, p, y]).as_quat()  # extrinsic x, y, z = Rz·Ry·Rx
        assert min(np.abs(np.subtract(q, ref)).max(), np.abs(np.add(q, ref)).max()) < 1e-12


def test_rpy_round_trip_and_gimbal_lock() -> None:
    rng = np.random.default_rng(2)
    for r, p, y in rng.uniform([-3, -1.5, -3], [3, 1.5, 3], (50, 3)):
        assert m.rpy_from_quaternion(m.quaternion_from_rpy(r, p, y)) == pytest.approx((r, p, y), abs=1e-9)
    roll, pitch, yaw = m.rpy_from_quaternion(m.quaternion_from_rpy(0.3, math.pi / 2, 0.0))
    assert pitch == pytest.approx(math.pi / 2) and yaw == 0.0 and roll == pytest.approx(0.3, abs=1e-15)


@pytest.mark.parametrize("rpy", [(0.1, 0.2, 0.3), (-1.0, 0.5, 2.5), (0.0, 0.0, -3.0), (3.0, -1.2, 0.4)])
def test_rpy_and_matrix_are_fixed_axes_zyx(rpy: tuple[float, float, float]) -> None:
    r, p, y = rpy
    q = m.quaternion_from_rpy(r, p, y)
    assert m.rpy_from_quaternion(q) == pytest.approx(rpy, abs=1e-12)
    mat = m.matrix_from_quaternion(q)
    # R = Rz(y) Ry(p) Rx(r): first column is (cy cp, sy cp, -sp)
    assert [mat[0][0], mat[1][0], mat[2][0]] == pytest.approx([math.cos(y) * math.cos(p), math.sin(y) * math.cos(p),
                                                               -math.sin(p)], abs=1e-12)


def test_math3d_reexports_the_numpy_free_rotation_helpers() -> None:
    from zentf.core import rotation

    for name in rotation.__all__:
        assert getattr(m, name) is getattr(rotation, name)


def test_matrix_round_trip_and_4x4() -> None:
    q = m.quaternion_normalize((0.1, -0.7, 0.3, 0.5))
    back = m.quaternion_from_matrix(m.matrix_from_quaternion(q))
    assert min(np.abs(np.subtract(q, back)).max(), np.abs(np.add(q, back)).max()) < 1e-12
    mat = m.matrix_from_transform((1, 2, 3), q)
    assert mat.shape == (4, 4) and np.allclose(mat[:3, :3], Rotation.from_quat(q).as_matrix())
    t, q2 = m.transform_from_matrix(mat)
    assert t == (1.0, 2.0, 3.0)
    with pytest.raises(ValueError):
        m.matrix_from_quaternion((0, 0, 0, 0))


def test_compose_inverse_rotate() -> None:
    q = m.quaternion_from_rpy(0.2, -0.4, 1.1)
    t = (1.0, -2.0, 0.5)
    ti, qi = m.inverse_transform(t, q)
    tt, qq = m.compose(t, q, ti, qi)
    assert tt == pytest.approx((0, 0, 0), abs=1e-12) and abs(abs(qq[3]) - 1) < 1e-12
    v = (0.3, 0.4, -1.0)
    assert m.quat_rotate(q, v) == pytest.approx(tuple(Rotation.from_quat(q).apply(v)), abs=1e-12)
    assert m.quaternion_multiply(q, m.quaternion_inverse(q)) == pytest.approx((0, 0, 0, 1), abs=1e-12)


def test_slerp_endpoints_midpoint_and_shortest_path() -> None:
    a = m.quaternion_from_rpy(0, 0, 0.0)
    b = m.quaternion_from_rpy(0, 0, 1.0)
    assert m.slerp(a, b, 0.0) == pytest.approx(a) and m.slerp(a, b, 1.0) == pytest.approx(b)
    assert m.slerp(a, b, 0.5) == pytest.approx(m.quaternion_from_rpy(0, 0, 0.5), abs=1e-12)
    neg_b = tuple(-x for x in b)  # same rotation, other hemisphere: still the short way
    mid = m.slerp(a, neg_b, 0.5)
    assert min(np.abs(np.subtract(mid, m.quaternion_from_rpy(0, 0, 0.5))).max(),
               np.abs(np.add(mid, m.quaternion_from_rpy(0, 0, 0.5))).max()) < 1e-12
    assert m.slerp(a, a, 0.3) == a  # zero angle returns the first, untouched
    assert m.lerp((0, 0, 0), (2, 4, 6), 0.25) == (0.5, 1.0, 1.5)


def test_batched_versions_equal_scalar() -> None:
    rng = np.random.default_rng(3)
    q0 = Rotation.random(64, random_state=4).as_quat()
    q1 = Rotation.random(64, random_state=5).as_quat()
    t = rng.uniform(0, 1, 64)
    v = rng.normal(size=(64, 3))
    s = m.slerp_batch(q0, q1, t)
    r = m.quat_rotate_batch(q0, v)
    p = m.quaternion_multiply_batch(q0, q1)
    mats = m.matrix_from_quaternion_batch(q0)
    for i in range(64):
        assert np.allclose(s[i], m.slerp(q0[i], q1[i], t[i]), atol=1e-12)
        assert np.allclose(r[i], m.quat_rotate(q0[i], v[i]), atol=1e-12)
        assert np.allclose(p[i], m.quaternion_multiply(q0[i], q1[i]), atol=1e-12)
        assert np.allclose(mats[i], m.matrix_from_quaternion(q0[i]), atol=1e-12)
