"""Lights that cast mesh shadows (paper 003: parallel or perspective extrusion): the frame's
lights, :mod:`oclshade.lights` (a Sun or a PointLight)."""
from ..lights import Light, LightLike, PointLight, as_light, light_key, towards_light

__all__ = ["Light", "LightLike", "PointLight", "as_light", "light_key", "towards_light"]
