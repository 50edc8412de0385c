"""The sparse KKT stepping's mode store and factorisation cache, built from the modes'
networks (:class:`~lcs.network.NetworkRealisation`) the first time the kernel asks for a mode.
"""

from __future__ import annotations

import numpy as np

from lcs.bits import to_words, words
from lcs.model import ModeKey
from lcs.simulation.problem import Problem, mode_tuple
from lcs.simulation.switches import SwitchPlan

from .layout import (
    C_LEN,
    K_ALWAYS,
    K_BOTH_ACTIVE,
    K_COL_ACTIVE,
    K_COL_INACTIVE,
    K_ROW_ACTIVE,
    NF_LEN,
    NF_OUTSTATE,
    ST_D,
    ST_F,
    ST_LEN,
    ST_RW,
    ST_RX,
    ST_SU,
    ST_SX,
    ST_TEMPLATE,
    ST_YL,
    ST_YU,
    V_LEN,
    VF_YCOL,
    VF_YROW,
    VI_ORDER,
    VI_YORDER,
    VI_YPINV,
    KKTCache,
    NetStack,
)
from .lu import FACTOR_OK, factor, lu_arrays
from .ordering import minimum_degree

__all__ = ["NetStackBuilder", "NoNetwork", "cache_for", "compressed"]


class NoNetwork(Exception):
    """A mode that the sparse stepping cannot take (no network: an LCS given by its matrices,
    or a singular network matrix); the run goes on with the dense kernel."""


class _Flat:
    """A growing 1-D array (capacity doubling)."""

    def __init__(self, dtype):
        self.a = np.zeros(64, dtype)
        self.n = 0

    def extend(self, values) -> int:
        values = np.asarray(values, dtype=self.a.dtype)
        start = self.n
        need = start + values.size
        if need > self.a.size:
            grown = np.zeros(max(need, 2 * self.a.size), self.a.dtype)
            grown[:start] = self.a[:start]
            self.a = grown
        self.a[start:need] = values
        self.n = need
        return start


def compressed(major: np.ndarray, minor: np.ndarray, size: int):
    """Pointers (size + 1,) and the permutation that sorts entries by ``major`` then
    ``minor`` (CSR with major = rows, CSC with major = columns)."""
    order = np.lexsort((minor, major))
    ptr = np.zeros(size + 1, np.int64)
    np.cumsum(np.bincount(major, minlength=size), out=ptr[1:])
    return ptr, order


def _pow2_inverse(a: np.ndarray) -> np.ndarray:
    """Powers of two nearest 1/a (1 where a is 0), as
    :func:`lcs.integrators.moreau.sparse.step._pow2_inverse`."""
    out = np.ones_like(a)
    good = a > 0
    m, e = np.frexp(a[good])
    out[good] = np.ldexp(1.0, -e + (m < 2 ** -0.5))
    return out


