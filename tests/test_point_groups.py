"""The metrics' attached-body groups (src_f90/fsph_groups.f90 through
fsph.metrics.attached_points): points join within the sum of their
reaches or through links; the body is the group of the largest mass."""

import numpy as np
from scipy.sparse import coo_matrix
from scipy.sparse.csgraph import connected_components
from scipy.spatial import cKDTree

from fsph._core import fsph_api
from fsph.metrics import attached_points


def graph_labels(x, reach, links):
    """Groups by a graph library, for comparison: the pairs within the
    sum of the reaches, and the links."""
    pairs = cKDTree(x).query_pairs(2.0 * reach.max(), output_type="ndarray").reshape(-1, 2)
    dist = np.linalg.norm(x[pairs[:, 0]] - x[pairs[:, 1]], axis=1)
    pairs = np.vstack([pairs[dist <= reach[pairs[:, 0]] + reach[pairs[:, 1]]], links.reshape(-1, 2)])
    n = len(x)
    return connected_components(coo_matrix((np.ones(len(pairs)), (pairs[:, 0], pairs[:, 1])),
                                           shape=(n, n)), directed=False)[1]


def groups(x, reach, links=np.zeros((0, 2), int)):
    return fsph_api.point_groups(np.asfortranarray(x.T), reach,
                                 np.asfortranarray((links + 1).astype(np.int32).T)) - 1


def test_chain_and_gap():
    """Points 1 mm apart with reach 0.51 mm form one chain; a gap of 1.2 mm
    starts another group; labels are the smallest index of the group."""
    x = np.array([[0.0, 0.0], [1.0, 0.0], [2.0, 0.0], [3.2, 0.0], [4.2, 0.0]]) * 1e-3
    reach = np.full(5, 0.51e-3)
    assert list(groups(x, reach)) == [0, 0, 0, 3, 3]
    # a link joins what distance does not
    assert list(groups(x, reach, np.array([[4, 1]]))) == [0, 0, 0, 0, 0]
    # zero reach: only coincident points join
    assert list(groups(x, np.zeros(5))) == [0, 1, 2, 3, 4]


def test_same_partition_as_a_graph_library():
    """On random sets (stretched boxes, mixed reaches, a few links) the
    partition equals the graph library's, and the attached body is the
    heavier group."""
    rng = np.random.default_rng(7)
    for trial in range(60):
        n = int(rng.integers(2, 300))
        x = rng.random((n, 2)) * np.array([1.0, rng.choice([0.01, 1.0, 30.0])])
        reach = rng.random(n) * rng.choice([0.02, 0.06, 0.2])
        links = rng.integers(0, n, (int(rng.integers(0, 10)), 2))
        mine, theirs = groups(x, reach, links), graph_labels(x, reach, links)
        # same partition: a one-to-one map between the labels
        pairs = set(zip(mine, theirs))
        assert len(pairs) == len(set(mine)) == len(set(theirs))
        mass = rng.random(n)
        heavy = np.bincount(theirs, weights=mass).argmax()
        assert np.array_equal(attached_points(x, reach, mass, links), theirs == heavy)
