"""What ``import flexmb`` and a simulation import: only what they use (issue 31, the warm start-up).

Every process that runs flexmb pays for its imports (a script, a test, a
study's case): the analyses import scipy.optimize, the integrators
scipy.integrate (which imports scipy.optimize and scipy.special), the VTK
export meshio, the plots matplotlib, a closed loop's factorizations
scipy.linalg (through :class:`flexmb._lazy.LazyModule`; numba imports it
itself for kernels that call BLAS or numpy's array functions). ``import flexmb`` imports none of them;
the public names that need them are imported on first use (the package's
``__getattr__``), and a model's build and simulation import the integrators
but not the analyses, scenes, studies, exports or plots; nor, in a model
without them, the contact elements and their laws, the constraint elements
or the post-processing modules (``flexmb.forces``, ``flexmb.constraint_elements``
and ``flexmb.post`` name them in lazy tables). Each check runs in
a new interpreter and reads ``sys.modules`` (no timing: the times are in
``benchmarks/startup.py``).
"""

from __future__ import annotations

import json
import os
import subprocess
import sys
import textwrap

import flexmb

#: never imported by ``import flexmb``
NOT_AT_IMPORT = ["matplotlib", "meshio", "scipy.linalg", "scipy.optimize", "scipy.integrate", "scipy.special",
                 "sksundae", "dask", "pyvista", "flexmb.analysis", "flexmb.study", "flexmb.scene", "flexmb.viz", "flexmb.export",
                 "flexmb.genalpha", "flexmb.integrators", "flexmb.system"]

#: the modules of contact elements, their laws, the constraint elements and the post-processing: imported
#: by neither ``import flexmb`` nor a run of a model without them
CONTACT_CONSTRAINT_POST = ["flexmb.forces.contact_base", "flexmb.forces.contact", "flexmb.forces.contact_laws",
                           "flexmb.forces.friction_laws", "flexmb.forces.capsules", "flexmb.forces.contact_groups",
                           "flexmb.constraint_elements.distance", "flexmb.constraint_elements.gear_pair",
                           "flexmb.constraint_elements.knife_edge", "flexmb.constraint_elements.point_on_curve",
                           "flexmb.constraint_elements.rolling_disc", "flexmb.post.contact", "flexmb.post.fields",
                           "flexmb.post.joint_loads", "flexmb.post.motion", "flexmb.post.sections"]
NOT_AT_IMPORT += CONTACT_CONSTRAINT_POST

#: the kernels of closed loops (and of cut joints' rows): imported by neither ``import flexmb`` nor a run of an open
#: tree (``flexmb.system`` and ``flexmb.constraints`` name them through ``flexmb._lazy.LazyModule``)
LOOP_KERNELS = ["flexmb.kernels.loops", "flexmb.kernels.constrained", "flexmb.kernels.constraint_matrix",
                "flexmb.kernels.loop_projection", "flexmb.kernels.loop_statics", "flexmb.kernels.loop_layout",
                "flexmb.kernels.equations", "flexmb.kernels.constraints"]
NOT_AT_IMPORT += LOOP_KERNELS

#: never imported by building and simulating a model (the integrators are)
NOT_IN_A_RUN = ["matplotlib", "meshio", "dask", "pyvista", "flexmb.analysis", "flexmb.study", "flexmb.scene",
                "flexmb.viz", "flexmb.export", *CONTACT_CONSTRAINT_POST, *LOOP_KERNELS]

BENCH = os.path.join(os.path.dirname(os.path.dirname(os.path.abspath(__file__))), "benchmarks")


def _modules_after(code: str) -> dict:
    """Run ``code`` in a new interpreter; the names of NOT_AT_IMPORT and NOT_IN_A_RUN then in sys.modules."""
    check = sorted(set(NOT_AT_IMPORT) | set(NOT_IN_A_RUN))
    script = textwrap.dedent(code) + textwrap.dedent(f"""
        import json, sys
        print(json.dumps({{m: m in sys.modules for m in {check!r}}}))
    """)
    out = subprocess.run([sys.executable, "-c", script], capture_output=True, text=True, timeout=300,
                         env=dict(os.environ, OPENBLAS_NUM_THREADS="1"))
    assert out.returncode == 0, out.stderr
    return json.loads(out.stdout.strip().splitlines()[-1])


def test_import_flexmb_imports_no_analysis_integrator_export_or_plot():
    loaded = _modules_after("import flexmb")
    assert [m for m in NOT_AT_IMPORT if loaded[m]] == []