class NetStackBuilder:
    """Every mode's network in a :class:`~lcs.integrators.moreau.sparse.layout.NetStack`, grown on
    demand.

    Parameters
    ----------
    problem : Problem
    plan : SwitchPlan
    theta : float
    n, m, p, r : int
        States, pairs, inputs, stored probes.
    src_maps : dict
        Source-driven switches' control rows per mode (checked as the dense stack does).
    base : ModeKey
        The guessed initial switch states.
    """

    def __init__(self, problem: Problem, plan: SwitchPlan, theta: float, n: int, m: int,
                 p: int, r: int, src_maps: dict, base: ModeKey):
        self.prob, self.plan, self.theta = problem, plan, float(theta)
        self.n, self.m, self.p, self.r = n, m, p, r
        self.k = len(plan.names)
        self.Wk = words(self.k)
        self.src_maps, self.base = src_maps, base
        self.keys: list[int] = []
        self.index: dict[int, int] = {}
        self.ptr = _Flat(np.int64)
        self.idx = _Flat(np.int64)
        self.val = _Flat(float)
        self.val2 = _Flat(float)
        self.kind = _Flat(np.int64)
        self.ivec = _Flat(np.int64)
        self.fvec = _Flat(float)
        self.cap = 0
        self.rows: dict[str, np.ndarray] = {}
        self.nmax = 1
        self.nzmax = 1
        self.tpl_nnz = 1  # the largest template
        self.cache_key = None
        self._grow(4)

    def _grow(self, cap: int) -> None:
        n, m, p, r = self.n, self.m, self.p, self.r
        shapes = {"dims": ((2,), np.int64), "tab": ((ST_LEN,), np.int64),
                  "vtab": ((V_LEN,), np.int64), "zw": ((m,), np.int64),
                  "key": ((self.Wk,), np.int64), "inp": ((p + 1,), np.int64),
                  "flags": ((NF_LEN,), np.int64), "Cy": ((r, n), float),
                  "Dy": ((r, m), float), "Fy": ((r, p), float)}
        c = self.count
        for name, (shape, dtype) in shapes.items():
            new = np.zeros((cap, *shape), dtype)
            if name in self.rows:
                new[:c] = self.rows[name][:c]
            self.rows[name] = new
        self.cap = cap

    @property
    def count(self) -> int:
        return len(self.keys)

    def mode_tuple(self, key: int) -> ModeKey:
        return mode_tuple(key, self.k)

    def arrays(self) -> NetStack:
        """The store as the kernel takes it."""
        rw = self.rows
        return NetStack(rw["dims"], rw["tab"], self.ptr.a, self.idx.a, self.val.a,
                        self.val2.a, self.kind.a, rw["vtab"], self.ivec.a, self.fvec.a,
                        rw["zw"], rw["key"], rw["inp"], rw["flags"], rw["Cy"], rw["Dy"],
                        rw["Fy"])

    def _structure(self, ptr: np.ndarray, idx, val, val2=None, kind=None) -> int:
        """Append a compressed structure (relative pointers); returns its start in ptr."""
        e = self.idx.extend(idx)
        self.val.extend(val)
        self.val2.extend(np.zeros(len(idx)) if val2 is None else val2)
        self.kind.extend(np.zeros(len(idx), np.int64) if kind is None else kind)
        return self.ptr.extend(np.asarray(ptr, np.int64) + e)

    def add(self, key: int) -> int:
        """Build the mode of ``key`` and append it; returns its id. Raises
        :class:`NoNetwork` for a mode without a usable network."""
        if key in self.index:
            return self.index[key]
        mode = self.mode_tuple(key)
        prob, n, m, p, theta = self.prob, self.n, self.m, self.p, self.theta
        net = prob.network(mode)
        if net is None:
            raise NoNetwork(f"mode {prob.describe(mode)} has no sparse network")
        _A, _B, _C, D, E, F = prob.mode_arrays(mode)
        out = prob.output(mode)
        prob.control_rows(mode, self.plan, self.src_maps, self.base)  # (the checks only)
        nz = net.nz
        N = nz + m
        zero = np.zeros(m, bool)
        zero[list(net.zero_w)] = True
        tpl = _template(net, D, theta, zero)
        tp, order = compressed(tpl[1], tpl[0], N)
        ti = tpl[0][order]
        union = tpl[4][order] != K_COL_INACTIVE
        up, ui = _pattern(tp, ti, union, N)
        q = minimum_degree(N, up, ui)
        yq, ylu = _factor_y(net, q)
        if ylu is None:
            raise NoNetwork(f"mode {prob.describe(mode)}: singular network matrix")
        if self.count == self.cap:
            self._grow(2 * self.cap)
        j = self.count
        rw = self.rows
        rw["dims"][j] = (nz, N)
        tab = rw["tab"][j]
        tab[ST_TEMPLATE] = self._structure(tp, ti, tpl[2][order], tpl[3][order],
                                           tpl[4][order])
        Sr, Sc, Sv = net.S
        xs = Sc < n
        ptr_, o = compressed(Sc[xs], Sr[xs], n)
        tab[ST_SX] = self._structure(ptr_, Sr[xs][o], Sv[xs][o])
        us = Sc >= n + m
        ptr_, o = compressed(Sc[us] - n - m, Sr[us], p)
        tab[ST_SU] = self._structure(ptr_, Sr[us][o], Sv[us][o])
        for st, (rr, cc, vv), rows_ in ((ST_RX, net.Rx, n), (ST_RW, net.Rw, m)):
            ptr_, o = compressed(rr, cc, rows_)
            tab[st] = self._structure(ptr_, cc[o], vv[o])
        Dk = np.array(D, dtype=float)
        Dk[zero] = 0.0
        Dk[:, zero] = 0.0
        dr, dc = np.nonzero(Dk)
        ptr_, o = compressed(dr, dc, m)
        tab[ST_D] = self._structure(ptr_, dc[o], Dk[dr, dc][o])
        fr, fc = np.nonzero(F)
        ptr_, o = compressed(fr, fc, m)
        tab[ST_F] = self._structure(ptr_, fc[o], np.asarray(F)[fr, fc][o])
        Lp, Li, Lx, Up, Ui, Ux, pinv, rs, cs = ylu
        tab[ST_YL] = self._structure(Lp, Li, Lx)
        tab[ST_YU] = self._structure(Up, Ui, Ux)
        vt = rw["vtab"][j]
        vt[VI_ORDER] = self.ivec.extend(q)
        vt[VI_YORDER] = self.ivec.extend(yq)
        vt[VI_YPINV] = self.ivec.extend(pinv)
        vt[VF_YROW] = self.fvec.extend(rs)
        vt[VF_YCOL] = self.fvec.extend(cs)
        rw["zw"][j] = zero
        rw["key"][j] = to_words(key, self.Wk)
        used = np.flatnonzero(np.any(np.asarray(E) != 0, axis=0)
                              | np.any(np.asarray(F) != 0, axis=0))
        rw["inp"][j, 0] = used.size
        rw["inp"][j, 1:1 + used.size] = used
        rw["Cy"][j] = out.Cy
        rw["Dy"][j] = out.Dy
        rw["Fy"][j] = out.Fy
        rw["flags"][j, NF_OUTSTATE] = int(
            out.Cy.shape == (n, n) and np.array_equal(out.Cy, np.eye(n))
            and not out.Dy.any() and not out.Fy.any() and not (out.duty >= 0).any())
        self.nmax = max(self.nmax, N)
        self.nzmax = max(self.nzmax, nz)
        self.tpl_nnz = max(self.tpl_nnz, len(ti))
        self.keys.append(key)
        self.index[key] = j
        return j


