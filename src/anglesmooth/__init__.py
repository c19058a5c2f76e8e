"""anglesmooth: angle-based smoothing of 2D finite-element meshes."""
from .__about__ import __version__
