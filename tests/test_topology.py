"""netlist.topology.bridges against the definition (remove the edge, are its ends still
joined?), checked by union-find on random multigraphs; the per-mode helpers (Partition,
SwitchedBridges) against a fresh union-find and a fresh search of every subset's graph."""

from __future__ import annotations

import random

from netlist.topology import Partition, SwitchedBridges, UnionFind, bridges


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


def _random_graph(rng, nodes, count):
    return [(rng.choice(nodes), rng.choice(nodes)) for _ in range(rng.randint(0, count))]


def test_switched_bridges_match_a_fresh_search():
    rng = random.Random(11)
    for _ in range(300):
        nodes = [f"n{i}" for i in range(rng.randint(1, 10))]
        fixed = _random_graph(rng, nodes, 12)
        # (optional edges may reach nodes that no fixed edge has)
        optional = _random_graph(rng, nodes + ["p", "q"], 6)
        graph = SwitchedBridges(fixed, optional)
        assert graph.size == len(fixed)
        for _ in range(4):
            present = [j for j in range(len(optional)) if rng.random() < 0.5]
            whole = bridges(fixed + [optional[j] for j in present])
            assert graph.bridges(present) == {i for i in whole if i < len(fixed)}, (
                fixed, optional, present)


def test_partition_matches_a_fresh_union_find():
    rng = random.Random(5)
    for _ in range(300):
        nodes = [f"n{i}" for i in range(rng.randint(1, 9))]
        fixed = _random_graph(rng, nodes, 8)
        extra = _random_graph(rng, nodes + ["p"], 5)
        partition = Partition(fixed)
        uf, cycle = partition.joined(extra)
        fresh = UnionFind()
        fresh_cycle = False
        for a, b in fixed + extra:
            if not fresh.union(a, b):
                fresh_cycle = True
        assert (partition.has_cycle or cycle) == fresh_cycle
        for a in nodes + ["p"]:
            for b in nodes + ["p"]:
                joined = uf.find(partition.root(a)) == uf.find(partition.root(b))
                assert joined == (fresh.find(a) == fresh.find(b))
