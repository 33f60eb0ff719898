"""Forward kinematics: every link's pose in the root link, for one joint vector or many at once.

A joint's transform parent -> child is ``origin · motion(q)``: a rotation about the (origin-frame)
axis for revolute and continuous joints, a translation along it for prismatic ones; fixed, floating
and planar joints contribute their origin only (robot_state_publisher's KDL tree does the same).
Mimic joints follow ``multiplier * q(master) + offset``. The batch path works on ``(N, links, 4, 4)``
arrays: one numpy step per joint for all N vectors.
"""
from __future__ import annotations

import math
from collections.abc import Mapping, Sequence
from dataclasses import dataclass

import numpy as np

from ..core.math3d import quaternion_multiply_batch
from .model import Joint, Robot, origin_matrices

__all__ = ["Kinematics", "JointTransforms"]

_FIXED, _REVOLUTE, _PRISMATIC = 0, 1, 2


@dataclass(slots=True)
class _JointData:
    name: str
    kind: int
    parent: int          # index of the parent link in Kinematics.link_names
    child: int
    origin: np.ndarray   # 4x4
    axis: np.ndarray     # (3,)
    cross: np.ndarray    # 3x3 cross-product matrix of axis
    source: int          # index into the actuated vector, -1: none (fixed, or mimic of a non-actuated joint)
    multiplier: float
    offset: float


def _cross_matrices(a: np.ndarray) -> np.ndarray:
    """``(n, 3, 3)`` cross-product matrices of ``(n, 3)`` axes."""
    m = np.zeros((len(a), 3, 3))
    m[:, 0, 1], m[:, 0, 2] = -a[:, 2], a[:, 1]
    m[:, 1, 0], m[:, 1, 2] = a[:, 2], -a[:, 0]
    m[:, 2, 0], m[:, 2, 1] = -a[:, 1], a[:, 0]
    return m


