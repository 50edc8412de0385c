"""Basins of attraction by simple cell mapping (C. S. Hsu, *Cell-to-Cell Mapping*, 1987).

A rectangle of two chosen states (the others held at fixed values) is divided into
``N0 x N1`` cells. Each cell's centre is mapped once through the map (one period of the
stroboscopic map); the cell containing the image is the cell's image, and an image outside
the rectangle (or a failed evaluation) goes to the *sink cell*. This turns the map into a map
on a finite set, whose structure is found exactly:

* *periodic groups*: cycles of cells (attractors of the cell map; a period-k orbit of the
  continuous map appears as a group of about k cells, or a few more when the cells are coarse);
* the *domain of attraction* (basin) of each group: every cell whose image chain ends in it;
* the *step number* of each cell: the number of iterations (periods) it takes to enter its
  group -- a discrete transient time.

The sink is group 0 (a cell "escapes" when its chain leaves the rectangle). The core
:func:`simple_cell_mapping` takes only the image array; :func:`cell_basins` evaluates the
images of any :class:`~.maps.Map` (in parallel) and runs it.
"""

from __future__ import annotations

import time
from collections.abc import Callable, Sequence
from dataclasses import dataclass, field

import numpy as np

from .. import interrupt
from .maps import Map, MapError
from .parallel import portable, task_engine

__all__ = ["NOT_COMPUTED", "Attractor", "BasinMap", "CellGrid", "GridAxis", "ScmResult",
           "cell_basins", "merge_touching_groups", "simple_cell_mapping"]

SINK = -1  # image index of the sink cell in the image arrays
#: Group and step number of a cell an interrupted map did not decide (BasinMap.computed).
NOT_COMPUTED = -1


@dataclass(frozen=True)
class GridAxis:
    """One axis of the cell grid: ``count`` cells covering ``[lo, hi]`` of state ``name``."""

    name: str
    lo: float
    hi: float
    count: int

    def __post_init__(self) -> None:
        if not (self.hi > self.lo) or int(self.count) < 1:
            raise ValueError(f"axis {self.name}: need hi > lo and count >= 1")

    @property
    def width(self) -> float:
        return (self.hi - self.lo) / self.count

    def centres(self) -> np.ndarray:
        """Cell centres, shape (count,)."""
        return self.lo + (np.arange(self.count) + 0.5) * self.width

    def locate(self, v: np.ndarray) -> np.ndarray:
        """Cell index of each value, -1 outside ``[lo, hi)`` (or non-finite)."""
        v = np.asarray(v, dtype=float)
        with np.errstate(invalid="ignore"):
            idx = np.floor((v - self.lo) / self.width)
        ok = np.isfinite(idx) & (idx >= 0) & (idx < self.count)
        return np.where(ok, idx, -1).astype(np.int64)


@dataclass(frozen=True)
class CellGrid:
    """A 2-D cell grid; flat cell index ``i0 * N1 + i1`` (axis 0 is the slow index)."""

    axes: tuple[GridAxis, GridAxis]

    @property
    def shape(self) -> tuple[int, int]:
        return (self.axes[0].count, self.axes[1].count)

    @property
    def size(self) -> int:
        return self.axes[0].count * self.axes[1].count

    def centres(self) -> np.ndarray:
        """Centres of all cells in flat order, shape (size, 2)."""
        a, b = np.meshgrid(self.axes[0].centres(), self.axes[1].centres(), indexing="ij")
        return np.stack([a.ravel(), b.ravel()], axis=1)

    def locate(self, points: np.ndarray) -> np.ndarray:
        """Flat cell index of each point (shape (K, 2)), :data:`SINK` outside."""
        p = np.asarray(points, dtype=float).reshape(-1, 2)
        i0 = self.axes[0].locate(p[:, 0])
        i1 = self.axes[1].locate(p[:, 1])
        return np.where((i0 >= 0) & (i1 >= 0), i0 * self.axes[1].count + i1, SINK)


@dataclass
class ScmResult:
    """Simple cell mapping of an image array.

    Attributes
    ----------
    group : ndarray of int64, shape (N,)
        Group (attractor) number each cell ends in: 0 = sink, 1, 2, ... periodic groups in
        order of discovery.
    steps : ndarray of int64, shape (N,)
        Iterations to enter the group (0 for cells of a periodic group; for the sink group,
        iterations until the chain leaves the grid, counting the leaving step).
    periodic : ndarray of bool, shape (N,)
        Cell belongs to a periodic group.
    groups : list of ndarray
        ``groups[g - 1]``: cells of periodic group g in cycle order.
    """

    group: np.ndarray
    steps: np.ndarray
    periodic: np.ndarray
    groups: list[np.ndarray]


