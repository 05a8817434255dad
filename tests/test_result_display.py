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
