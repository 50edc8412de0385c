"""Graph helpers for the formulation: loops and cutsets of a circuit's branch graph.

A circuit is a multigraph whose vertices are nodes and whose edges are two-terminal branches.
Two topological degeneracies stop a circuit from having an explicit state-space form:

- a *loop* made only of voltage-defined branches (capacitors, voltage sources, closed
  switches, E/H sources): Kirchhoff's voltage law ties their voltages together;
- a *cutset* made only of current-defined branches (inductors, current sources, F/G sources):
  Kirchhoff's current law ties their currents together.

:func:`find_loop` finds a cycle in the subgraph of the voltage-defined branches;
:func:`find_cutset` contracts every branch that is *not* current-defined and looks for a
current-defined branch joining two different super-nodes (every super-node with such a branch
is bounded by a cutset of current-defined branches).
"""

from __future__ import annotations

from collections import deque
from collections.abc import Iterable, Sequence

Branch = tuple[str, str, str]  # (element name, node a, node b)


class UnionFind:
    """Disjoint sets of hashable items with path halving."""

    def __init__(self) -> None:
        self._parent: dict[str, str] = {}

    def find(self, item: str) -> str:
        parent = self._parent
        parent.setdefault(item, item)
        while parent[item] != item:
            parent[item] = parent[parent[item]]
            item = parent[item]
        return item

    def union(self, a: str, b: str) -> bool:
        """Merge the sets of ``a`` and ``b``; False if they already were one set."""
        ra, rb = self.find(a), self.find(b)
        if ra == rb:
            return False
        self._parent[ra] = rb
        return True

    def roots(self) -> dict[str, str]:
        """Every item seen, with the representative of its set."""
        return {item: self.find(item) for item in list(self._parent)}


def _forest_path(adjacency: dict[str, list[tuple[str, str]]], start: str, goal: str) -> list[str]:
    """Names of the edges on the unique path from ``start`` to ``goal`` in a forest."""
    previous: dict[str, tuple[str, str] | None] = {start: None}
    queue = deque([start])
    while queue:
        node = queue.popleft()
        if node == goal:
            break
        for neighbour, name in adjacency.get(node, ()):
            if neighbour not in previous:
                previous[neighbour] = (node, name)
                queue.append(neighbour)
    path: list[str] = []
    node = goal
    while previous.get(node) is not None:
        node, name = previous[node]  # type: ignore[misc]
        path.append(name)
    path.reverse()
    return path


def find_loop(branches: Sequence[Branch]) -> list[str] | None:
    """A cycle among ``branches``, as element names, or None if they form a forest.

    Branches are taken in order; the first one that closes a cycle is reported together with
    the path between its ends through the earlier branches (a self-loop, both terminals on one
    node, is a cycle of one branch).

    Parameters
    ----------
    branches : sequence of (name, node_a, node_b)
        The branches of the subgraph, e.g. the voltage-defined branches of one switch mode.

    Returns
    -------
    list of str or None
        The element names on the cycle, the closing branch last.
    """
    uf = UnionFind()
    adjacency: dict[str, list[tuple[str, str]]] = {}
    for name, a, b in branches:
        if a == b:
            return [name]
        if not uf.union(a, b):
            return _forest_path(adjacency, a, b) + [name]
        adjacency.setdefault(a, []).append((b, name))
        adjacency.setdefault(b, []).append((a, name))
    return None


def find_cutset(
    contracted: Iterable[tuple[str, str]],
    branches: Sequence[Branch],
    ground: str,
) -> list[str] | None:
    """A cutset made only of ``branches``, or None if there is none.

    Parameters
    ----------
    contracted : iterable of (node_a, node_b)
        Every branch that is *not* current-defined (resistors, diodes, voltage-defined
        branches); these are contracted, so their nodes merge into super-nodes.
    branches : sequence of (name, node_a, node_b)
        The current-defined branches (inductors, current sources, F/G sources).
    ground : str
        The ground node; the super-node holding it is never the one reported, because the
        other side of a cut is more telling (e.g. "L1, I1" at one node).

    Returns
    -------
    list of str or None
        The names of the branches that join the reported super-node to the rest of the
        circuit: the smallest such cut among the super-nodes without ground, ties broken by
        netlist order.
    """
    uf = UnionFind()
    for a, b in contracted:
        uf.union(a, b)
    ground_root = uf.find(ground)
    cuts: dict[str, list[str]] = {}
    for name, a, b in branches:
        ra, rb = uf.find(a), uf.find(b)
        if ra == rb:
            continue
        for root in (ra, rb):
            if root != ground_root:
                cuts.setdefault(root, []).append(name)
    if not cuts:
        return None
    return min(cuts.values(), key=len)


def bridges(edges: Sequence[tuple[str, str]]) -> set[int]:
    """Indices of the bridges of a multigraph: the edges whose removal disconnects their two
    ends (a self-loop never is one; of two parallel edges, neither is).

    One depth-first search (Tarjan's low-link), O(nodes + edges), iterative.
    """
    adjacency: dict[str, list[tuple[str, int]]] = {}
    for i, (a, b) in enumerate(edges):
        if a == b:
            continue
        adjacency.setdefault(a, []).append((b, i))
        adjacency.setdefault(b, []).append((a, i))
    order: dict[str, int] = {}
    low: dict[str, int] = {}
    out: set[int] = set()
    for root in adjacency:
        if root in order:
            continue
        order[root] = low[root] = len(order)
        # (node, edge it was reached by, position in its adjacency list)
        stack: list[list] = [[root, -1, 0]]
        while stack:
            frame = stack[-1]
            node, via, pos = frame
            nbrs = adjacency[node]
            if pos < len(nbrs):
                frame[2] = pos + 1
                nxt, eid = nbrs[pos]
                if eid == via:
                    continue
                if nxt in order:
                    low[node] = min(low[node], order[nxt])
                else:
                    order[nxt] = low[nxt] = len(order)
                    stack.append([nxt, eid, 0])
                continue
            stack.pop()
            if stack:
                parent = stack[-1][0]
                low[parent] = min(low[parent], low[node])
                if low[node] > order[parent]:
                    out.add(via)
    return out


