"""What a notebook shows of a Result: a short HTML table."""

from __future__ import annotations

import numpy as np

import flexmb as fm

from conftest import fourbar, fourbar_initial


def test_html_summary_names_status_integrator_cost_residuals_and_energy():
    res = fm.simulate(fourbar(), 0.2, positions=fourbar_initial(), n_out=11, method="CVODE_BDF")
    html = res._repr_html_()
    assert html.startswith("<table>") and html.endswith("</table>")
    for text in ("finished: reached t_end", "0 ... 0.2 s, 11 outputs", "CVODE_BDF", f"{res.n_steps} steps",
                 f"{res.n_rhs} right-hand sides", "largest residuals", "energy"):
        assert text in html, text
    assert f"{np.max(res.residual):.2e}" in html


def test_html_summary_of_an_open_tree_has_no_residual_line_and_says_why_auto_chose():
    model = fm.Model()
    bar = fm.RigidBody.slender_bar("bar", mass=1.0, length=1.0)
    model.add(fm.Revolute("pin", model.ground, bar), fm.Gravity((0.0, -9.81, 0.0)))
    res = fm.simulate(model, 0.1, positions={"pin": 0.5}, n_out=3)
    html = res._repr_html_()
    assert "largest residuals" not in html and "0 constraint rows" in html
    assert res.method_reason and res.method_reason.split(":")[0] in html.replace("&#x27;", "'")
