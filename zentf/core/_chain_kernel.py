"""numba-compiled arithmetic of ``batch.lookup_transforms``: a planned chain composed in one pass per time.

Imported lazily by ``zentf.core.batch`` (never at ``import zentf``); needs numba (the ``fast`` extra).
The arithmetic repeats the numpy path's operation for operation (same Taylor slerp, same
composition formulas, same order), so the two paths agree to rounding; only the loop structure
differs: no temporary rows, no Python between links.
"""
from __future__ import annotations

import math

import numpy as np
from numba import njit

_SIN = np.array([(-1.0) ** k / math.factorial(2 * k + 1) for k in range(14)])
_COS = np.array([(-1.0) ** k / math.factorial(2 * k) for k in range(14)])


_BLOCK = 128      # times per block: both accumulators of a block stay in L1


@njit(cache=True, fastmath=False, nogil=True)
def chain_kernel(tf: np.ndarray, k: np.ndarray, off: np.ndarray, cnt: np.ndarray, kt: np.ndarray,
                 unit: np.ndarray, cval: np.ndarray, n_src: int, mode: int, sin_c: np.ndarray,
                 cos_c: np.ndarray, out: np.ndarray) -> None:
    """tf[n] (sorted float ns - base); link l reads rows k[off[l]:off[l] + cnt[l]] (one interval's
    16 constants per row; cnt[l] == 0: the constant link cval[l] = px, py, pz, qw, qx, qy, qz);
    links [0, n_src) are the source walk, the rest the target walk. mode 0: inv(target) ∘ source,
    1: source only (the source walk reached the target), 2: inv(target) only. out: (7, n).

    Links outside, times inside (per block of times): the times of a block are independent, so
    the CPU overlaps their composition chains instead of waiting on one time's chain."""
    n = tf.shape[0]
    n_links = off.shape[0]
    ptr = np.zeros(n_links, np.int64)
    acc = np.empty((2, 7, _BLOCK))       # [0]: source side, [1]: target side; s (3), w, v (3)
    val = np.empty((7, _BLOCK))          # the current link's value at each time of the block
    for b0 in range(0, n, _BLOCK):
        nb = min(_BLOCK, n - b0)
        for side in range(2):
            for i in range(nb):
                acc[side, 0, i] = 0.0
                acc[side, 1, i] = 0.0
                acc[side, 2, i] = 0.0
                acc[side, 3, i] = 1.0
                acc[side, 4, i] = 0.0
                acc[side, 5, i] = 0.0
                acc[side, 6, i] = 0.0
        for l in range(n_links):
            a = acc[0] if l < n_src else acc[1]
            c = cnt[l]
            o = off[l]
            terms = kt[l]
            is_unit = unit[l]
            v = val
            if c == 0:
                for q in range(7):
                    cq = cval[l, q]
                    for i in range(nb):
                        v[q, i] = cq
            else:
                p = ptr[l]
                for i in range(nb):
                    t = tf[b0 + i]
                    while p + 1 < c and k[o + p + 1, 0] <= t:
                        p += 1
                    r = k[o + p]
                    rr = t - r[0]
                    x = rr * r[1]
                    v[0, i] = r[2] + r[5] * rr
                    v[1, i] = r[3] + r[6] * rr
                    v[2, i] = r[4] + r[7] * rr
                    if terms == 1:
                        v[3, i] = r[8]
                        v[4, i] = r[9]
                        v[5, i] = r[10]
                        v[6, i] = r[11]
                    else:
                        x2 = x * x
                        sp = x2 * sin_c[terms - 1]
                        cp = x2 * cos_c[terms - 1]
                        for m in range(terms - 2, 0, -1):
                            sp = (sp + sin_c[m]) * x2
                            cp = (cp + cos_c[m]) * x2
                        sp = (sp + 1.0) * x
                        cp = cp + 1.0
                        v[3, i] = r[8] * cp + r[12] * sp
                        v[4, i] = r[9] * cp + r[13] * sp
                        v[5, i] = r[10] * cp + r[14] * sp
                        v[6, i] = r[11] * cp + r[15] * sp
                ptr[l] = p
            # compose, branch-free per time (the compiler vectorizes these loops)
            if is_unit:
                for i in range(nb):
                    px = v[0, i]
                    py = v[1, i]
                    pz = v[2, i]
                    w = v[3, i]
                    ux = v[4, i]
                    uy = v[5, i]
                    uz = v[6, i]
                    ax = a[0, i]
                    ay = a[1, i]
                    az = a[2, i]
                    cx = (uy * az - uz * ay) * 2.0
                    cy = (uz * ax - ux * az) * 2.0
                    cz = (ux * ay - uy * ax) * 2.0
                    a[0, i] = ax + w * cx + (uy * cz) - (uz * cy) + px
                    a[1, i] = ay + w * cy + (uz * cx) - (ux * cz) + py
                    a[2, i] = az + w * cz + (ux * cy) - (uy * cx) + pz
                    aw = a[3, i]
                    bx = a[4, i]
                    by = a[5, i]
                    bz = a[6, i]
                    d = ux * bx + uy * by + uz * bz
                    a[3, i] = aw * w - d
                    a[4, i] = bx * w + (uy * bz - uz * by + aw * ux)
                    a[5, i] = by * w + (uz * bx - ux * bz + aw * uy)
                    a[6, i] = bz * w + (ux * by - uy * bx + aw * uz)
            else:
                for i in range(nb):
                    px = v[0, i]
                    py = v[1, i]
                    pz = v[2, i]
                    w = v[3, i]
                    ux = v[4, i]
                    uy = v[5, i]
                    uz = v[6, i]
                    ax = a[0, i]
                    ay = a[1, i]
                    az = a[2, i]
                    cx = uy * az - uz * ay + w * ax
                    cy = uz * ax - ux * az + w * ay
                    cz = ux * ay - uy * ax + w * az
                    d = ux * ax + uy * ay + uz * az
                    a[0, i] = w * cx + (uy * cz) - (uz * cy) + d * ux + px
                    a[1, i] = w * cy + (uz * cx) - (ux * cz) + d * uy + py
                    a[2, i] = w * cz + (ux * cy) - (uy * cx) + d * uz + pz
                    aw = a[3, i]
                    bx = a[4, i]
                    by = a[5, i]
                    bz = a[6, i]
                    d = ux * bx + uy * by + uz * bz
                    a[3, i] = aw * w - d
                    a[4, i] = bx * w + (uy * bz - uz * by + aw * ux)
                    a[5, i] = by * w + (uz * bx - ux * bz + aw * uy)
                    a[6, i] = bz * w + (ux * by - uy * bx + aw * uz)
        s = acc[0]
        g = acc[1]
        for i in range(nb):
            sx = s[0, i]
            sy = s[1, i]
            sz = s[2, i]
            qw = s[3, i]
            qx = s[4, i]
            qy = s[5, i]
            qz = s[6, i]
            if mode != 1 and n_links > n_src:
                # inverse of the target accumulator: q* and quatRotate(q*, -g) (general formula)
                w = g[3, i]
                ux = -g[4, i]
                uy = -g[5, i]
                uz = -g[6, i]
                ax = -g[0, i]
                ay = -g[1, i]
                az = -g[2, i]
                cx = uy * az - uz * ay + w * ax
                cy = uz * ax - ux * az + w * ay
                cz = ux * ay - uy * ax + w * az
                d = ux * ax + uy * ay + uz * az
                px = w * cx + (uy * cz) - (uz * cy) + d * ux
                py = w * cy + (uz * cx) - (ux * cz) + d * uy
                pz = w * cz + (ux * cy) - (uy * cx) + d * uz
                if mode == 2:
                    sx, sy, sz, qw, qx, qy, qz = px, py, pz, w, ux, uy, uz
                else:
                    cx = uy * sz - uz * sy + w * sx
                    cy = uz * sx - ux * sz + w * sy
                    cz = ux * sy - uy * sx + w * sz
                    d = ux * sx + uy * sy + uz * sz
                    nx = w * cx + (uy * cz) - (uz * cy) + d * ux + px
                    ny = w * cy + (uz * cx) - (ux * cz) + d * uy + py
                    nz = w * cz + (ux * cy) - (uy * cx) + d * uz + pz
                    d = ux * qx + uy * qy + uz * qz
                    nw = qw * w - d
                    mx = qx * w + (uy * qz - uz * qy + qw * ux)
                    my = qy * w + (uz * qx - ux * qz + qw * uy)
                    mz = qz * w + (ux * qy - uy * qx + qw * uz)
                    sx, sy, sz, qw, qx, qy, qz = nx, ny, nz, nw, mx, my, mz
            out[0, b0 + i] = sx
            out[1, b0 + i] = sy
            out[2, b0 + i] = sz
            out[3, b0 + i] = qx
            out[4, b0 + i] = qy
            out[5, b0 + i] = qz
            out[6, b0 + i] = qw
