"""Switching instants of the switches driven by independent sources, before any integration.

Switches driven by independent sources (the control's output map has ``Cy = 0`` and ``Dy = 0``)
have a control that is a known function of time, ``c(t) = Fy u(t)``. Their switching instants
are computed before stepping: exactly on piecewise-linear segments (DC, PULSE, PWL between
breakpoints), by sampling and ``brentq`` otherwise. State-dependent controls (comparators) are
located inside the steps by the kernel (:mod:`lcs.integrators.moreau.dense`); here they only keep
their initial state while the source-driven instants are computed.

This module holds the compiled path (controls whose rows do not depend on the mode, on
piecewise-linear sources); the others take the general path of
:mod:`lcs.simulation.source_general`. The band rules are :mod:`lcs.simulation.switch_bands`.
"""

from __future__ import annotations

from collections.abc import Sequence
from dataclasses import dataclass

import numpy as np

from ..bits import from_words, to_words, words
from ..jit import jitted
from ..model import SwitchedLCS
from .inputs import MERGE_FRACTION, InputFunction, evaluate_inputs
from .source_general import general_events
from .switch_bands import SUB_BAND_OFF, SUB_BAND_ON, band_rule, initial_sub, initially_on, sub_on


@dataclass
class _ControlMaps:
    """Per mode, the rows ``Fy`` (k, p) of the switch controls as functions of the inputs
    (zero rows for the switches not in ``which``)."""

    system: SwitchedLCS
    cache: dict
    which: frozenset | None = None

    def rows(self, mode) -> np.ndarray:
        if mode not in self.cache:
            sw = self.system.switches
            Fy = np.zeros((len(sw), len(self.system.inputs)))
            idx = [i for i in range(len(sw)) if self.which is None or i in self.which]
            if idx:
                # One output map for every control of the mode (a map per switch cost 128
                # evaluations a mode on a 64-cell MMC arm), checked as a whole (two np.any
                # per switch were 0.1 s of that arm's run).
                om = self.system.outputs(mode, [sw[i].control for i in idx])
                Cy = np.asarray(om.Cy, dtype=float).reshape(len(idx), -1)
                Dy = np.asarray(om.Dy, dtype=float).reshape(len(idx), -1)
                state_dependent = np.any(Cy != 0, axis=1) | np.any(Dy != 0, axis=1)
                if state_dependent.any():
                    i = idx[int(np.argmax(state_dependent))]
                    raise NotImplementedError(
                        f"switch {sw[i].name}: its control {sw[i].control!r} depends on "
                        f"the circuit state in mode {self.system.describe_mode(mode)} "
                        "although it is driven by sources alone in the initial mode; "
                        "switches whose kind (source-driven or comparator) changes with "
                        "the mode are not supported")
                Fy[idx] = np.asarray(om.Fy, dtype=float)
            self.cache[mode] = Fy
        return self.cache[mode]


@jitted
def _linear_switch_events(sa, sb, ca, cb, sub0, lo, hi, rule, out_t, out_on):
    """Switching instants of one switch whose control is linear on every segment
    ``[sa[s], sb[s]]`` (from the right limit ``ca[s]`` to the left limit ``cb[s]``), by
    ngspice's rule (:func:`~lcs.simulation.switch_bands.band_rule`): above the band
    ``[lo, hi]`` on, below it off, inside it as ``rule`` says from the sub-state ``sub0`` at
    ``sa[0]``. Writes instants and new states into ``out_t``/``out_on``; returns how many."""
    sub = sub0
    ne = 0
    ts = np.empty(3)
    rs = np.empty(3, np.int64)
    for s in range(sa.shape[0]):
        t0 = sa[s]
        t1 = sb[s]
        c0 = ca[s]
        c1 = cb[s]
        r0 = 0 if c0 < lo else (2 if c0 > hi else 1)
        r1 = 0 if c1 < lo else (2 if c1 > hi else 1)
        # The regions the control enters on the segment, in order: the one at its start (the
        # control may jump at a breakpoint), then the band edges it crosses (c is linear).
        ts[0] = t0
        rs[0] = r0
        k = 1
        if r1 > r0:
            if r0 == 0:
                ts[k] = min(max(t0 + (lo - c0) / (c1 - c0) * (t1 - t0), t0), t1)
                rs[k] = 1
                k += 1
            if r1 == 2:
                ts[k] = min(max(t0 + (hi - c0) / (c1 - c0) * (t1 - t0), t0), t1)
                rs[k] = 2
                k += 1
        elif r1 < r0:
            if r0 == 2:
                ts[k] = min(max(t0 + (hi - c0) / (c1 - c0) * (t1 - t0), t0), t1)
                rs[k] = 1
                k += 1
            if r1 == 0:
                ts[k] = min(max(t0 + (lo - c0) / (c1 - c0) * (t1 - t0), t0), t1)
                rs[k] = 0
                k += 1
        for j in range(k):
            r = rs[j]
            if r == 2:
                new = 1
            elif r == 0:
                new = 0
            elif sub >= 2:
                new = sub
            elif rule == 0:
                new = sub + 2
            elif rule == 1:
                new = 3 - sub
            else:
                new = 2
            was = sub == 1 or sub == 3
            now = new == 1 or new == 3
            if now != was:
                out_t[ne] = ts[j]
                out_on[ne] = now
                ne += 1
            sub = new
    return ne


