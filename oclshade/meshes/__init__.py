"""Triangle meshes in the frame (issue 20): loading, their G-buffer, and their shadows by
shadow volumes (paper 003)."""
from .mesh import TriangleMesh

__all__ = ["TriangleMesh"]
