"""What a notebook shows of a Result: a short HTML table, and the picture of ``show()``."""

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


def test_a_picture_is_its_path_and_shows_the_png_inline(tmp_path):
    """``result.show()`` returns a viz.Picture: a Path in a script, the image in a notebook or a docs page."""
    import base64

    import matplotlib

    matplotlib.use("Agg")
    import matplotlib.pyplot as plt

    from flexmb.viz import Picture

    png = tmp_path / "state.png"
    plt.imsave(png, np.eye(4))
    picture = Picture(png)
    assert isinstance(picture, type(png)) and picture == png and picture.read_bytes() == png.read_bytes()
    assert picture._repr_png_() == png.read_bytes()
    html = picture._repr_html_()
    assert html.startswith('<img src="data:image/png;base64,')
    assert base64.b64decode(html.split("base64,", 1)[1].split('"', 1)[0]) == png.read_bytes()
    text = tmp_path / "not_a.png"
    text.write_text("no picture")
    assert Picture(text)._repr_png_() is None and Picture(text)._repr_html_() is None


# ----------------------------------------------------------------------------- what a terminal shows (issue #32)


def test_a_result_s_repr_fits_on_one_screen():
    """repr(Result) printed every array (35-64 kB); now the notebook table's rows and the arrays' shapes."""
    res = fm.simulate(fourbar(), 0.5, positions=fourbar_initial(), n_out=201)
    text = repr(res)
    assert len(text.splitlines()) <= 20 and len(text) < 2000, text
    for part in ("finished: reached t_end", "201 outputs", res.method, "largest residuals", "x (201, 3)",
                 "reactions (201, 2)"):
        assert part in text, part


def test_print_model_and_repr_system_say_what_flexmb_info_says():
    model = fourbar()
    assert repr(model) == ("<Model 'fourbar': 3 bodies, 4 joints, 1 force element, 0 drivers; print() it for its "
                           "coordinates, loops and freedoms>")
    text = str(model)
    for part in ("bodies (3):", "crank: RigidBody, mass 0.1 kg", "A: Revolute ground -> crank; coordinates A.angle",
                 "C: PlanarRevolute coupler -> rocker; cut joint closing a loop, 2 constraint rows",
                 "forces: gravity (Gravity)", "coordinates: n = 3", "constraint rows: m = 2 (C.slide.x, C.slide.y)",
                 "redundant rows: 0", "degrees of freedom: p = n - rank = 1"):
        assert part in text, part
    system = model.build()
    assert repr(system) == ("<System 'fourbar': 3 bodies, 4 joints, n = 3 coordinates, 1 loop-closing joints, m = 2 "
                            "constraint rows (0 redundant), p = 1 degrees of freedom; complement svd>")
    assert str(system).splitlines()[1:] == text.splitlines()[1:]


def test_the_description_counts_redundant_rows_and_lists_an_invalid_model_s_problems():
    spatial = fourbar(fm.Revolute)  # the four-bar closed by a spatial revolute: 5 rows of rank 2, 3 redundant
    assert "m = 5 constraint rows (3 redundant), p = 1 degrees of freedom" in repr(spatial.build())
    assert "redundant rows: 3" in str(spatial)
    broken = fm.Model("broken")
    broken.add(fm.Revolute("pin", broken.ground, "nobody"))
    assert str(broken).startswith("Model 'broken', which does not build: ") and "nobody" in str(broken)
