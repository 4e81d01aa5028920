"""Triangle meshes in the frame (issue 20): loading, their G-buffer, and their shadows by
shadow volumes (paper 003).  docs/meshes.md."""
from .bvh import BVH, build_bvh
from .caster import MeshCaster
from .load import load_mesh, load_normal_map, load_texture
from .mesh import MeshSurface, TriangleMesh
from .shadow_volumes import MeshShadows, PointLight  # noqa: F401  (shadow volumes, paper 003)

__all__ = ["BVH", "MeshCaster", "MeshSurface", "TriangleMesh", "build_bvh", "load_mesh", "load_normal_map",
           "load_texture"]
