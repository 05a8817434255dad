"""Write ``docs/figures/wiper_figs_5_6.png`` (the paper's Figs. 5 and 6 redrawn) and ``wiper_main_job.png``.

The runs of ``flexmb run wiper`` (rigid blades, then flexible blades of 6
segments; crank at 60 rpm, one turn, outputs every 2 ms), drawn on the
frame the paper's Fig. 6 prints: time 0 to 1 s, tip speed 0 to 2.5 (m/s,
our reading of the OCR; see ``docs/paper_figures.md``). Left, Fig. 5, rigid
blades; right, Fig. 6, flexible blades; each panel shows both tips (the
paper does not say which tip it plots) and, dotted, the other panel's
right tip. Speeds are exact, from the kinematics of the stored
states (:func:`flexmb.post.motion.point_motion`). ``wiper_main_job.png``
is the ``wiper.png`` of the same runs (:func:`flexmb.scene.figures.wiper_figure`),
at a lower resolution. The script prints the numbers the page quotes. Run
from the repository::

    python docs/figures/wiper_figs_5_6.py
"""

from pathlib import Path

import matplotlib
import numpy as np

matplotlib.use("Agg")

from matplotlib.figure import Figure  # noqa: E402

import flexmb as fm  # noqa: E402
from flexmb.scene.figures import wiper_figure  # noqa: E402
from flexmb.post.motion import point_motion  # noqa: E402
from flexmb.scenes.wiper import WiperOptions, wiper  # noqa: E402

HERE = Path(__file__).resolve().parent


def run(flexible: bool) -> dict:
    """The run, its system, and both tips' positions and exact velocities (m, m/s) over one crank turn."""
    options = WiperOptions(flexible=flexible, n_segments=6)
    model, initial = wiper(options)
    system = model.build(complement="svd")
    res = fm.simulate(system, 1.0, positions=initial, rtol=1e-6, n_out=501, progress=False)
    tip = (options.blade_length, 0.0, 0.0)
    motion = {side: point_motion(res, f"{side}_blade", tip, (0, 1), system) for side in ("right", "left")}
    speed = {side: np.linalg.norm(v, axis=1) for side, (_, v) in motion.items()}
    return {"t": res.t, "result": res, "system": system, "motion": motion, **speed}


def main():
    runs = {"rigid": run(False), "flexible": run(True)}
    fig = Figure(figsize=(8.0, 3.2))
    axes = fig.subplots(1, 2, sharey=True)
    for ax, (label, other), fig_no in zip(axes, (("rigid", "flexible"), ("flexible", "rigid")), (5, 6)):
        r, o = runs[label], runs[other]
        ax.plot(r["t"], r["right"], color="C0", lw=1.6, label="right tip")
        ax.plot(r["t"], r["left"], color="C1", lw=1.2, ls="--", label="left tip")
        ax.plot(o["t"], o["right"], color="k", lw=0.7, ls=":", label=f"right tip, {other} blades")
        ax.set_title(f"Fig. {fig_no}: {label} blades", fontsize=10)
        ax.set_xlim(0.0, 1.0)
        ax.set_ylim(0.0, 2.5)
        ax.set_xticks(np.arange(0.0, 1.01, 0.2))
        ax.set_yticks(np.arange(0.0, 2.51, 0.5))
        ax.set_xlabel("time (s)")
        ax.grid(alpha=0.3)
        ax.legend(fontsize=7, loc="upper center", ncols=1)
    axes[0].set_ylabel("tip speed (m/s)")
    fig.subplots_adjust(left=0.08, right=0.98, bottom=0.15, top=0.9, wspace=0.12)
    out = HERE / "wiper_figs_5_6.png"
    fig.savefig(out, dpi=100)
    print(f"wrote {out}")
    main_job = wiper_figure({k: r["result"] for k, r in runs.items()}, {k: r["system"] for k, r in runs.items()},
                            {k: r["motion"]["right"] for k, r in runs.items()})
    main_job.savefig(HERE / "wiper_main_job.png", dpi=72)
    print(f"wrote {HERE / 'wiper_main_job.png'}")
    for label, r in runs.items():
        for side in ("right", "left"):
            v, t = r[side], r["t"]
            half = t <= 0.5
            first, second = np.argmax(np.where(half, v, 0)), np.argmax(np.where(half, 0, v))
            mid = (t > 0.3) & (t < 0.7)
            slow = np.flatnonzero(mid)[np.argmin(v[mid])]
            print(f"{label:8s} {side:5s} tip: peaks {v[first]:.3f} m/s at t = {t[first]:.3f} s and "
                  f"{v[second]:.3f} m/s at t = {t[second]:.3f} s; slowest mid-turn {v[slow]:.3f} m/s at "
                  f"t = {t[slow]:.3f} s; {v[0]:.3f} m/s at t = 0, {v[-1]:.3f} m/s at t = 1 s")
    flexible = runs["flexible"]["result"]
    k = flexible.body_names.index("right_blade.base")  # the blade's clamp frame: x along it, y across it
    p = runs["flexible"]["motion"]["right"][0]
    across = np.einsum("tj,tj->t", flexible.rotations[:, k, :, 1], p - flexible.origins[:, k])
    mz = flexible.section_loads(runs["flexible"]["system"].model["right_blade"]).component("Mz")[:, 0]
    print(f"right blade: tip deflection up to {1e3 * np.abs(across).max():.3f} mm, root moment Mz up to "
          f"{np.abs(mz).max():.3f} N m (at t = {flexible.t[np.abs(mz).argmax()]:.3f} s)")
    d = runs["flexible"]["right"] - runs["rigid"]["right"]
    print(f"flexible - rigid right tip speed: largest {np.abs(d).max():.3f} m/s at t = "
          f"{runs['rigid']['t'][np.abs(d).argmax()]:.3f} s; rms {np.sqrt(np.mean(d ** 2)):.4f} m/s")


if __name__ == "__main__":
    main()