def simple_cell_mapping(image: np.ndarray) -> ScmResult:
    """Periodic groups, domains of attraction and step numbers of a cell map.

    Parameters
    ----------
    image : ndarray of int, shape (N,)
        ``image[i]``: the cell the centre of cell i maps into, or :data:`SINK` (-1).

    Returns
    -------
    ScmResult

    Notes
    -----
    Hsu's unravelling algorithm: follow each unprocessed cell's image chain, marking it,
    until it reaches a processed cell (the chain joins that cell's group, with step numbers
    counted back from it) or a cell of the chain itself (a new periodic group: the cells from
    that cell on). Every cell is visited once: O(N).
    """
    image = np.asarray(image, dtype=np.int64)
    N = image.size
    if np.any((image < SINK) | (image >= N)):
        raise ValueError("image entries must be cell indices or -1 (sink)")
    group = np.full(N, -2, dtype=np.int64)  # -2 unprocessed, -3 on the current chain
    steps = np.zeros(N, dtype=np.int64)
    periodic = np.zeros(N, dtype=bool)
    groups: list[np.ndarray] = []
    img = image.tolist()
    grp = group  # alias: numpy scalar access in the loop is the cost, keep it simple
    pos_in_chain: dict[int, int] = {}
    for start in range(N):
        if grp[start] != -2:
            continue
        chain: list[int] = []
        pos_in_chain.clear()
        c = start
        while c != SINK and grp[c] == -2:
            grp[c] = -3
            pos_in_chain[c] = len(chain)
            chain.append(c)
            c = img[c]
        if c == SINK:
            g, base = 0, 1  # the last chain cell maps out: 1 step to the sink
            tail = chain
        elif grp[c] == -3:
            # A new periodic group: the chain from c on.
            j = pos_in_chain[c]
            cyc = np.array(chain[j:], dtype=np.int64)
            groups.append(cyc)
            g = len(groups)
            grp[cyc] = g
            periodic[cyc] = True
            steps[cyc] = 0
            tail, base = chain[:j], 1
        else:
            g, base = int(grp[c]), int(steps[c]) + 1
            tail = chain
        # Cells before the joining point: steps counted back from it.
        for k, cell in enumerate(reversed(tail)):
            grp[cell] = g
            steps[cell] = base + k
    return ScmResult(group=group, steps=steps, periodic=periodic, groups=groups)


@dataclass
class Attractor:
    """A periodic group of the cell map.

    Attributes
    ----------
    group : int
        Group number (1, 2, ...).
    cells : ndarray of int64
        Flat indices of its cells, in cycle order.
    points : ndarray, shape (k, 2)
        Their centres (values of the two grid states).
    basin_cells : int
        Number of cells in its domain of attraction (including its own).
    """

    group: int
    cells: np.ndarray
    points: np.ndarray
    basin_cells: int

    @property
    def period(self) -> int:
        return int(self.cells.size)


@dataclass
class BasinMap:
    """Basins of attraction on a 2-D cell grid.

    Attributes
    ----------
    grid : CellGrid
    base_state : ndarray, shape (n,)
        The full state used for every cell (the two grid states replaced by the centre).
    state_indices : tuple[int, int]
        Positions of the grid states in the map state.
    image : ndarray of int64, shape (N0, N1)
        Image cell (flat index) of each cell, -1 sink.
    group : ndarray of int64, shape (N0, N1)
        Attractor number per cell (0 = sink: leaves the grid or fails).
    steps : ndarray of int64, shape (N0, N1)
        Periods to reach the attractor.
    attractors : list of Attractor
    failed : ndarray of bool, shape (N0, N1)
        The map could not be evaluated at the centre (mapped to the sink).
    param : float or None
    wall_time : float
    notes : list of str
    engine : str
        Where the cell images were computed.
    computed : ndarray of bool, shape (N0, N1), or None
        An interrupted map: the cells whose image was computed (the others, and the cells
        whose image chain reaches them, have group and steps :data:`NOT_COMPUTED`); None
        when every cell was.
    """

    grid: CellGrid
    base_state: np.ndarray
    state_indices: tuple[int, int]
    image: np.ndarray
    group: np.ndarray
    steps: np.ndarray
    attractors: list[Attractor]
    failed: np.ndarray
    param: float | None = None
    param_name: str | None = None
    wall_time: float = 0.0
    notes: list[str] = field(default_factory=list)
    engine: str = ""
    computed: np.ndarray | None = None

    def arrays(self) -> dict[str, np.ndarray]:
        """Arrays ``group``, ``steps``, ``image``, ``failed`` (N0, N1), the axes
        (``axis0_centres``, ``axis1_centres``, ``axis_names``, ``axis_bounds``) and the
        attractors (``attractor_groups``, ``attractor_cells`` flat, ``attractor_offsets``):
        the members of ``pelcs basins -o OUT.npz``."""
        cells = [a.cells for a in self.attractors]
        offsets = np.cumsum([0] + [c.size for c in cells])
        return dict(
            group=self.group, steps=self.steps, image=self.image, failed=self.failed,
            axis_names=np.array([a.name for a in self.grid.axes]),
            axis_bounds=np.array([[a.lo, a.hi] for a in self.grid.axes]),
            axis0_centres=self.grid.axes[0].centres(),
            axis1_centres=self.grid.axes[1].centres(),
            base_state=self.base_state, state_indices=np.array(self.state_indices),
            attractor_groups=np.array([a.group for a in self.attractors], dtype=np.int64),
            attractor_cells=np.concatenate(cells) if cells else np.empty(0, np.int64),
            attractor_offsets=offsets,
            param=np.array(np.nan if self.param is None else self.param),
            param_name=np.array(self.param_name or ""),
            **({} if self.computed is None else {"computed": self.computed}),
        )


