"""TOML scene files: a model, its initial state, solver settings and outputs in one file.

A scene file (read with the standard library's :mod:`tomllib`) describes
everything the Python API builds: materials, cross-sections, rigid and
flexible bodies, joints, force elements, drivers, initial conditions, the
solver and the outputs. Bodies, joints and force elements are looked up *by
plugin name* in :mod:`flexmb.registry` (``type = "revolute"``), and the other
keys of their table are passed to the class as keyword arguments, so a
third-party plugin is usable from a scene without any change here. Every
error is a :class:`~flexmb.errors.SceneError` whose message starts with the
file and the key path (``scene.toml: joints.pin.axis: must have 3
components, got 2``). Units are SI throughout. The format is documented in
``docs/scenes.md``.

Examples
--------
>>> import flexmb as fm
>>> scene = fm.loads_scene('''
... [bodies.bar]
... shape = "slender_bar"
... mass = 1.0
... length = 1.0
... [joints.pin]
... type = "revolute"
... parent = "ground"
... child = "bar"
... [forces.gravity]
... type = "gravity"
... g = [0.0, -9.81, 0.0]
... [initial]
... positions = { pin = 0.5 }
... [solver]
... t_end = 1.0
... ''')
>>> scene.system().coordinate_names
['pin.angle']
"""

from .settings import SECTIONS, InitialState, OutputSettings, SolverSettings
from .scene import Scene
from .load import builtin_scenes, load_builtin, load_scene, loads_scene, scene_from_dict

__all__ = ["Scene", "SolverSettings", "OutputSettings", "InitialState", "load_scene", "loads_scene", "SECTIONS"]
__all__ += ["scene_from_dict", "builtin_scenes", "load_builtin"]