def _linear_events(maps, mode0, sub0, active, bands, bounds, u_start, u_end, linear_inputs,
                   inputs, tol, t0):
    """Compiled path of :func:`source_switch_events` for piecewise-linear gates whose control
    rows do not depend on the mode (the usual case): per switch, a linear control crosses each
    threshold at most once per segment. Returns ``(mode0, events)`` or None when the
    conditions do not hold (then the generic path runs)."""
    rows = maps.rows(mode0)
    idx = sorted(active)
    for i in idx:
        if not (linear_inputs or all(getattr(inputs[j], "piecewise_linear", False)
                                     for j in np.flatnonzero(rows[i]))):
            return None
    ca_all = u_start @ rows.T
    cb_all = u_end @ rows.T
    sa = np.ascontiguousarray(bounds[:-1])
    sb = np.ascontiguousarray(bounds[1:])
    cap = 3 * len(sa) + 4
    times, sw_idx, states = [], [], []
    for i in idx:
        if not rows[i].any():
            continue
        out_t = np.empty(cap)
        out_on = np.empty(cap, np.bool_)
        lo, hi, rule = bands[i]
        ne = _linear_switch_events(sa, sb, np.ascontiguousarray(ca_all[:, i]),
                                   np.ascontiguousarray(cb_all[:, i]), int(sub0[i]), float(lo),
                                   float(hi), int(rule), out_t, out_on)
        times.append(out_t[:ne])
        sw_idx.append(np.full(ne, i))
        states.append(out_on[:ne])
    k = len(mode0)
    Wk = words(k)
    if not times:
        return tuple(mode0), (np.empty(0), np.empty((0, Wk), np.int64))
    t_all = np.concatenate(times)
    i_all = np.concatenate(sw_idx).astype(np.int64)
    on_all = np.concatenate(states)
    order = np.argsort(t_all, kind="stable")
    t_all, i_all, on_all = t_all[order], i_all[order], on_all[order]
    key0 = to_words(sum(1 << i for i, on in enumerate(mode0) if on), Wk)
    out_t = np.empty(len(t_all))
    out_k = np.empty((len(t_all), Wk), np.int64)
    ne = _merge_keys(np.ascontiguousarray(t_all), np.ascontiguousarray(i_all),
                     np.ascontiguousarray(on_all), key0, float(t0), float(tol), out_t, out_k,
                     np.empty(Wk, np.int64))

    def mode_of(key_words):
        key = from_words(key_words)
        return tuple(bool((key >> i) & 1) for i in range(k))

    # The rows must be the same in every mode reached (else the generic path decides).
    ref = rows[idx]
    scale = np.abs(ref).max() if idx else 0.0
    for key in {tuple(r) for r in out_k[:ne].tolist()} | {tuple(key0.tolist())}:
        other = maps.rows(mode_of(key))
        if other is rows:
            continue
        # (equal rows, the usual case, without allclose's temporaries)
        sub = other[idx]
        if not (np.array_equal(sub, ref)
                or np.allclose(sub, ref, rtol=0.0, atol=1e-13 * scale)):
            return None
    return mode_of(key0), (out_t[:ne].copy(), out_k[:ne].copy())


@jitted
def _merge_keys(t_all, i_all, on_all, key0, t0, tol, out_t, out_k, key):
    """Switch keys (bitsets, :mod:`lcs.bits`) after each instant: simultaneous instants (within
    ``tol``) merged, instants at ``t0`` folded into the initial key ``key0`` (updated), instants
    that change nothing dropped. Returns the number of instants kept."""
    W = key0.shape[0]
    for w in range(W):
        key[w] = key0[w]
    ne = 0
    for e in range(t_all.shape[0]):
        i = i_all[e]
        if on_all[e]:
            key[i >> 6] |= np.int64(1) << (i & 63)
        else:
            key[i >> 6] &= ~(np.int64(1) << (i & 63))
        t = t_all[e]
        if ne > 0 and abs(out_t[ne - 1] - t) <= tol:
            for w in range(W):
                out_k[ne - 1, w] = key[w]
        elif t <= t0 + tol:
            for w in range(W):
                key0[w] = key[w]
        else:
            out_t[ne] = t
            for w in range(W):
                out_k[ne, w] = key[w]
            ne += 1
    # Drop the instants that do not change the key.
    m = 0
    for e in range(ne):
        same = True
        for w in range(W):
            prev = key0[w] if m == 0 else out_k[m - 1, w]
            if out_k[e, w] != prev:
                same = False
        if not same:
            out_t[m] = out_t[e]
            for w in range(W):
                out_k[m, w] = out_k[e, w]
            m += 1
    return m