def _template(net, D, theta: float, zero: np.ndarray):
    """The KKT template's entries (rows, cols, val, val2, kind) for a step of length s:
    value ``val + s val2``; see :mod:`lcs.integrators.moreau.sparse.layout` for the kinds."""
    n, m, nz = net.n, net.m, net.nz
    Yr, Yc, Yv = net.Y
    Sr, Sc, Sv = net.S
    Rr, Rc, Rv = net.Rx
    # P = S_x Rx (nz x nz): its entries from each state's S column and Rx row
    xs = Sc < n
    sr, sk, sv = Sr[xs], Sc[xs], Sv[xs]
    o1 = np.argsort(sk, kind="stable")
    o2 = np.argsort(Rr, kind="stable")
    sr, sk, sv = sr[o1], sk[o1], sv[o1]
    rr, rc, rv = Rr[o2], Rc[o2], Rv[o2]
    s_start = np.searchsorted(sk, np.arange(n + 1))
    r_start = np.searchsorted(rr, np.arange(n + 1))
    pr, pc, pv = [], [], []
    for k in range(n):
        a = slice(s_start[k], s_start[k + 1])
        b = slice(r_start[k], r_start[k + 1])
        if a.start == a.stop or b.start == b.stop:
            continue
        pr.append(np.repeat(sr[a], b.stop - b.start))
        pc.append(np.tile(rc[b], a.stop - a.start))
        pv.append(np.outer(sv[a], rv[b]).ravel())
    if pr:
        pr_, pc_, pv_ = np.concatenate(pr), np.concatenate(pc), np.concatenate(pv)
    else:
        pr_ = pc_ = np.zeros(0, np.int64)
        pv_ = np.zeros(0)
    # the companion network's entries: Y (val) and -θ P (val2), coalesced
    rows = np.concatenate([Yr, pr_])
    cols = np.concatenate([Yc, pc_])
    lin = rows * nz + cols
    uniq, inv = np.unique(lin, return_inverse=True)
    v0 = np.bincount(inv, np.concatenate([Yv, np.zeros(pv_.size)]), uniq.size)
    v1 = np.bincount(inv, np.concatenate([np.zeros(Yv.size), -theta * pv_]), uniq.size)
    keep = (v0 != 0) | (v1 != 0)
    parts = [(uniq[keep] // nz, uniq[keep] % nz, v0[keep], v1[keep],
              np.full(int(keep.sum()), K_ALWAYS))]
    wr, wc, wv = net.Rw
    ok = ~zero[wr]
    parts.append((nz + wr[ok], wc[ok], wv[ok], np.zeros(int(ok.sum())),
                  np.full(int(ok.sum()), K_ROW_ACTIVE)))
    ls = (Sc >= n) & (Sc < n + m)
    lr, lc, lv = Sr[ls], Sc[ls] - n, Sv[ls]
    ok = ~zero[lc]
    parts.append((lr[ok], nz + lc[ok], -lv[ok], np.zeros(int(ok.sum())),
                  np.full(int(ok.sum()), K_COL_ACTIVE)))
    if theta != 1.0:
        dr, dc = np.nonzero(np.asarray(D))
        ok = ~zero[dr] & ~zero[dc]
        dr, dc = dr[ok], dc[ok]
        parts.append((nz + dr, nz + dc, (theta - 1.0) * np.asarray(D)[dr, dc],
                      np.zeros(dr.size), np.full(dr.size, K_BOTH_ACTIVE)))
    diag = nz + np.arange(m)
    parts.append((diag, diag, np.ones(m), np.zeros(m), np.full(m, K_COL_INACTIVE)))
    return tuple(np.concatenate([pt[i] for pt in parts]).astype(dt)
                 for i, dt in enumerate((np.int64, np.int64, float, float, np.int64)))


