"""Off-screen rendering (pyvista), GIFs and time-history plots (matplotlib)."""

from __future__ import annotations

import numpy as np
import pytest

pv = pytest.importorskip("pyvista")
pytest.importorskip("matplotlib")
iio = pytest.importorskip("imageio.v3")

import flexmb as fm  # noqa: E402
from flexmb import viz  # noqa: E402

from conftest import fourbar, fourbar_initial  # noqa: E402

pv.OFF_SCREEN = True

SIZE = (240, 180)


@pytest.fixture(scope="module")
def result():
    return fm.simulate(fourbar(), 0.3, positions=fourbar_initial(), n_out=9)


def _foreground(img, background=255):
    """Mask of pixels that differ from a white background."""
    return np.any(img[..., :3] != background, axis=-1)


def test_render_state_draws_the_bodies(result, tmp_path):
    path = viz.render_state(result, 0, tmp_path / "state.png", window_size=SIZE)
    img = iio.imread(path)
    assert img.shape[:2] == SIZE[::-1]
    assert img.var() > 0
    fg = _foreground(img)
    h, w = fg.shape
    # the camera frames the mechanism: bodies in the centre region, margins clear
    assert fg[h // 4: 3 * h // 4, w // 4: 3 * w // 4].any()
    assert 0.005 < fg.mean() < 0.5
    assert not fg[:2].any() and not fg[-2:].any()
    assert sorted(p.name for p in tmp_path.iterdir()) == ["state.png"]


def test_render_colours_by_velocity(result, tmp_path):
    path = viz.render_state(result, -1, tmp_path / "v.png", window_size=SIZE, scalars="velocity", view="iso")
    assert _foreground(iio.imread(path)).any()


def test_animate_writes_every_frame(result, tmp_path):
    path = viz.animate(result, tmp_path / "run.gif", stride=2, window_size=(120, 90))
    frames = iio.imread(path, index=None)
    assert path.stat().st_size > 0
    assert frames.shape[0] == 5  # outputs 0, 2, 4, 6, 8
    assert not np.array_equal(frames[0], frames[-1])  # the mechanism moved


def test_result_plot_writes_png(result, tmp_path):
    fig = result.plot(["A", "D.angle"], path=tmp_path / "history.png", energy=True)
    assert (tmp_path / "history.png").read_bytes()[:8] == b"\x89PNG\r\n\x1a\n"
    assert [line.get_label() for line in fig.axes[0].lines] == ["A.angle", "D.angle"]
    assert len(fig.axes) == 2


def test_bad_viz_input(result, tmp_path):
    with pytest.raises(fm.ExportError, match="view"):
        viz.render_state(result, 0, tmp_path / "a.png", view="top")
    with pytest.raises(fm.ExportError, match="output index"):
        viz.render_state(result, 99, tmp_path / "a.png")
    with pytest.raises(fm.ExportError, match="no coordinate or joint"):
        result.plot("nope", path=tmp_path / "b.png")
    assert list(tmp_path.iterdir()) == []
