"""netlist.topology.bridges against the definition (remove the edge, are its ends still
joined?), checked by union-find on random multigraphs."""

from __future__ import annotations

import random

from netlist.topology import UnionFind, bridges


def _bridges_by_definition(edges):
    out = set()
    for i, (a, b) in enumerate(edges):
        if a == b:
            continue
        uf = UnionFind()
        for j, (c, d) in enumerate(edges):
            if j != i:
                uf.union(c, d)
        if uf.find(a) != uf.find(b):
            out.add(i)
    return out


def test_small_cases():
    assert bridges([]) == set()
    assert bridges([("a", "b")]) == {0}
    assert bridges([("a", "b"), ("a", "b")]) == set()  # parallel edges
    assert bridges([("a", "a"), ("a", "b")]) == {1}  # a self-loop is never a bridge
    # A triangle with a tail and a second component.
    e = [("a", "b"), ("b", "c"), ("c", "a"), ("c", "d"), ("x", "y")]
    assert bridges(e) == {3, 4}


def test_random_multigraphs_match_the_definition():
    rng = random.Random(7)
    for _ in range(300):
        nodes = [f"n{i}" for i in range(rng.randint(1, 9))]
        edges = [(rng.choice(nodes), rng.choice(nodes)) for _ in range(rng.randint(0, 14))]
        assert bridges(edges) == _bridges_by_definition(edges), edges


def test_a_long_ladder_does_not_recurse():
    # 20000 nodes in a path: an iterative search (a recursive one would overflow the stack).
    edges = [(f"n{i}", f"n{i + 1}") for i in range(20000)]
    assert bridges(edges) == set(range(20000))