def _pattern(tp: np.ndarray, ti: np.ndarray, keep: np.ndarray, N: int):
    """The CSC pattern of the kept entries."""
    col = np.repeat(np.arange(N), np.diff(tp))
    ptr = np.zeros(N + 1, np.int64)
    np.cumsum(np.bincount(col[keep], minlength=N), out=ptr[1:])
    return ptr, np.ascontiguousarray(ti[keep])


def _factor_y(net, q: np.ndarray):
    """Y's order (the KKT order restricted to the network's unknowns) and its scaled
    factors ``(Lp, Li, Lx, Up, Ui, Ux, pinv, row scale, column scale)``, or None when Y is
    singular."""
    nz = net.nz
    yq = q[q < nz].astype(np.int64)
    Yr, Yc, Yv = net.Y
    rmax = np.zeros(nz)
    np.maximum.at(rmax, Yr, np.abs(Yv))
    rs = _pow2_inverse(rmax)
    cmax = np.zeros(nz)
    np.maximum.at(cmax, Yc, np.abs(Yv) * rs[Yr])
    cs = _pow2_inverse(cmax)
    ptr, o = compressed(Yc, Yr, nz)
    Ai = np.ascontiguousarray(Yr[o])
    Ax = np.ascontiguousarray((Yv * rs[Yr] * cs[Yc])[o])
    cap = 4 * len(Ai) + 16
    while True:
        arrs = lu_arrays(nz, cap, cap)
        st = factor(nz, ptr, Ai, Ax, yq, 0.1, 1e-13, *arrs)
        if st == FACTOR_OK or st != -2:
            break
        cap *= 4
    if st != FACTOR_OK:
        return yq, None
    Lp, Li, Lx, Up, Ui, Ux, pinv = arrs[0]
    return yq, (Lp, Li[:Lp[nz]].copy(), Lx[:Lp[nz]].copy(), Up, Ui[:Up[nz]].copy(),
                Ux[:Up[nz]].copy(), pinv, rs, cs)


def cache_for(slots: int, nmax: int, cap: int, Wm: int) -> KKTCache:
    """An empty :class:`~lcs.integrators.moreau.sparse.layout.KKTCache` of ``slots`` slots for
    matrices up to ``nmax`` unknowns with ``cap`` entries in each factor."""
    T = max(1, int(slots))
    H = 1 << max(4, (4 * T - 1).bit_length())
    return KKTCache(np.full(T, -1, np.int64), np.zeros(T), np.zeros((T, Wm), np.int64),
                    np.full(T, -2, np.int64), np.zeros((T, nmax + 1), np.int64),
                    np.zeros((T, cap), np.int64), np.zeros((T, cap)),
                    np.zeros((T, nmax + 1), np.int64), np.zeros((T, cap), np.int64),
                    np.zeros((T, cap)), np.zeros((T, nmax), np.int64), np.ones((T, nmax)),
                    np.ones((T, nmax)), np.zeros(C_LEN, np.int64), np.full(T, -1, np.int64),
                    np.full(H, -1, np.int64), np.full(H, -1, np.int64),
                    np.full(T, -1, np.int64), np.full(T, -1, np.int64))
