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