def test_lazy_module_imports_at_first_read_and_keeps_the_name():
    from flexmb._lazy import LazyModule

    code = textwrap.dedent("""
        import sys
        from flexmb._lazy import LazyModule
        lazy = LazyModule("fractions")
        assert "fractions" not in sys.modules
        assert lazy.Fraction(1, 3) * 3 == 1
        assert "fractions" in sys.modules and vars(lazy)["Fraction"] is sys.modules["fractions"].Fraction
        print("ok")
    """)
    out = subprocess.run([sys.executable, "-c", code], capture_output=True, text=True, timeout=300)
    assert out.returncode == 0, out.stderr
    assert out.stdout.strip() == "ok"
    lazy = LazyModule("json")
    try:
        lazy.no_such_function
    except AttributeError as exc:
        assert "no_such_function" in str(exc)
    else:
        raise AssertionError("no AttributeError")
    try:
        lazy.__wrapped__
    except AttributeError:
        pass
    else:
        raise AssertionError("a dunder read imported the module")
    assert "json" in repr(lazy)


def test_a_simulation_imports_no_analysis_scene_study_export_or_plot():
    loaded = _modules_after(f"""
        import sys
        sys.path.insert(0, {BENCH!r})
        import flexmb as fm
        from scenes import b1
        res = fm.simulate(b1(2).build(), 0.01, method="CVODE_BDF", n_out=2, progress=False)
        assert res.status == "finished", res.status
    """)
    assert [m for m in NOT_IN_A_RUN if loaded[m]] == []
    assert loaded["flexmb.integrators"]  # the check reads sys.modules of the run


#: never imported by a run of CVODE_BDF stepped in compiled code (an open tree with compiled force elements): it
#: uses none of scipy's solvers, and looks its integrator up by name without importing scikit-sundae's class
NOT_IN_A_COMPILED_CVODE_RUN = ["scipy.integrate", "scipy.optimize", "scipy.special", "scipy.sparse", "sksundae",
                               "flexmb.integrators.sundials", "flexmb.integrators.second_order",
                               "flexmb.genalpha.solver"]


def _run_modules(method: str, check: list[str]) -> dict:
    """Simulate B1 N = 8 by ``method`` in a new interpreter: which of ``check`` are then in sys.modules."""
    out = subprocess.run([sys.executable, "-c", textwrap.dedent(f"""
        import json, sys
        sys.path.insert(0, {BENCH!r})
        import flexmb as fm
        from scenes import b1
        res = fm.simulate(b1(8).build(), 0.01, method={method!r}, n_out=2, progress=False)
        assert res.status == "finished" and res.method == {method!r}, (res.status, res.method)
        print(json.dumps({{m: m in sys.modules for m in {check!r}}}))
    """)], capture_output=True, text=True, timeout=300, env=dict(os.environ, OPENBLAS_NUM_THREADS="1"))
    assert out.returncode == 0, out.stderr
    return json.loads(out.stdout.strip().splitlines()[-1])


def test_a_compiled_cvode_run_imports_no_scipy_integrate_optimize_or_sundae():
    loaded = _run_modules("CVODE_BDF", NOT_IN_A_COMPILED_CVODE_RUN)
    assert [m for m in NOT_IN_A_COMPILED_CVODE_RUN if loaded[m]] == []


def test_scipys_solvers_are_imported_when_asked_for():
    loaded = _run_modules("RK45", ["scipy.integrate", "flexmb.integrators.sundials"])
    assert loaded == {"scipy.integrate": True, "flexmb.integrators.sundials": False}


def test_the_integrators_public_names_resolve_on_first_use():
    import flexmb.integrators as integrators
    from flexmb.integrators import sundials

    assert set(integrators.__all__) <= set(dir(integrators))
    for name in integrators.__all__:
        assert getattr(integrators, name) is not None, name
    assert integrators.CVODEBDF is sundials.CVODEBDF is flexmb.registry.get("integrators", "CVODE_BDF")
    assert flexmb.registry.path("integrators", "CVODE_BDF") == "flexmb.integrators.sundials:CVODEBDF"
    try:
        integrators.no_such_name
    except AttributeError as exc:
        assert "no_such_name" in str(exc)
    else:
        raise AssertionError("no AttributeError")