def source_switch_events(system: SwitchedLCS, inputs: Sequence[InputFunction], t0: float,
                         t1: float, breakpoints: np.ndarray, h: float,
                         which: Sequence[int] | None = None, base=None, maps_out=None,
                         as_arrays: bool = False):
    """Switch states at ``t0`` and switching instants in ``(t0, t1)`` for source-driven gates.

    Parameters
    ----------
    system : SwitchedLCS
    inputs : sequence of callables
        The resolved source waveforms, one per input of ``system``.
    t0, t1 : float
        Run interval, s.
    breakpoints : ndarray
        Sorted source breakpoints inside (t0, t1), s (the controls are smooth between them).
    h : float
        Step, s (sampling resolution for non-linear controls).
    which : sequence of int, optional
        Indices of the source-driven switches (default: all). The others keep their state in
        ``base`` (default: off) throughout.
    base : tuple of bool, optional
        States of the switches not in ``which``.
    maps_out : dict, optional
        Receives ``{mode: Fy rows (k, p)}`` of the controls used (for later consistency
        checks).
    as_arrays : bool
        Return the events as two arrays ``(times, keys)`` (keys: bit i set when switch i is
        on) instead of a list of ``(t, mode)``.

    Returns
    -------
    mode0 : tuple[bool, ...]
        Switch states at ``t0`` (on while control > vt + vh, off while < vt - vh; inside the
        band, the switch's ``options["initial"]`` (or ``"on"``), default off).
    events : list of (float, tuple[bool, ...])
        Switching instants (s) and the mode after them, increasing.

    Raises
    ------
    NotImplementedError
        If a switch of ``which`` has a control that depends on the state (``Cy`` or ``Dy``
        nonzero) in some mode, or switches that switch each other at one instant without
        settling (:func:`~lcs.simulation.source_general.general_events`).
    """
    sw = system.switches
    if not sw:
        return (), []
    active = frozenset(range(len(sw)) if which is None else which)
    maps = _ControlMaps(system, {} if maps_out is None else maps_out, frozenset(active))
    if not active:
        m0 = tuple(bool(b) for b in base) if base is not None else tuple(False for _ in sw)
        return m0, ((np.empty(0), np.empty((0, words(len(sw))), np.int64)) if as_arrays
                    else [])
    linear_inputs = all(getattr(f, "piecewise_linear", False) for f in inputs)

    def controls(mode, t, side):
        return evaluate_inputs(inputs, np.atleast_1d(t), side) @ maps.rows(mode).T

    bands = [band_rule(s) for s in sw]
    initial = [initially_on(s.options) for s in sw]
    if base is not None:
        initial = [initial[i] if i in active else bool(base[i]) for i in range(len(sw))]
    mode = tuple(initial)
    subs = [SUB_BAND_ON if on else SUB_BAND_OFF for on in mode]
    # Mode-dependent control maps: iterate to a fixed point (at most a few passes).
    for _ in range(len(sw) + 1):
        c0 = controls(mode, t0, +1)[0]
        subs = [initial_sub(float(c0[i]), sw[i]) if i in active else subs[i]
                for i in range(len(sw))]
        new = tuple(sub_on(subs[i]) if i in active else mode[i] for i in range(len(sw)))
        if new == mode:
            break
        mode = new
    mode0 = mode
    bounds = np.concatenate(([t0], breakpoints, [t1]))
    tol = MERGE_FRACTION * h
    # Inputs at every segment end, once (vectorised): right limits at the starts, left
    # limits at the ends. Controls are then small matrix products per segment.
    u_start = evaluate_inputs(inputs, bounds[:-1], +1)
    u_end = evaluate_inputs(inputs, bounds[1:], -1)
    fast = _linear_events(maps, mode0, subs, active, bands, bounds, u_start, u_end,
                          linear_inputs, inputs, tol, t0)
    if fast is not None:
        m0, (ft, fk) = fast
        if as_arrays:
            return m0, (ft, fk)
        k = len(sw)
        keys = [from_words(row) for row in fk]
        return m0, [(t, tuple(bool((key >> i) & 1) for i in range(k)))
                    for t, key in zip(ft.tolist(), keys, strict=True)]
    # The general path (control rows that depend on the mode, or sources that are not
    # piecewise linear): the switches moved one instant at a time.
    mode0, out = general_events(sw, active, maps.rows, inputs, linear_inputs, bands, subs,
                                mode0, bounds, u_start, u_end, h, tol, t0, controls)
    if as_arrays:
        Wk = words(len(sw))
        keys = np.zeros((len(out), Wk), np.int64)
        for r_, (_, md) in enumerate(out):
            keys[r_] = to_words(sum(1 << i for i, on in enumerate(md) if on), Wk)
        return mode0, (np.array([t for t, _ in out], dtype=float), keys)
    return mode0, out

