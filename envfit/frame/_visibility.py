r"""Shadow rays of the frame model: whether the map is seen from a hit point in a direction,
cast by Embree (``embreex``, Intel's ray-tracing kernels) against the scene's triangles
(:class:`envfit.renderers._frame.Occluder`).

The renderer's own rule is the reference (Mitsuba 3: ``Scene::ray_test`` of
``DirectIntegrator::sample``'s emitter sample, ``Scene::ray_intersect`` of its BSDF sample,
``src/integrators/direct.cpp``): a direction is lit when the ray from the hit point meets no
surface. Two differences are bounded, not hidden:

* ray origins: offset along the geometric normal by :math:`10^{-4}(1 + \max_k |p_k|)` (the
  renderer offsets by its own float error bound, ≈ 10⁻⁵ of the same scale);
* a shape marked ``convex`` (a sphere, a rectangle, a disk, a cube) is left out of its own
  points' rays, as it cannot shadow its outer side; a sphere is an icosphere slightly
  outside the true one (:mod:`envfit.renderers.mitsuba3._frame_scene`).

``tests/test_frame.py`` compares this with Mitsuba's own ``ray_test`` on random rays.
"""
from __future__ import annotations

import numpy as np

from envfit.base import ParameterError

__all__ = ["Visibility"]


def _embree():
    try:
        from embreex import rtcore_scene
        from embreex.mesh_construction import TriangleMesh
    except ImportError:
        raise ParameterError("the frame model casts shadow rays with Embree: "
                             "pip install embreex") from None
    return rtcore_scene, TriangleMesh


class Visibility:
    """Occlusion tests against the occluders, one Embree scene per convex shape left out.

    Parameters
    ----------
    occluders : sequence of :class:`envfit.renderers._frame.Occluder`

    Examples
    --------
    >>> import numpy as np
    >>> from envfit.renderers._frame import Occluder
    >>> quad = Occluder("Rectangle", np.array([[-1., 1, -1], [1, 1, -1], [1, 1, 1], [-1, 1, 1]]),
    ...                 np.array([[0, 1, 2], [0, 2, 3]]), True)
    >>> v = Visibility([quad])
    >>> v.visible(np.zeros((2, 3)), np.array([[0., 1, 0], [0, -1, 0]]), -1).tolist()
    [False, True]
    """

    def __init__(self, occluders):
        self.occluders = tuple(occluders)
        self._scenes: dict = {}

    def _scene(self, leave_out: int):
        if leave_out not in self._scenes:
            rtcs, mesh = _embree()
            keep = [o for i, o in enumerate(self.occluders) if i != leave_out]
            if not keep:
                self._scenes[leave_out] = None
            else:
                sc = rtcs.EmbreeScene()
                for o in keep:
                    mesh(sc, np.ascontiguousarray(o.vertices, dtype=np.float32),
                         np.ascontiguousarray(o.faces, dtype=np.int32))
                self._scenes[leave_out] = sc
        return self._scenes[leave_out]

    def leave_out(self, shape: int) -> int:
        """The shape left out of the rays from a point on ``shape`` (−1: none)."""
        return shape if 0 <= shape < len(self.occluders) and self.occluders[shape].convex \
            else -1

    def first_shape(self, origins, directions) -> np.ndarray:
        """The index of the first occluder each ray meets (−1: none) (R,) int."""
        sc = self._scene(-1)
        d = np.ascontiguousarray(directions, dtype=np.float32)
        if sc is None or len(d) == 0:
            return np.full(len(d), -1)
        o = np.ascontiguousarray(np.broadcast_to(origins, d.shape), dtype=np.float32)
        return np.asarray(sc.run(o, d, output=1)["geomID"]).astype(np.int64)

    def visible(self, origins, directions, shape: int) -> np.ndarray:
        """Whether each ray (origins (R, 3), unit directions (R, 3)) from a point on ``shape``
        (its index; −1: none) meets no occluder (R,) bool."""
        sc = self._scene(self.leave_out(int(shape)))
        d = np.ascontiguousarray(directions, dtype=np.float32)
        if sc is None or len(d) == 0:
            return np.ones(len(d), dtype=bool)
        o = np.ascontiguousarray(np.broadcast_to(origins, d.shape), dtype=np.float32)
        return np.asarray(sc.run(o, d, query="OCCLUDED")) < 0