def merge_touching_groups(scm: ScmResult, grid: CellGrid) -> ScmResult:
    """Merge periodic groups whose cells are 8-neighbours on the grid (one attractor).

    Step numbers are kept: a cell of a merged group still counts the periods to reach its
    own periodic group.
    """
    ng = len(scm.groups)
    if ng < 2:
        return scm
    parent = list(range(ng + 1))

    def find(a: int) -> int:
        while parent[a] != a:
            parent[a] = parent[parent[a]]
            a = parent[a]
        return a

    n1 = grid.axes[1].count
    n0 = grid.axes[0].count
    owner = {int(c): g for g, cyc in enumerate(scm.groups, start=1) for c in cyc}
    for c, g in owner.items():
        i0, i1 = divmod(c, n1)
        for d0 in (-1, 0, 1):
            for d1 in (-1, 0, 1):
                j0, j1 = i0 + d0, i1 + d1
                if 0 <= j0 < n0 and 0 <= j1 < n1:
                    other = owner.get(j0 * n1 + j1)
                    if other is not None and find(other) != find(g):
                        parent[find(other)] = find(g)
    roots = sorted({find(g) for g in range(1, ng + 1)})
    if len(roots) == ng:
        return scm
    new_id = {r: k for k, r in enumerate(roots, start=1)}
    relabel = np.zeros(ng + 1, dtype=np.int64)
    for g in range(1, ng + 1):
        relabel[g] = new_id[find(g)]
    groups = [np.concatenate([scm.groups[g - 1] for g in range(1, ng + 1)
                              if relabel[g] == k]) for k in range(1, len(roots) + 1)]
    return ScmResult(group=relabel[scm.group], steps=scm.steps, periodic=scm.periodic,
                     groups=groups)


def _image_task(task, report) -> tuple[np.ndarray, np.ndarray]:
    """Worker: images of a block of cell centres."""
    source, param, points, base, idx = task
    m = source if isinstance(source, Map) else source(param)
    out = np.full((points.shape[0], 2), np.nan)
    failed = np.zeros(points.shape[0], dtype=bool)
    x = np.array(base, dtype=float)
    done = 0
    for k, p in enumerate(points):
        x[idx[0]], x[idx[1]] = p
        try:
            y = m(x)
            out[k] = y[idx[0]], y[idx[1]]
        except MapError:
            failed[k] = True
        done += 1
        if done == 64:
            report(done)
            done = 0
    report(done)
    return out, failed


