"""Quadrics standing on the terrain (paper 004): spheres, ellipsoids, cylinders and
paraboloids ray-cast in closed form into the G-buffer, depth-merged with the terrain, with
their shadows (kernels/quadric.cl; twin oclshade.reference.quadrics)."""
from .caster import ObjectIds, QuadricCaster, screen_rect
from .objects import KINDS, Quadric, frame_from_axis

__all__ = ["KINDS", "ObjectIds", "Quadric", "QuadricCaster", "frame_from_axis", "screen_rect"]