class Kinematics:
    """FK over a checked ``Robot``. ``joint_names`` is the order of joint vectors (actuated joints)."""

    def __init__(self, robot: Robot) -> None:
        self.robot = robot
        order = robot.joints_in_order()
        self.link_names: list[str] = [robot.root] + [j.child for j in order]
        self._link_index = {n: i for i, n in enumerate(self.link_names)}
        actuated = robot.actuated_joints()
        self.joint_names: list[str] = [j.name for j in actuated]
        self._index = {n: i for i, n in enumerate(self.joint_names)}
        self._joints: list[_JointData] = []
        # every joint's constants built as whole arrays (a model can have 100,000 joints); each joint keeps views
        origins = origin_matrices([j.origin for j in order])
        axes = np.array([j.axis for j in order], dtype=float).reshape(-1, 3)
        crosses = _cross_matrices(axes)
        index = self._link_index
        for i, j in enumerate(order):
            kind = _REVOLUTE if j.type in ("revolute", "continuous") else _PRISMATIC if j.type == "prismatic" else _FIXED
            source, mult, off = self._source(j)
            self._joints.append(_JointData(j.name, kind, index[j.parent], index[j.child], origins[i], axes[i],
                                           crosses[i], source, mult, off))

    def _source(self, j: Joint) -> tuple[int, float, float]:
        """Which actuated joint drives j, and how: (index, multiplier, offset)."""
        if not j.movable:
            return -1, 0.0, 0.0
        driver, mult, off = self.robot.mimic_drivers()[j.name]
        if driver is None:
            return -1, 0.0, off
        return self._index[driver], mult, off

    # ------------------------------------------------------------------ positions
    def vector(self, positions: Mapping[str, float] | Sequence[float] | None) -> np.ndarray:
        """A joint vector in ``joint_names`` order from a name -> value mapping (missing: 0)."""
        if positions is None:
            return np.zeros(len(self.joint_names))
        if isinstance(positions, Mapping):
            q = np.zeros(len(self.joint_names))
            for name, v in positions.items():
                i = self._index.get(name)
                if i is not None:
                    q[i] = float(v)
            return q
        q = np.asarray(positions, dtype=float)
        if q.shape != (len(self.joint_names),):
            raise ValueError(f"expected {len(self.joint_names)} joint values ({', '.join(self.joint_names)}), "
                             f"got shape {q.shape}")
        return q

    def joint_positions(self, positions: Mapping[str, float] | Sequence[float] | None) -> dict[str, float]:
        """The position of every movable joint (mimic joints computed) for a joint vector."""
        q = self.vector(positions)
        return {jd.name: (jd.multiplier * q[jd.source] if jd.source >= 0 else 0.0) + jd.offset
                for jd in self._joints if jd.kind != _FIXED}

    # ------------------------------------------------------------------ one vector
    @staticmethod
    def _motion(jd: _JointData, v: float) -> np.ndarray:
        m = np.eye(4)
        if jd.kind == _REVOLUTE:
            s, c = math.sin(v), math.cos(v)
            m[:3, :3] += s * jd.cross + (1.0 - c) * (jd.cross @ jd.cross)
        elif jd.kind == _PRISMATIC:
            m[:3, 3] = jd.axis * v
        return m

    def joint_transform(self, joint: str, position: float = 0.0) -> np.ndarray:
        """4x4 parent -> child of one joint at ``position``."""
        jd = next((x for x in self._joints if x.name == joint), None)
        if jd is None:
            raise KeyError(f"unknown joint {joint!r}")
        return jd.origin if jd.kind == _FIXED else jd.origin @ self._motion(jd, position)

    def link_poses(self, positions: Mapping[str, float] | Sequence[float] | None = None) -> dict[str, np.ndarray]:
        """Every link's 4x4 pose in the root link."""
        q = self.vector(positions)
        poses = [np.eye(4)] * len(self.link_names)
        for jd in self._joints:
            parent = poses[jd.parent]
            if jd.kind == _FIXED:
                poses[jd.child] = parent @ jd.origin
            else:
                v = (jd.multiplier * q[jd.source] if jd.source >= 0 else 0.0) + jd.offset
                poses[jd.child] = parent @ jd.origin @ self._motion(jd, v)
        return dict(zip(self.link_names, poses))

    def link_pose(self, link: str, positions: Mapping[str, float] | Sequence[float] | None = None,
                  base: str | None = None) -> np.ndarray:
        """4x4 pose of ``link`` in ``base`` (default: the root link)."""
        poses = self.link_poses(positions)
        try:
            pose = poses[link]
            return pose if base is None else np.linalg.inv(poses[base]) @ pose
        except KeyError as e:
            raise KeyError(f"unknown link {e.args[0]!r}") from None

    # ------------------------------------------------------------------ many vectors
    def link_poses_batch(self, q: np.ndarray) -> np.ndarray:
        """``(N, len(link_names), 4, 4)`` poses for ``q`` of shape ``(N, len(joint_names))``.

        Rotations (N, 3, 3) and translations (N, 3) are carried apart; a product with a joint's
        constant matrix is one (3N x 3) @ (3 x 3) BLAS call, the joint motion is Rodrigues' formula
        R·(I + sin q K + (1 - cos q) K²) applied as two such products.
        """
        q = np.asarray(q, dtype=float)
        if q.ndim != 2 or q.shape[1] != len(self.joint_names):
            raise ValueError(f"expected an (N, {len(self.joint_names)}) array of joint vectors, got {q.shape}")
        n = q.shape[0]
        nl = len(self.link_names)
        rot = np.empty((nl, n, 3, 3))
        pos = np.empty((nl, n, 3))
        rot[0] = np.eye(3)
        pos[0] = 0.0
        for jd in self._joints:
            rp, tp = rot[jd.parent], pos[jd.parent]
            flat = rp.reshape(3 * n, 3)
            ro = (flat @ jd.origin[:3, :3]).reshape(n, 3, 3)          # parent · origin rotation
            t = tp + (flat @ jd.origin[:3, 3]).reshape(n, 3)
            if jd.kind == _FIXED:
                rot[jd.child] = ro
                pos[jd.child] = t
                continue
            v = q[:, jd.source] * jd.multiplier + jd.offset if jd.source >= 0 else np.full(n, jd.offset)
            flat_o = ro.reshape(3 * n, 3)
            if jd.kind == _REVOLUTE:
                k1 = (flat_o @ jd.cross).reshape(n, 3, 3)
                k2 = (flat_o @ (jd.cross @ jd.cross)).reshape(n, 3, 3)
                rot[jd.child] = ro + np.sin(v)[:, None, None] * k1 + (1.0 - np.cos(v))[:, None, None] * k2
                pos[jd.child] = t
            else:
                rot[jd.child] = ro
                pos[jd.child] = t + v[:, None] * (flat_o @ jd.axis).reshape(n, 3)
        out = np.zeros((n, nl, 4, 4))
        out[..., :3, :3] = rot.transpose(1, 0, 2, 3)
        out[..., :3, 3] = pos.transpose(1, 0, 2)
        out[..., 3, 3] = 1.0
        return out