def cell_basins(
    source: Map | Callable[[float], Map],
    grid: CellGrid | Sequence[tuple[str, float, float, int]],
    *,
    param: float | None = None,
    base_state=None,
    merge_adjacent: bool = True,
    workers: int | None = None,
    progress: bool = False,
    start_method: str | None = None,
    scheduler=None,
) -> BasinMap:
    """Basins of attraction of a map on a 2-D cell grid (simple cell mapping).

    Parameters
    ----------
    source : Map or callable
        The map itself (pickled to the workers: fine for a :class:`~.maps.FunctionMap` of a
        module-level function), or a factory ``factory(param) -> Map`` (e.g.
        :class:`netlist.studies.sweep.CircuitMapFactory`), which each worker calls once.
    grid : CellGrid or sequence of two ``(state name, lo, hi, count)``
        The grid states are named as the map names its states (case-insensitive).
    param : float, optional
        Parameter value for the factory.
    base_state : array_like, shape (n,), optional
        Values of the states that are not on the grid (default zeros, or the map's ``x0``).
    merge_adjacent : bool
        Merge periodic groups whose cells touch (8-neighbourhood) into one attractor: a fixed
        point near a cell corner otherwise shows up as up to four one-cell groups, each with
        a sliver of the basin (the cell map's resolution limit, not dynamics).
    workers : int, optional
        Local processes (default all cores).
    progress : bool
    start_method : str, optional
    scheduler : None, str or distributed.Client, optional
        Where the cell images are computed (:func:`~.parallel.task_engine`): default
        locally; ``"local"`` a Dask local cluster; a Dask scheduler address or client. The
        basin map is the same whatever computes it.

    Returns
    -------
    BasinMap
    """
    t_wall = time.perf_counter()
    if not isinstance(grid, CellGrid):
        axes = tuple(GridAxis(str(n), float(lo), float(hi), int(c)) for n, lo, hi, c in grid)
        if len(axes) != 2:
            raise ValueError("the grid needs exactly two axes")
        grid = CellGrid(axes)  # type: ignore[arg-type]
    m = source if isinstance(source, Map) else source(param)
    lower = [s.lower() for s in m.state_names]
    try:
        idx = tuple(lower.index(a.name.lower()) for a in grid.axes)
    except ValueError:
        raise KeyError(f"grid states {[a.name for a in grid.axes]} must be states of the map: "
                       f"{', '.join(m.state_names)}") from None
    if idx[0] == idx[1]:
        raise ValueError("the two grid axes must be different states")
    if base_state is None:
        x0 = getattr(m, "x0", None)
        base_state = np.zeros(m.dim) if x0 is None else np.asarray(x0, dtype=float)
    base = np.asarray(base_state, dtype=float).copy()
    centres = grid.centres()
    src_param = None if isinstance(source, Map) else param
    with task_engine(scheduler, workers, start_method=start_method) as engine:
        if engine.distributed:
            source = portable(source)
        nw = engine.workers
        n_blocks = min(centres.shape[0], max(1, 8 * nw if nw > 1 else 1))
        blocks = np.array_split(np.arange(centres.shape[0]), n_blocks)
        tasks = [(source, src_param, centres[b], base, idx) for b in blocks]
        results = engine.run(_image_task, tasks, progress=progress, total=centres.shape[0],
                             desc="cells", unit="cell", partial=True)
        engine_name = engine.description
    # An interrupt (lcs.interrupt) leaves the blocks under way unfinished (None): their
    # cells are not computed.
    computed = np.ones(centres.shape[0], dtype=bool)
    for b, r in zip(blocks, results, strict=True):
        if r is None:
            computed[b] = False
    results = [r if r is not None else (np.full((b.size, 2), np.nan),
                                        np.zeros(b.size, dtype=bool))
               for b, r in zip(blocks, results, strict=True)]
    images = np.concatenate([r[0] for r in results])
    failed = np.concatenate([r[1] for r in results])
    image = grid.locate(images)
    scm = simple_cell_mapping(image)  # (a cell not computed maps to the sink here)
    if merge_adjacent:
        scm = merge_touching_groups(scm, grid)
    unknown = None if computed.all() else _unknown_cells(scm, image, computed)
    if unknown is not None:
        scm.group[unknown] = NOT_COMPUTED
        scm.steps[unknown] = NOT_COMPUTED
    attractors = []
    for g, cyc in enumerate(scm.groups, start=1):
        attractors.append(Attractor(group=g, cells=cyc, points=centres[cyc],
                                    basin_cells=int(np.count_nonzero(scm.group == g))))
    shape = grid.shape
    notes = []
    if failed.any():
        notes.append(f"{int(failed.sum())} cell(s) could not be mapped (simulation failed); "
                     "they go to the sink")
    if unknown is not None:
        signum = interrupt.requested()
        how = f" ({interrupt.signal_name(signum)})" if signum is not None else ""
        notes.insert(0, f"the basins were interrupted{how} after {int(computed.sum())} of "
                     f"{computed.size} cells: {int(unknown.sum())} cell(s) not computed or "
                     f"whose image chain reaches one are group and steps {NOT_COMPUTED} "
                     "(white in the plot); the attractors and basins found are of the "
                     "computed cells")
    return BasinMap(
        grid=grid, base_state=base, state_indices=idx, image=image.reshape(shape),
        group=scm.group.reshape(shape), steps=scm.steps.reshape(shape), attractors=attractors,
        failed=failed.reshape(shape), param=m.param, param_name=m.param_name,
        wall_time=time.perf_counter() - t_wall, notes=notes, engine=engine_name,
        computed=None if unknown is None else computed.reshape(shape),
    )


def _unknown_cells(scm: ScmResult, image: np.ndarray, computed: np.ndarray) -> np.ndarray:
    """The cells whose group is unknown: not computed, or whose image chain reaches a cell
    not computed. Such chains end in the sink (a cell not computed is mapped there), so
    they are followed back from it in the order of their step numbers."""
    unknown = ~computed
    sink = np.flatnonzero((scm.group == 0) & computed)
    for cell in sink[np.argsort(scm.steps[sink], kind="stable")]:
        nxt = image[cell]
        if nxt != SINK and unknown[nxt]:
            unknown[cell] = True
    return unknown
