"""Write ``docs/figures/wiper_viewer_1.png`` and ``wiper_viewer_2.png``: the viewer page of the wiper in Chromium.

The flexible wiper of ``flexmb run wiper`` over its first half second
(51 outputs), written as a viewer page (:func:`flexmb.viz.write_view`) and
shown by headless Chromium at t = 0.1 s and t = 0.3 s, coloured by von
Mises stress: the two frames the browser test compares in the same way.
Needs Chromium on the PATH (Debian: ``apt-get install chromium``). Run from
the repository::

    python docs/figures/wiper_viewer.py
"""

import tempfile
from pathlib import Path

import flexmb as fm
from flexmb.scenes.wiper import WiperOptions, wiper
from flexmb.viz import write_view
from flexmb.viz._browser import screenshot

HERE = Path(__file__).resolve().parent
FRAMES = {1: 10, 2: 30}  # picture number: frame (0.01 s apart)


def main():
    model, initial = wiper(WiperOptions(flexible=True))
    system = model.build()
    res = fm.simulate(system, 0.5, positions=initial, rtol=1e-6, n_out=51, progress=False)
    page = write_view(res, Path(tempfile.mkdtemp()) / "wiper.html", system=system, title="wiper (flexible)")
    for number, frame in FRAMES.items():
        png = screenshot(page, HERE / f"wiper_viewer_{number}.png", f"frame={frame}&color=von_mises",
                         window_size=(900, 520))
        print(f"wrote {png} (t = {res.t[frame]:.2f} s)")


if __name__ == "__main__":
    main()
