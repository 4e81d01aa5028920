"""OpenCL C kernels of oclshade, shipped as package data (oclshade.kernels)."""