def test_an_open_trees_build_rates_and_result_import_no_scipy_linalg():
    """The kernels of an open tree's build and right-hand side call no BLAS and nothing of numba.np.arraymath
    (numba imports scipy.linalg for either): the integrators and the Jacobian import it."""
    out = subprocess.run([sys.executable, "-c", textwrap.dedent(f"""
        import sys
        sys.path.insert(0, {BENCH!r})
        import numpy as np
        import flexmb as fm
        from scenes import b1
        system = b1(2).build()
        y = np.zeros(2 * system.n_speeds)
        y[system.n_speeds:] = 0.5
        rate = system.state_rate(0.0, y)
        res = fm.Result.from_states(system, y[:system.n_speeds], y[system.n_speeds:], t=0.0)
        assert np.all(np.isfinite(rate)) and res.shape("beam").shape[-1] == 3
        print(sorted(m for m in ("scipy.linalg", "numba.np.arraymath") if m in sys.modules))
    """)], capture_output=True, text=True, timeout=300, env=dict(os.environ, OPENBLAS_NUM_THREADS="1"))
    assert out.returncode == 0, out.stderr
    assert out.stdout.strip().splitlines()[-1] == "[]"


def test_every_public_name_resolves_and_is_listed():
    assert set(flexmb.__all__) <= set(dir(flexmb))
    for name in flexmb.__all__:
        assert getattr(flexmb, name) is not None, name
    assert callable(flexmb.simulate) and flexmb.simulate.__module__ == "flexmb.simulate"


def test_star_import_and_lazy_names_in_a_new_interpreter():
    code = textwrap.dedent("""
        import sys
        import flexmb
        import flexmb.simulate  # the submodule, imported again: the package's name stays the function
        assert callable(flexmb.simulate), flexmb.simulate
        assert "flexmb.analysis" not in sys.modules
        assert flexmb.linearize.__module__.startswith("flexmb.analysis")
        ns = {}
        exec("from flexmb import *", ns)
        missing = [n for n in flexmb.__all__ if n not in ns]
        assert not missing, missing
        assert ns["Study"] is flexmb.Study and ns["System"] is flexmb.System
        try:
            flexmb.no_such_name
        except AttributeError as exc:
            assert "no_such_name" in str(exc)
        else:
            raise AssertionError("no AttributeError")
        print("ok")
    """)
    out = subprocess.run([sys.executable, "-c", code], capture_output=True, text=True, timeout=300)
    assert out.returncode == 0, out.stderr
    assert out.stdout.strip() == "ok"


def test_the_subpackages_lazy_names_resolve_to_their_modules():
    import flexmb.constraint_elements as constraint_elements
    import flexmb.forces as forces
    import flexmb.post as post
    from flexmb.constraint_elements.point_on_curve import PointOnLine
    from flexmb.forces.contact_groups import Spheres
    from flexmb.post.sections import section_loads

    for package in (forces, constraint_elements, post):
        assert set(package.__all__) <= set(dir(package)), package.__name__
        for name in package.__all__:
            assert getattr(package, name) is not None, (package.__name__, name)
        try:
            package.no_such_name
        except AttributeError as exc:
            assert "no_such_name" in str(exc)
        else:
            raise AssertionError("no AttributeError")
    assert forces.Spheres is Spheres is flexmb.Spheres
    assert constraint_elements.PointOnLine is PointOnLine is flexmb.PointOnLine
    assert post.section_loads is section_loads


def test_a_contact_model_built_in_a_new_interpreter_finds_its_contacts():
    """The contact modules, imported by the model's first contact element, are found by the run's checks
    (``impact_speeds._contact_groups`` looks them up only where they were imported)."""
    out = subprocess.run([sys.executable, "-c", textwrap.dedent("""
        import sys
        import flexmb as fm
        from flexmb.impact_speeds import _contact_groups
        def model(contact):
            m = fm.Model()
            ball = fm.RigidBody("ball", mass=1.0, inertia=[0.001, 0.001, 0.001])
            m.add(fm.Free("free", m.ground, ball))
            if contact:
                m.add(fm.SpherePlaneContact("floor", ball, 0.05, fm.LinearContactLaw(1e5)))
            return m.build()
        assert _contact_groups(model(False)) == []
        assert "flexmb.forces.contact_base" not in sys.modules
        groups = _contact_groups(model(True))
        assert [(cls.__name__, [e.name for e in es]) for cls, es in groups] == [("SpherePlaneContact", ["floor"])]
        print("ok")
    """)], capture_output=True, text=True, timeout=300, env=dict(os.environ, OPENBLAS_NUM_THREADS="1"))
    assert out.returncode == 0, out.stderr
    assert out.stdout.strip().splitlines()[-1] == "ok"
