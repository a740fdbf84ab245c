"""Half-edge collapses in quadric-error order, for :mod:`morf.web.light_mesh`.

The mesh is kept as a face array (dead faces marked) and, per vertex, the set of faces around it;
candidate collapses sit in a heap with the versions of their two vertices, and a popped candidate
whose vertices changed since it was pushed is dropped (the changed vertices pushed fresh ones).
"""

from __future__ import annotations

import heapq

import numpy as np

MIN_NORMAL_COS = 0.3  # a collapse may turn a face's normal by up to about 73 degrees, no further


class EdgeCollapse:
    """Collapse ``u`` into a neighbour ``v`` (``v`` keeps everything it had) while it is cheap.

    Args:
        points: (V, 5) position and scaled texture coordinates; the quadrics live there.
        faces: (F, 3) triangles.
        quadrics: (V, 6, 6) each vertex's sum of its faces' quadrics.
        movable: (V,) bool, vertices that may be merged away.
        weights: (V, J) dense bone weights; ``max_weight_change``: the largest L1 distance merged.
        multiplier: (V,) the cost of merging each vertex away is multiplied by it.
    """

    def __init__(self, points, faces, quadrics, movable, weights, max_weight_change: float, multiplier):
        self.points, self.faces = points, faces.astype(np.int64).copy()
        self.q, self.movable, self.weights = quadrics.copy(), movable, weights
        self.max_weight_change, self.multiplier = max_weight_change, multiplier
        self.alive = np.ones(len(faces), bool)
        self.face_count = len(faces)  # alive faces, kept in step with ``alive``
        self.vf: list[set[int]] = [set() for _ in range(len(points))]
        for f, tri in enumerate(self.faces):
            for i in tri:
                self.vf[i].add(f)
        self.version = np.zeros(len(points), np.int64)
        self.x = np.concatenate([points, np.ones((len(points), 1))], axis=1)
        self.rows = points.tolist()  # for the per-face checks: plain floats are faster than small arrays
        self.heap: list[tuple[float, int, int, int, int]] = []
        for u in np.flatnonzero(movable):
            self._push_from(int(u))

    def neighbours(self, u: int) -> set[int]:
        return {int(i) for f in self.vf[u] for i in self.faces[f]} - {u}

    def _push_from(self, u: int) -> None:
        """Push ``u``'s collapses into each neighbour ``v``, costed (Q_u + Q_v) at v's point."""
        vs = np.fromiter(self.neighbours(u), np.int64)
        if not len(vs):
            return
        x = self.x[vs]
        costs = self.multiplier[u] * (np.einsum("ki,ij,kj->k", x, self.q[u], x) + np.einsum("ki,kij,kj->k", x, self.q[vs], x))
        vu = int(self.version[u])
        for v, c, ver in zip(vs.tolist(), costs.tolist(), self.version[vs].tolist()):
            heapq.heappush(self.heap, (c, u, v, vu, ver))

    def run(self, target_faces: int, max_cost: float) -> float:
        """Collapse until ``target_faces`` remain or the cheapest candidate costs more than
        ``max_cost``; may be called again with a larger ``max_cost`` to go on. Returns the largest
        error paid (the cost over the vertex's multiplier; 0 when nothing was collapsed)."""
        worst = 0.0
        while self.heap and self.face_count > target_faces:
            cost, u, v, vu, vv = heapq.heappop(self.heap)
            if vu != self.version[u] or vv != self.version[v] or not self.vf[u]:
                continue
            if cost > max_cost:
                heapq.heappush(self.heap, (cost, u, v, vu, vv))  # still a candidate for a looser bound
                break
            if self._allowed(u, v):
                self._collapse(u, v)
                worst = max(worst, cost / max(float(self.multiplier[u]), 1e-12))
        return worst

    def _allowed(self, u: int, v: int) -> bool:
        if np.abs(self.weights[u] - self.weights[v]).sum() > self.max_weight_change:
            return False
        shared = self.vf[u] & self.vf[v]
        if len(shared) != 2:
            return False
        opposite = {int(i) for f in shared for i in self.faces[f]} - {u, v}
        if self.neighbours(u) & self.neighbours(v) != opposite:
            return False  # the link condition: anything more would pinch the surface
        pts = self.rows
        for f in self.vf[u] - shared:
            tri = self.faces[f].tolist()
            new = [v if i == u else i for i in tri]
            if not (_keeps_normal(*(pts[i] for i in tri), *(pts[i] for i in new))
                    and _keeps_orientation(*(pts[i] for i in tri), *(pts[i] for i in new))):
                return False
        return True

    def _collapse(self, u: int, v: int) -> None:
        shared = self.vf[u] & self.vf[v]
        self.face_count -= len(shared)
        for f in shared:
            self.alive[f] = False
            for i in self.faces[f]:
                self.vf[int(i)].discard(f)
        for f in self.vf[u]:
            self.faces[f][self.faces[f] == u] = v
            self.vf[v].add(f)
        self.vf[u] = set()
        self.q[v] += self.q[u]
        touched = {v} | self.neighbours(v)
        for i in touched:
            self.version[i] += 1
        for i in touched:
            if self.movable[i]:
                self._push_from(i)


def _keeps_normal(a, b, c, a2, b2, c2) -> bool:
    """The face (a, b, c) -> (a2, b2, c2) (points: x, y, z, ...) keeps some area and turns its normal
    by less than acos(MIN_NORMAL_COS)."""
    n1 = _normal(a, b, c)
    n2 = _normal(a2, b2, c2)
    l1 = (n1[0] ** 2 + n1[1] ** 2 + n1[2] ** 2) ** 0.5
    l2 = (n2[0] ** 2 + n2[1] ** 2 + n2[2] ** 2) ** 0.5
    dot = n1[0] * n2[0] + n1[1] * n2[1] + n1[2] * n2[2]
    return l2 > 1e-12 * max(l1, 1e-30) and dot >= MIN_NORMAL_COS * l1 * l2


def _normal(a, b, c):
    ux, uy, uz = b[0] - a[0], b[1] - a[1], b[2] - a[2]
    vx, vy, vz = c[0] - a[0], c[1] - a[1], c[2] - a[2]
    return uy * vz - uz * vy, uz * vx - ux * vz, ux * vy - uy * vx


def _keeps_orientation(a, b, c, a2, b2, c2) -> bool:
    """The face keeps its winding in the atlas (coordinates 3 and 4 of the points) and some area: no
    fold-over of the texture."""
    s1 = (b[3] - a[3]) * (c[4] - a[4]) - (b[4] - a[4]) * (c[3] - a[3])
    s2 = (b2[3] - a2[3]) * (c2[4] - a2[4]) - (b2[4] - a2[4]) * (c2[3] - a2[3])
    return s1 * s2 > 0 and abs(s2) > 1e-3 * abs(s1)
