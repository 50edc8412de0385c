"""Simple cell mapping (lcs.analysis.basins): the core on hand-made cell maps, a 2-D map with
known basins, then a converter."""

from __future__ import annotations

import numpy as np
import pytest
from test_analysis_maps import buck_reference, netlists  # noqa: F401 - fixture

from lcs.analysis.basins import CellGrid, GridAxis, cell_basins, simple_cell_mapping
from lcs.analysis.maps import FunctionMap
from netlist.studies.sweep import CircuitMapFactory
from pelcs.analysis_plots import plot_basins, plot_bifurcation
from pelcs.writers import write_basins


def two_wells(v):
    """x -> s + 0.4 (x - s) with s = sign(x) for |x| <= 2, escapes (x -> 3x) beyond;
    y -> 0.4 y. Attractors (±1, 0); basins x < 0 and x > 0 inside |x| < 2. (The factor 0.4,
    not 0.5, keeps the images of cell centres off the cell boundaries.)"""
    x, y = v
    if abs(x) > 2:
        return np.array([3 * x, 0.4 * y])
    s = 1.0 if x > 0 else -1.0
    return np.array([s + 0.4 * (x - s), 0.4 * y])


def flip_xy(v):
    """x -> -x, y -> 0.4 y: every cell pair (x, -x) on the y = 0 row is a 2-cycle."""
    return np.array([-v[0], 0.4 * v[1]])


def test_scm_core_on_hand_made_cell_map():
    # 0 -> 1 -> 2 -> 1 (2-cycle {1, 2}); 3 -> 3 (fixed); 4 -> 3; 5 -> sink; 6 -> 5.
    img = np.array([1, 2, 1, 3, 3, -1, 5])
    r = simple_cell_mapping(img)
    assert len(r.groups) == 2
    g_cycle = r.group[1]
    assert r.group[0] == r.group[2] == g_cycle and sorted(r.groups[g_cycle - 1]) == [1, 2]
    assert r.group[3] == r.group[4] != g_cycle
    assert r.group[5] == r.group[6] == 0
    np.testing.assert_array_equal(r.steps, [1, 0, 0, 0, 1, 1, 2])
    np.testing.assert_array_equal(r.periodic, [False, True, True, True, False, False, False])
    with pytest.raises(ValueError):
        simple_cell_mapping(np.array([5, 0]))


def test_grid_locate_and_centres():
    g = CellGrid((GridAxis("a", 0, 1, 2), GridAxis("b", -1, 1, 4)))
    assert g.shape == (2, 4) and g.size == 8
    c = g.centres()
    assert c.shape == (8, 2)
    np.testing.assert_array_equal(g.locate(c), np.arange(8))
    np.testing.assert_array_equal(g.locate(np.array([[1.5, 0], [0.2, np.nan], [0.7, 0.9]])),
                                  [-1, -1, 7])


@pytest.mark.slow  # (over 0.4 s: outside the fast subset)
@pytest.mark.parametrize("workers", [1, 2])
def test_two_wells_known_basins(workers):
    # 61 x 21 cells of width 0.1 centred on the fixed points (±1, 0).
    m = FunctionMap(two_wells, ("x", "y"))
    bm = cell_basins(m, [("x", -3.05, 3.05, 61), ("y", -1.05, 1.05, 21)], workers=workers)
    assert len(bm.attractors) == 2
    pts = sorted(tuple(a.points.mean(axis=0)) for a in bm.attractors)
    np.testing.assert_allclose(pts, [(-1, 0), (1, 0)], atol=1e-12)
    assert all(a.period == 1 for a in bm.attractors)
    xs = bm.grid.axes[0].centres()
    g_of = {round(float(a.points[0, 0])): a.group for a in bm.attractors}
    for i, x in enumerate(xs):
        row = bm.group[i]
        if abs(x) > 2:
            assert (row == 0).all()  # escapes: sink
        elif x < -0.01:
            assert (row == g_of[-1]).all()
        elif x > 0.01:
            assert (row == g_of[1]).all()
    # Step numbers: zero on the attractor, growing away from it, 1 to leave the grid.
    i1, j0 = int(np.argmin(abs(xs - 1))), 10
    assert bm.steps[i1, j0] == 0
    assert bm.steps[i1 + 5, j0] > bm.steps[i1 + 1, j0] > 0
    assert (bm.steps[np.abs(xs) > 2] == 1).all()


