"""From a validated deck to the initial scene: grid, materials and particles."""

from .build import Scene, build_scene

__all__ = ["Scene", "build_scene"]
