"""The loader: turns a parsed scene document into a :class:`~flexmb.scene.Scene`, with key paths in every error."""

from __future__ import annotations

import difflib
import inspect
import math
import re

import attrs
import numpy as np

from .. import memory, registry
from ..errors import FlexmbError, ModelError, PluginError, SceneError
from .figures import FIGURES, RUNS_OF_FIGURES
from .keys import key_paths, set_key
from .initial import check_initial, load_initial
from .scene import Scene
from .settings import (SECTIONS, STUDY_KEYS, OutputSettings, SolverSettings, _is_number, _prefix_problem,
                       _toml_type)

__all__: list[str] = []

_BODY_KEYS = {"parent", "child", "body", "body1", "body2"}


class _Loader:
    """Turns the parsed TOML document into a :class:`Scene`, raising SceneError with key paths."""

    def __init__(self, data: dict, source: str, stem: str, run: str | None = None):
        self.data = data
        self.source = source
        self.stem = stem
        self.run = run  # the label of the run being built, for one of the [runs] of a scene
        self.materials: dict = {}
        self.sections: dict = {}
        self.bodies: dict = {}
        self.joints: dict = {}
        self.types: dict = {}

    # -- errors and checks
    def fail(self, path: str, message: str):
        where = f"{path}: " if path else ""
        raise SceneError(f"{self.source}: {where}{message}", path)

    def table(self, path: str, value) -> dict:
        if not isinstance(value, dict):
            self.fail(path, f"must be a table, got {_toml_type(value)}")
        return value

    def keys(self, path: str, table: dict, required=(), optional=()) -> None:
        allowed = list(required) + list(optional)
        for k in table:
            if k not in allowed:
                self.fail(f"{path}.{k}" if path else k, f"unknown key; allowed keys: {', '.join(allowed)}")
        for k in required:
            if k not in table:
                self.fail(path, f"missing key {k!r}")

    def number(self, path: str, value, positive=False, integer=False):
        if integer:
            if not isinstance(value, int) or isinstance(value, bool):
                self.fail(path, f"must be an integer, got {_toml_type(value)} {value!r}")
        elif not _is_number(value):
            self.fail(path, f"must be a number, got {_toml_type(value)} {value!r}")
        if positive and not value > 0:
            self.fail(path, f"must be > 0, got {value!r}")
        return value if integer else float(value)

    def string(self, path: str, value) -> str:
        if not isinstance(value, str):
            self.fail(path, f"must be a string, got {_toml_type(value)} {value!r}")
        return value

    def boolean(self, path: str, value) -> bool:
        if not isinstance(value, bool):
            self.fail(path, f"must be true or false, got {_toml_type(value)} {value!r}")
        return value

    def named(self, path: str, section: str) -> dict:
        """The sub-tables of a top-level table such as ``[bodies]``."""
        tables = self.table(section, self.data.get(section, {}))
        for name, t in tables.items():
            self.table(f"{section}.{name}", t)
        return tables

    # -- references
    def ref(self, path: str, value, kind: str):
        table = {"body": self.bodies, "joint": self.joints, "section": self.sections,
                 "material": self.materials}[kind]
        if not isinstance(value, str):
            self.fail(path, f"must be the name of a {kind} (a string), got {_toml_type(value)} {value!r}")
        if value not in table:
            known = sorted(table)
            self.fail(path, f"unknown {kind} {value!r}; known: {', '.join(known) or 'none'}")
        return table[value]

    @staticmethod
    def ref_kind(key: str, annotation: str) -> str | None:
        if key in _BODY_KEYS or re.search(r"\bBody\b|FlexibleBody|RigidBody", annotation):
            return "body"
        if key == "joint" or re.search(r"\bJoint\b", annotation):
            return "joint"
        if key == "section" or re.search(r"\bSection\b", annotation):
            return "section"
        if key == "material" or re.search(r"\bMaterial\b", annotation):
            return "material"
        return None

    # -- generic construction
    def call(self, path: str, ctor, name: str | None, table: dict, what: str, read=()):
        """Call ``ctor(name=name, **table)`` after checking keys and references against its signature.

        ``read``: keys of the scene's table that the loader has read and taken
        out already (a driver's ``kind`` and ``rpm``): listed among the
        allowed keys of a message.
        """
        try:
            sig = inspect.signature(ctor)
        except (TypeError, ValueError):
            sig = None
        kwargs = {}
        if sig is not None:
            params = {k: p for k, p in sig.parameters.items()
                      if p.kind in (p.POSITIONAL_OR_KEYWORD, p.KEYWORD_ONLY) and k not in ("self", "cls")}
            var_kw = any(p.kind == p.VAR_KEYWORD for p in sig.parameters.values())
            if var_kw and isinstance(getattr(ctor, "__self__", None), type):
                owner = inspect.signature(ctor.__self__).parameters
                params.update({k: p for k, p in owner.items() if k not in params})
            allowed = [k for k in params if k != "name"]
            for k in table:
                if k not in allowed:
                    known = [*read, *allowed]
                    close = difflib.get_close_matches(k, known, n=1)
                    hint = f"; did you mean {close[0]!r}?" if close else ""
                    self.fail(f"{path}.{k}", f"unknown key for {what}; allowed keys: {', '.join(known)}{hint}")
            for k, p in params.items():
                if k != "name" and p.default is p.empty and k not in table:
                    self.fail(path, f"missing key {k!r} ({what} needs it)")
        else:
            params = {}
        types = {}
        if attrs.has(ctor):  # the field's declared type (the __init__ annotation is the converter's)
            types = {a.alias or a.name: a.type for a in attrs.fields(ctor) if a.type is not None}
        for k, v in table.items():
            p = params.get(k)
            annotation = "" if p is None or p.annotation is inspect.Parameter.empty else str(p.annotation)
            if k in types:
                t = types[k]
                annotation = t if isinstance(t, str) else getattr(t, "__name__", str(t))
            kind = self.ref_kind(k, annotation)
            key_path = f"{path}.{k}"
            if kind is not None:
                v = self.ref(key_path, v, kind)
            else:
                self.precheck(key_path, v, annotation, None if p is None else p.default)
            kwargs[k] = v
        if name is not None:
            kwargs["name"] = name
        try:
            return ctor(**kwargs)
        except (ModelError, TypeError, ValueError) as exc:
            self.translate(path, exc, table)
        except ArithmeticError as exc:  # e.g. length = 1e300 overflowing length**2, or -1e-300 ** 4 == 0
            self.fail(path, f"values out of range for {what} ({type(exc).__name__}: {exc})")

    def precheck(self, path: str, value, annotation: str, default) -> None:
        """Catch wrong TOML types and vector lengths before the class sees them."""
        ann = annotation.replace(" ", "")
        if ann in ("float", "float|None") and not _is_number(value):
            self.fail(path, f"must be a number, got {_toml_type(value)} {value!r}")
        if ann == "int" and (not isinstance(value, int) or isinstance(value, bool)):
            self.fail(path, f"must be an integer, got {_toml_type(value)} {value!r}")
        if ann == "bool" and not isinstance(value, bool):
            self.fail(path, f"must be true or false, got {_toml_type(value)} {value!r}")
        if ann == "str" and not isinstance(value, str):
            self.fail(path, f"must be a string, got {_toml_type(value)} {value!r}")
        if "ndarray" in ann and isinstance(value, (str, bool, dict)):
            self.fail(path, f"must be numbers, got {_toml_type(value)} {value!r}")
        if isinstance(value, list):
            bad = [x for x in np.ravel(np.array(value, dtype=object)) if not _is_number(x)] \
                if all(not isinstance(x, list) for x in value) else []
            if "ndarray" in ann and bad:
                self.fail(path, f"must be numbers, got {_toml_type(bad[0])} {bad[0]!r} in {value!r}")
            flat = all(_is_number(x) for x in value)
            if flat and isinstance(default, (tuple, list)) and len(default) == 3 and len(value) != 3:
                self.fail(path, f"must have 3 components, got {len(value)}")

    def translate(self, path: str, exc: Exception, table: dict):
        """Re-raise a construction error as a SceneError at the key it names."""
        msg = str(exc).replace("\n", " ")
        m = re.match(r"^(?:[A-Za-z_][\w.]*(?: '[^']*')?|[\w.]+\(\)): ", msg)
        rest = msg[m.end():] if m else msg
        for k in sorted(table, key=len, reverse=True):
            if re.match(rf"{re.escape(k)}(?: must| is| has| cannot|:)", rest):
                self.fail(f"{path}.{k}", rest[len(k):].lstrip(" :"))
        key = _failing_field(exc)
        if key in table:
            self.fail(f"{path}.{key}", rest[len(key):].lstrip() if rest.startswith(key + " ") else rest)
        self.fail(path, rest)

    def plugin(self, path: str, kind: str, table: dict, default: str | None = None):
        # a [forces] table may name a contact geometry of the group flexmb.contacts too
        geometries = _contact_geometries() if kind == "forces" else []
        if "type" not in table and default is None:
            self.fail(path, f"missing key 'type' (a {kind} plugin name; pick one of "
                            f"{', '.join(registry.names(kind) + geometries)})")
        type_name = self.string(f"{path}.type", table.get("type", default))
        if type_name in geometries and type_name not in registry.names(kind):
            return type_name, registry.get("contacts", type_name)
        try:
            return type_name, registry.get(kind, type_name)
        except PluginError as exc:
            also = f" (or a contact geometry: {', '.join(geometries)})" if geometries else ""
            self.fail(f"{path}.type", f"{exc}{also}")

    # -- sections of the file
    def load(self) -> Scene:
        from ..model import Model

        for k in self.data:
            if k not in SECTIONS:
                self.fail(k, f"unknown section; allowed: {', '.join(SECTIONS)}")
        mt = self.table("model", self.data.get("model", {}))
        self.keys("model", mt, optional=("name", "complement"))
        name = self.string("model.name", mt.get("name", self.stem))
        complement = self.string("model.complement", mt.get("complement", "svd"))
        model = Model(name)
        self.bodies["ground"] = model.ground
        self.load_materials()
        self.load_sections()
        self.load_bodies(model)
        self.load_joints(model)
        self.load_forces(model)
        self.load_constraints(model)
        self.load_drivers(model)
        solver = self.load_solver(complement)
        self.load_study()
        initial = load_initial(self)
        output = self.load_output(name)
        scene = Scene(name, model, initial, solver, output, self.source, self.types)
        self.check_memory(model)
        try:
            system = scene.system()
        except FlexmbError as exc:
            self.fail("", str(exc).replace(":\n  - ", ": ").replace("\n  - ", "; "))
        check_initial(self, scene, system)
        try:
            memory.check(system, solver.n_out, what=f"{solver.n_out} output times", model=False)
        except ModelError as exc:
            self.fail("solver.n_out", str(exc))
        self.check_metrics(scene, system)
        scene.runs = self.load_runs(scene)
        if self.run is None and FIGURES[output.figure][0] == "runs":
            needs = RUNS_OF_FIGURES.get(output.figure, ())
            if not scene.runs or not set(needs) <= set(scene.runs):
                self.fail("output.figure", f"figure {output.figure!r} draws the [runs] of a scene "
                                           f"({', '.join(needs) or 'any'}); this one has "
                                           f"{', '.join(scene.runs) or 'none'}")
        return scene

    def check_metrics(self, scene, system) -> None:
        """Refuse an ``[output.metrics]`` entry that names no output of this scene."""
        from .metrics import _check_output

        for key, spec in scene.output.metrics.items():
            try:
                _check_output(spec, scene, system)
            except FlexmbError as exc:
                self.fail(f"output.metrics.{key}", str(exc))

    def load_runs(self, scene: Scene) -> dict:
        """The scenes of ``[runs]``: for each, this document with the run's key paths replaced, loaded.

        A run that replaces no key is ``scene`` itself (as a scene without runs), not loaded again.
        """
        import copy

        runs = {}
        for label, keys in self.named("runs", "runs").items():
            # it names the run's files (<prefix>_<label>.npz, vtk_<label>/): no folder, no hidden file, no option
            if len(label) > 200 or not re.fullmatch(r"\w[\w.\- ]*", label):
                self.fail(f"runs.{label}", "a run's name must start with a letter, digit or _ and hold only those, "
                                           f"spaces and . -, got {label!r}")
            if not keys:
                runs[label] = attrs.evolve(scene, runs={})
                continue
            doc = copy.deepcopy({k: v for k, v in self.data.items() if k != "runs"})
            for key, value in keys.items():
                for path in key_paths(key):
                    try:
                        set_key(doc, path, value, self.source, what=f"key of run {label!r}")
                    except SceneError as exc:
                        self.fail(f"runs.{label}", str(exc).removeprefix(f"{self.source}: "))
            try:
                runs[label] = _Loader(doc, self.source, self.stem, run=label).load()
            except SceneError as exc:
                self.fail(f"runs.{label}", str(exc).removeprefix(f"{self.source}: "))
        return runs

    def check_memory(self, model) -> None:
        """Refuse a model too large for memory at the key that sizes it (the finest flexible body's n_segments)."""
        from ..flexible import FlexibleBody

        try:
            memory.check(model, what=f"Model {model.name!r}")
        except ModelError as exc:
            flexible = [(b.n_segments, name) for name, b in self.bodies.items() if isinstance(b, FlexibleBody)]
            self.fail(f"bodies.{max(flexible)[1]}.n_segments" if flexible else "", str(exc))

    def load_study(self) -> dict:
        t = self.table("study", self.data.get("study", {}))
        self.keys("study", t, optional=STUDY_KEYS)
        out = {}
        if "time_limit" in t:
            out["time_limit"] = self.number("study.time_limit", t["time_limit"], positive=True)
            if not math.isfinite(out["time_limit"]):
                self.fail("study.time_limit", f"must be finite (seconds), got {t['time_limit']!r}")
        return out

    def load_materials(self):
        from ..sections import Material

        for name, t in self.named("materials", "materials").items():
            path = f"materials.{name}"
            if "preset" in t:
                self.keys(path, t, required=("preset",))
                presets = [k for k in ("aluminium", "steel")]
                preset = self.string(f"{path}.preset", t["preset"])
                if preset not in presets:
                    self.fail(f"{path}.preset", f"unknown preset {preset!r}; pick one of {', '.join(presets)}")
                self.materials[name] = getattr(Material, preset)()
                continue
            self.keys(path, t, required=("E", "density"), optional=("nu", "G"))
            kw = {k: self.number(f"{path}.{k}", v) for k, v in t.items()}
            try:
                self.materials[name] = Material(name=name, **kw)
            except (ModelError, TypeError, ValueError) as exc:
                self.translate(path, exc, t)
            except ArithmeticError as exc:  # overflow or underflow of extreme values
                self.fail(path, f"values out of range ({type(exc).__name__}: {exc})")

    def load_sections(self):
        from ..sections import Section

        kinds = {"rectangular": ("b", "h"), "circular": ("d",), "tube": ("d_out", "d_in"),
                 "general": ("area", "Iy", "Iz", "J")}
        for name, t in self.named("sections", "sections").items():
            path = f"sections.{name}"
            kind = self.string(f"{path}.kind", t.get("kind", "general"))
            if kind not in kinds:
                self.fail(f"{path}.kind", f"unknown section kind {kind!r}; pick one of {', '.join(kinds)}")
            optional = ("kind", "Ip", "c_y", "c_z") if kind == "general" else ("kind",)
            self.keys(path, t, required=kinds[kind], optional=optional)
            kw = {k: self.number(f"{path}.{k}", v) for k, v in t.items() if k != "kind"}
            try:
                self.sections[name] = (Section(name=name, **kw) if kind == "general"
                                       else getattr(Section, kind)(**kw))
            except (ModelError, TypeError, ValueError) as exc:
                self.translate(path, exc, t)
            except ArithmeticError as exc:  # overflow or underflow of extreme values
                self.fail(path, f"values out of range ({type(exc).__name__}: {exc})")

    def load_bodies(self, model):
        for name, t in self.named("bodies", "bodies").items():
            path = f"bodies.{name}"
            if name == "ground":
                self.fail(path, "the name 'ground' is reserved for the inertial frame")
            type_name, cls = self.plugin(path, "bodies", t, default="rigid_body")
            rest = {k: v for k, v in t.items() if k not in ("type", "shape")}
            ctor, what = cls, f"body type {type_name!r}"
            if "shape" in t:
                shape = self.string(f"{path}.shape", t["shape"])
                shapes = _constructors(cls)
                if shape not in shapes:
                    self.fail(f"{path}.shape", f"unknown shape {shape!r} for {type_name}; pick one of "
                                               f"{', '.join(sorted(shapes)) or 'none'}")
                ctor, what = shapes[shape], f"shape {shape!r}"
            body = self.call(path, ctor, name, rest, what)
            self.bodies[name] = body
            self.types[name] = self.types[path] = type_name
            model.add(body)

    def _load_plugins(self, model, section, what):
        """Build every table of ``[section]`` by its plugin ``type`` and add it to the model."""
        built = {}
        for name, t in self.named(section, section).items():
            path = f"{section}.{name}"
            type_name, cls = self.plugin(path, section, t)
            built[name] = self.call(path, cls, name, {k: v for k, v in t.items() if k != "type"},
                                    f"{what} type {type_name!r}")
            self.types[name] = self.types[path] = type_name
            model.add(built[name])
        return built

    def load_joints(self, model):
        self.joints.update(self._load_plugins(model, "joints", "joint"))

    def load_forces(self, model):
        self._load_plugins(model, "forces", "force")

    def load_constraints(self, model):
        self._load_plugins(model, "constraints", "constraint")

    def load_drivers(self, model):
        from ..drivers import Driver

        kinds = _constructors(Driver)
        for name, t in self.named("drivers", "drivers").items():
            path = f"drivers.{name}"
            t = dict(t)
            kind = self.string(f"{path}.kind", t.pop("kind", "constant_speed"))
            if kind not in kinds:
                self.fail(f"{path}.kind", f"unknown driver kind {kind!r}; pick one of {', '.join(sorted(kinds))}")
            if "joint" not in t:
                self.fail(path, "missing key 'joint'")
            joint = self.ref(f"{path}.joint", t["joint"], "joint")
            if "coordinate" in t and isinstance(t["coordinate"], str):
                if t["coordinate"] not in joint.coordinate_names:
                    self.fail(f"{path}.coordinate", f"joint {joint.name!r} has no coordinate {t['coordinate']!r}; "
                                                    f"its coordinates: {', '.join(joint.coordinate_names)}")
                t["coordinate"] = list(joint.coordinate_names).index(t["coordinate"])
            read = ("kind", "rpm") if kind == "constant_speed" else ("kind",)
            if kind == "constant_speed" and "rpm" in t:
                if "speed" in t:
                    self.fail(f"{path}.rpm", "give speed (rad/s or m/s) or rpm, not both")
                t["speed"] = 2 * np.pi * self.number(f"{path}.rpm", t.pop("rpm")) / 60.0
            model.add(self.call(path, kinds[kind], name, t, f"driver kind {kind!r}", read=read))

    def load_solver(self, complement: str) -> SolverSettings:
        t = self.table("solver", self.data.get("solver", {}))
        if "solver" not in self.data:
            self.fail("solver", "missing section (at least t_end)")
        fields = ("t_end", "method", "rtol", "atol", "n_out", "complement", "projection_tol", "max_step",
                  "track_work")
        self.keys("solver", t, required=("t_end",), optional=fields[1:])
        kw = {}
        for k, v in t.items():
            p = f"solver.{k}"
            if k in ("method", "complement"):
                kw[k] = self.string(p, v)
            elif k == "track_work":
                kw[k] = self.boolean(p, v)
            elif k == "n_out":
                kw[k] = self.number(p, v, integer=True)
                if kw[k] < 2:
                    self.fail(p, f"must be >= 2, got {v}")
            else:
                kw[k] = self.number(p, v, positive=True)
                if k != "max_step" and not math.isfinite(kw[k]):  # t_end = inf would integrate forever
                    self.fail(p, f"must be finite, got {v!r}")
        kw.setdefault("complement", complement)
        if kw["complement"] not in registry.names("complements"):
            key = "solver.complement" if "complement" in t else "model.complement"
            self.fail(key, f"unknown complement strategy {kw['complement']!r}; pick one of "
                           f"{', '.join(registry.names('complements'))}")
        method = kw.get("method", "auto")
        if method != "auto" and method not in registry.names("integrators"):
            self.fail("solver.method", f"unknown integrator {method!r}; pick one of auto, "
                                       f"{', '.join(registry.names('integrators'))}")
        return SolverSettings(**kw)

    def load_output(self, name: str) -> OutputSettings:
        t = self.table("output", self.data.get("output", {}))
        self.keys("output", t, optional=("npz", "summary", "plots", "vtk", "prefix", "points", "figure", "metrics"))
        kw = {k: self.boolean(f"output.{k}", t[k]) for k in ("npz", "summary", "plots", "vtk") if k in t}
        default = re.sub(r"^[.\-]+", "", re.sub(r"[^\w.\-]+", "_", name))[:200] or "scene"
        prefix = self.string("output.prefix", t.get("prefix", default))
        problem = _prefix_problem(prefix)
        if problem:
            self.fail("output.prefix", problem)
        points = {}
        for label, p in self.table("output.points", t.get("points", {})).items():
            path = f"output.points.{label}"
            self.table(path, p)
            self.keys(path, p, required=("body",), optional=("point",))
            body = self.ref(f"{path}.body", p["body"], "body")
            if body.name == "ground":
                self.fail(f"{path}.body", "track a point of a moving body, not the ground")
            point = p.get("point", [0.0, 0.0, 0.0])
            if not (isinstance(point, list) and len(point) == 3 and all(_is_number(x) for x in point)):
                self.fail(f"{path}.point", f"must be 3 numbers (m, in the body frame), got {point!r}")
            points[label] = (body.name, tuple(float(x) for x in point))
        if "figure" in t:
            kw["figure"] = self.string("output.figure", t["figure"])
            if kw["figure"] not in FIGURES:
                self.fail("output.figure", f"unknown figure {kw['figure']!r}; pick one of {', '.join(FIGURES)}")
        metrics = self.table("output.metrics", t.get("metrics", {}))
        for key, spec in metrics.items():
            self.string(f"output.metrics.{key}", spec)
        return OutputSettings(prefix=prefix, points=points, metrics=dict(metrics), **kw)


def _failing_field(exc: BaseException) -> str | None:
    """Name of the attrs field whose validator raised ``exc`` (validators get ``attribute``), if any."""
    name = None
    tb = exc.__traceback__
    while tb is not None:
        attribute = tb.tb_frame.f_locals.get("attribute")
        if isinstance(attribute, attrs.Attribute):
            name = attribute.alias or attribute.name
        tb = tb.tb_next
    return name


def _constructors(cls) -> dict:
    """Public class methods of ``cls`` whose first argument is ``name`` (its named constructors)."""
    out = {}
    for k in dir(cls):
        if k.startswith("_") or not isinstance(inspect.getattr_static(cls, k), classmethod):
            continue
        method = getattr(cls, k)
        try:
            first = next(iter(inspect.signature(method).parameters), None)
        except (TypeError, ValueError):
            continue
        if first == "name":
            out[k] = method
    return out


def _contact_geometries() -> list[str]:
    """The contact geometries of the plugin group ``flexmb.contacts`` (force elements a [forces] table may name)."""
    from ..forces.contact_base import Contact
    from ..forces.law_tables import contact_names

    return contact_names(Contact)
