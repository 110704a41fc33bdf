"""A Mitsuba 3 BSDF (``scalar_rgb``) queried one direction at a time, the reference of the
microfacet tests: eval, pdf and sample in the local frame (normal +z)."""
from __future__ import annotations

import numpy as np


def mitsuba_bsdf_queries(props: dict, wi, wo, u1, u2):
    """(eval (K,), pdf (K,), samples (K, 6)) of the Mitsuba BSDF ``props`` for views ``wi``:
    eval and pdf at ``wo``; ``sample(ctx, si, u1, u2)`` as (wo x, y, z, pdf, weight,
    sampled component)."""
    import mitsuba as mi
    mi.set_variant("scalar_rgb")
    bsdf, ctx = mi.load_dict(props), mi.BSDFContext()
    ev, pdf, smp = [], [], []
    for a, b, s1, s2 in zip(wi, wo, u1, u2):
        si = mi.SurfaceInteraction3f()
        si.sh_frame = mi.Frame3f(mi.Vector3f(0, 0, 1))
        si.wi = mi.Vector3f(*a)
        ev.append(bsdf.eval(ctx, si, mi.Vector3f(*b))[0])
        pdf.append(bsdf.pdf(ctx, si, mi.Vector3f(*b)))
        bs, w = bsdf.sample(ctx, si, float(s1), mi.Point2f(float(s2[0]), float(s2[1])))
        smp.append([*bs.wo, bs.pdf, w[0], bs.sampled_component])
    return np.array(ev), np.array(pdf), np.array(smp)