class Partition:
    """The connected components of a fixed set of edges, merged per query with a few more.

    A switch mode's union-finds (the nodes joined by its voltage-defined branches, by those
    and the resistors, by its closed switches) differ only in the closed switches: the
    components of the other branches are found once and each mode unions its switches on
    top of them (a 64-cell MMC arm: 64-128 unions a mode instead of about 450).

    Parameters
    ----------
    edges : sequence of (node_a, node_b)
        The edges present in every query.
    """

    def __init__(self, edges: Sequence[tuple[str, str]]):
        uf = UnionFind()
        # (a cycle, a self-loop included, among the fixed edges)
        self.has_cycle = False
        for a, b in edges:
            if not uf.union(a, b):
                self.has_cycle = True
        self._root = uf.roots()

    def joined(self, extra: Iterable[tuple[str, str]]) -> tuple[UnionFind, bool]:
        """The fixed components merged with the ``extra`` edges, and whether any extra edge
        closed a cycle (with the fixed edges or the earlier extra edges; a self-loop does).

        Returns a union-find over the components' representatives: two nodes are joined
        when ``uf.find(partition.root(a)) == uf.find(partition.root(b))``.
        """
        uf = UnionFind()
        cycle = False
        root = self._root
        for a, b in extra:
            if not uf.union(root.get(a, a), root.get(b, b)):
                cycle = True
        return uf, cycle

    def root(self, node: str) -> str:
        """The representative of ``node``'s component among the fixed edges."""
        return self._root.get(node, node)


class SwitchedBridges:
    """The bridges among fixed edges once some of a set of optional edges are added.

    The bridges of the fixed edges alone are found once, and their 2-edge-connected
    components contracted (contracting a connected subgraph keeps the bridge status of every
    edge outside it): the fixed bridges form a forest over the components, less its branches
    that no optional edge reaches (a gate drive's source: a bridge in every query). An
    optional edge inside one component changes nothing; the others are added to the trees of
    the forest that they touch, and only those trees are searched again. On a 64-cell MMC
    arm every switch lies inside one component: no search a mode, where two searches of about
    450 edges each took 2-4 ms.

    Parameters
    ----------
    fixed : sequence of (node_a, node_b)
        The edges present in every query (indexed as given).
    optional : sequence of (node_a, node_b)
        The edges a query may add (e.g. the switches, closed or not).
    """

    def __init__(self, fixed: Sequence[tuple[str, str]],
                 optional: Sequence[tuple[str, str]]):
        self.size = len(fixed)
        self._fixed_bridges = frozenset(bridges(fixed))
        uf = UnionFind()
        for i, (a, b) in enumerate(fixed):
            if i not in self._fixed_bridges:
                uf.union(a, b)
        comp: dict[str, str] = {}
        for a, b in (*fixed, *optional):
            for node in (a, b):
                if node not in comp:
                    comp[node] = uf.find(node)
        # The forest: the fixed bridges between components, grouped by tree.
        self._optional = [(comp[a], comp[b]) for a, b in optional]
        forest = _prune([(comp[fixed[i][0]], comp[fixed[i][1]], i)
                         for i in sorted(self._fixed_bridges)],
                        {c for edge in self._optional for c in edge})
        trees = UnionFind()
        for ca, cb, _ in forest:
            trees.union(ca, cb)
        self._tree = {c: trees.find(c) for c in set(comp.values())}
        self._forest: dict[str, list[tuple[str, str, int]]] = {}
        for edge in forest:
            self._forest.setdefault(self._tree[edge[0]], []).append(edge)

    def bridges(self, present: Iterable[int]) -> set[int]:
        """Indices of the fixed edges that are bridges of the fixed edges and the optional
        edges ``present`` (indices into ``optional``)."""
        added = [self._optional[j] for j in present]
        added = [(ca, cb) for ca, cb in added if ca != cb]
        out = set(self._fixed_bridges)
        if not added:
            return out
        touched = dict.fromkeys(self._tree[c] for edge in added for c in edge)
        forest = [edge for t in touched for edge in self._forest.get(t, ())]
        # Bridges of the touched trees with the added edges (those last: not asked about).
        cut = bridges([(ca, cb) for ca, cb, _ in forest] + added)
        out.difference_update(i for k, (_, _, i) in enumerate(forest) if k not in cut)
        return out


def _prune(forest: list[tuple[str, str, int]], keep: set[str]) -> list[tuple[str, str, int]]:
    """The edges of a forest less its branches without a vertex of ``keep``: leaves not in
    ``keep`` are cut off, then the leaves that leaves, until none is left."""
    degree: dict[str, int] = {}
    at: dict[str, list[int]] = {}
    for k, (a, b, _) in enumerate(forest):
        for v in (a, b):
            degree[v] = degree.get(v, 0) + 1
            at.setdefault(v, []).append(k)
    cut = [False] * len(forest)
    leaves = [v for v, d in degree.items() if d == 1 and v not in keep]
    while leaves:
        v = leaves.pop()
        for k in at[v]:
            if cut[k]:
                continue
            cut[k] = True
            a, b, _ = forest[k]
            other = b if a == v else a
            degree[other] -= 1
            if degree[other] == 1 and other not in keep:
                leaves.append(other)
    return [edge for k, edge in enumerate(forest) if not cut[k]]