@pytest.mark.slow  # (over 0.7 s: outside the fast subset)
def test_merging_touching_groups_and_two_cycles(tmp_path):
    m = FunctionMap(two_wells, ("x", "y"))
    # Fixed points on cell corners: four one-cell groups each, merged into one attractor.
    split = cell_basins(m, [("x", -3, 3, 60), ("y", -1, 1, 20)], workers=1,
                        merge_adjacent=False)
    merged = cell_basins(m, [("x", -3, 3, 60), ("y", -1, 1, 20)], workers=1)
    assert len(split.attractors) == 8 and len(merged.attractors) == 2
    assert sorted(a.period for a in merged.attractors) == [4, 4]
    fl = cell_basins(FunctionMap(flip_xy, ("x", "y")), [("x", -1.05, 1.05, 21),
                                                        ("y", -1.05, 1.05, 21)], workers=1,
                     merge_adjacent=False)
    # On the row y = 0 the cells x and -x form 2-cycles (x = 0 is a fixed cell).
    assert sorted(a.period for a in fl.attractors) == [1] + [2] * 10
    write_basins(fl, tmp_path / "b.npz")
    plot_basins(fl, tmp_path / "b.png")
    z = np.load(tmp_path / "b.npz")
    np.testing.assert_array_equal(z["group"], fl.group)
    assert z["attractor_offsets"][-1] == 21
    assert (tmp_path / "b.png").stat().st_size > 5000


@pytest.mark.slow  # (over 0.4 s: outside the fast subset)
def test_converter_basin(netlists):  # noqa: F811
    """Damped buck: one attractor, containing the fixed point of the expm reference map;
    every cell inside the region that maps into the grid reaches it."""
    Phi, c = buck_reference(0.5)
    x_ref = np.linalg.solve(np.eye(2) - Phi, c)
    f = CircuitMapFactory(netlists["buck"], period="ts")
    bm = cell_basins(f, [("v(C1)", 0, 24, 24), ("i(L1)", 0, 24, 24)], workers=2)
    assert len(bm.attractors) == 1
    at = bm.attractors[0]
    cell = bm.grid.locate(np.array([[x_ref[1], x_ref[0]]]))[0]
    assert cell in at.cells
    assert at.basin_cells + np.count_nonzero(bm.group == 0) == bm.grid.size
    assert at.basin_cells > 0.9 * bm.grid.size
    assert bm.steps.max() <= 10 and not bm.failed.any()
    assert bm.state_indices == (1, 0)


def test_grid_errors():
    m = FunctionMap(two_wells, ("x", "y"))
    with pytest.raises(KeyError):
        cell_basins(m, [("x", 0, 1, 2), ("z", 0, 1, 2)], workers=1)
    with pytest.raises(ValueError):
        cell_basins(m, [("x", 0, 1, 2), ("x", 0, 1, 2)], workers=1)
    with pytest.raises(ValueError):
        GridAxis("x", 1, 0, 3)


@pytest.mark.slow  # (over 0.7 s: outside the fast subset)
def test_plots_label_circuit_states_with_their_units(tmp_path, monkeypatch):
    # Basins and bifurcation figures name the states on their axes with units (v(...) in
    # V, i(...) in A); a state without a known unit keeps its bare name.
    from matplotlib.figure import Figure

    from lcs.analysis.bifurcation import bifurcation_diagram

    labels = []
    save = Figure.savefig

    def capture(self, *args, **kwargs):
        labels.append({lab for ax in self.axes for lab in (ax.get_xlabel(), ax.get_ylabel())})
        return save(self, *args, **kwargs)

    monkeypatch.setattr(Figure, "savefig", capture)
    m = FunctionMap(two_wells, ("v(C1)", "i(L1)"))
    plot_basins(cell_basins(m, [("v(C1)", -3, 3, 12), ("i(L1)", -1, 1, 4)], workers=1),
                tmp_path / "b.png")
    assert {"v(C1) [V]", "i(L1) [A]"} <= labels[-1]

    def factory(p):
        return FunctionMap(lambda x, p=p: np.array([p * x[0] * (1 - x[0]), 0.0]),
                           ("v(out)", "k"), param=p)

    plot_bifurcation(bifurcation_diagram(factory, [2.8, 3.0, 3.2], x0=[0.3, 0.0],
                                         transient=20, record=2, workers=1, param_name="p"),
                     tmp_path / "d.png")
    assert {"v(out) [V]", "k", "p"} <= labels[-1]