class JointTransforms:
    """robot_state_publisher's per-joint transforms (parent -> child, translation + quaternion),
    vectorized over the joints of one joint state."""

    def __init__(self, robot: Robot, joints: Sequence[Joint]) -> None:
        from ..core.math3d import quaternion_from_rpy

        self.names = [j.name for j in joints]
        self.parents = [j.parent for j in joints]
        self.children = [j.child for j in joints]
        self.t0 = np.array([j.origin.xyz for j in joints], dtype=float).reshape(-1, 3)
        self.q0 = np.array([quaternion_from_rpy(*j.origin.rpy) for j in joints], dtype=float).reshape(-1, 4)
        axes = np.array([j.axis for j in joints], dtype=float).reshape(-1, 3)
        self.axis = axes
        rot = origin_matrices([j.origin for j in joints])[:, :3, :3]
        self.slide = np.einsum("jab,jb->ja", rot, axes)  # prismatic direction in the parent frame
        self.revolute = np.array([j.type in ("revolute", "continuous") for j in joints], dtype=bool)
        self.prismatic = np.array([j.type == "prismatic" for j in joints], dtype=bool)

    def subset(self, idx: np.ndarray) -> "JointTransforms.Subset":
        """The constants of joints ``idx``, ready for ``compute`` (robot_state_publisher caches one per
        joint-name list it receives)."""
        return JointTransforms.Subset(self, np.asarray(idx, dtype=int))

    class Subset:
        """q = q0 ⊗ (axis sin(v/2), cos(v/2)) = cos(v/2) q0 + sin(v/2) (q0 ⊗ (axis, 0)); t = t0 + v slide."""

        def __init__(self, jt: "JointTransforms", idx: np.ndarray) -> None:
            rev = jt.revolute[idx]
            self.t0 = jt.t0[idx]
            self.q0 = jt.q0[idx]
            pure = np.zeros((len(idx), 4))
            pure[:, :3] = jt.axis[idx]
            self.q0a = quaternion_multiply_batch(self.q0, pure) * rev[:, None]
            self.half = np.where(rev, 0.5, 0.0)
            self.slide = jt.slide[idx] * jt.prismatic[idx][:, None]

        def compute(self, values: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
            """(translations (k,3), quaternions (k,4)) at ``values`` (k,)."""
            h = values * self.half
            q = self.q0 * np.cos(h)[:, None] + self.q0a * np.sin(h)[:, None]
            t = self.t0 + self.slide * values[:, None]
            return t, q

    def compute(self, idx: np.ndarray, values: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
        """(translations (k,3), quaternions (k,4)) of joints ``idx`` at ``values``."""
        return self.subset(idx).compute(np.asarray(values, dtype=float))
