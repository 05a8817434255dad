"""
Speed against error: choosing N and the tolerance
=================================================

Every number a simulation gives carries two errors: the *discretisation*
error of the model (N finite segments instead of a continuum) and the
*integration* error of the solver (a tolerance instead of the exact
solution of the model's equations). They are measured against different
references and never mixed in one figure (BENCHMARKS.md of the project):

* integration error: against the same model (same N) solved at the
  tightest tolerance;
* discretisation error: against a much finer model (here N = 32,
  Richardson-extrapolated), each solved tightly.

This tutorial measures both for the damped cantilever B1 (tutorial 03)
released straight from rest, tip deflection at t = 0.15 s (near the
bottom of its first swing), and shows how
to read a work-precision diagram (error against cost) to choose the
tolerance and the number of segments for a required accuracy.

The numbers to expect: the integration error of Radau falls about as fast
as the tolerance (slope near 1 in log-log) and the cost grows slowly
(about 1.8 times the right-hand sides for each factor 10 in rtol); the
discretisation error of the tip falls as 1/N^2 (observed order 2.0 from
N = 8 to 16) and is, for every N, far larger than the integration error
at any tolerance of the sweep. For a total error of 0.1 mm the tutorial
picks N = 32 and the loosest tolerance of the sweep, rtol = 1e-2: time is
better spent on segments than on tolerance for this beam.
"""

import time

import numpy as np

import flexmb as fm

# %%
# The scene
# ---------
# The B1 strip of tutorial 03 with 1 % of critical damping in its first
# mode, one bending angle per segment. ``tip_z`` reads the tip's vertical
# position from the deformed centre line at the last output time.

L, g, T_END = 1.0, 9.81, 0.15
section = fm.Section.rectangular(0.02, 0.005)
material = fm.Material.aluminium()


def cantilever(n_segments):
    """The damped B1 cantilever with N segments (bending in the x-z plane)."""
    model = fm.Model(f"B1 N={n_segments}")
    beam = fm.FlexibleBody.uniform_beam("beam", L, section, material, n_segments, keep=("bend_y",),
                                        damping_ratio=0.01)
    model.add(fm.Fixed("clamp", model.ground, beam), fm.Gravity((0.0, 0.0, -g)))
    return model.build()


def tip_z(system, rtol, method="Radau"):
    """Tip z at T_END (m), wall time (s) and right-hand sides of one run."""
    t0 = time.perf_counter()
    res = fm.simulate(system, T_END, rtol=rtol, atol=rtol * 1e-3, method=method, n_out=2)
    return res.shape("beam")[-1, -1, 2], time.perf_counter() - t0, res.n_rhs


# %%
# Integration error: a work-precision sweep
# -----------------------------------------
# One model (N = 8), one reference at rtol = 1e-9, then a sweep of
# tolerances. The error is the distance of the tip from the reference; the
# cost is the wall time and, machine-independent, the number of
# right-hand-side evaluations (``result.n_rhs``).

system8 = cantilever(8)
z_ref8, _, _ = tip_z(system8, 1e-9)
rtols = np.array([1e-2, 1e-3, 1e-4, 1e-5])
sweep = []
for rtol in rtols:
    z, wall, rhs = tip_z(system8, rtol)
    sweep.append((abs(z - z_ref8), wall, rhs))
int_error, wall, rhs = (np.array(c) for c in zip(*sweep))

print(f"integration error of the tip at t = {T_END} s, N = 8, Radau")
print(f"{'rtol':>8} {'error m':>10} {'wall s':>8} {'rhs':>6}")
for r, e, w, n in zip(rtols, int_error, wall, rhs):
    print(f"{r:8.0e} {e:10.2e} {w:8.3f} {n:6d}")

# %%
# Reading the diagram: in log-log, the error falls with the tolerance
# along a line of slope close to 1 ("tolerance proportionality"); the cost
# rises along a much flatter line, because Radau is of order 5. A
# tolerance is worth tightening only until the integration error is well
# below the discretisation error: beyond that the extra time buys nothing.

slope_error = np.polyfit(np.log10(rtols), np.log10(int_error), 1)[0]
rhs_per_decade = float(np.exp(np.mean(np.diff(np.log(rhs)))))
print(f"error against rtol: slope {slope_error:.2f}; right-hand sides grow x{rhs_per_decade:.2f} per decade")

# %%
# Discretisation error: N against a fine model
# --------------------------------------------
# Each N solved at rtol = 1e-5 (its integration error, by the sweep above,
# is a million times smaller than the differences between models); the
# reference is N = 32, extrapolated. The error falls as 1/N^2 (the clamp spring is 2k,
# see tutorial 03), so C = error * N^2 is nearly constant and predicts the
# N needed for an accuracy. The order is read between N = 8 and 16, where
# the beam is resolved; N = 4 is still outside the asymptotic range.

ns = np.array([4, 8, 16])
z_32 = tip_z(cantilever(32), 1e-5)[0]
z_n = np.array([tip_z(cantilever(n), 1e-5)[0] for n in ns])
# the N = 32 model has an error of its own, C / 32^2; Richardson's
# extrapolation with N = 16 (error ratio 4) removes it
z_limit = z_32 - (z_n[-1] - z_32) / 3.0
disc_error = np.abs(z_n - z_limit)
order = np.log2(disc_error[1] / disc_error[2])
print(f"\ndiscretisation error of the tip at t = {T_END} s (reference N = 32, extrapolated)")
for n, e in zip(ns, disc_error):
    print(f"  N = {n:3d}: {e:.3e} m")
print(f"observed order from N = 8 to 16: {order:.2f}")

# %%
# The choice
# ----------
# A required total accuracy of 0.1 mm is split: nine tenths for the model,
# one tenth for the solver. N is the smallest power of two whose predicted
# discretisation error ``C / N^2`` fits; the tolerance is the loosest one
# of the sweep whose integration error fits (for N = 8 here; the
# integration error depends little on N for this beam).

target = 1e-4
C = float(disc_error[2] * ns[2] ** 2)
n_choice = int(2 ** np.ceil(np.log2(np.sqrt(C / (0.9 * target)))))
fits = int_error <= 0.1 * target
rtol_choice = float(rtols[np.argmax(fits)]) if fits.any() else float(rtols[-1])
print(f"\nfor a total error of {1e3 * target:.1f} mm: N = {n_choice}, rtol = {rtol_choice:.0e}")

# %%
# The long form: the diagram itself
# ---------------------------------
# ``benchmarks/work_precision.py`` draws these diagrams for every
# benchmark scene, integrator and N (``benchmarks/README.md``); here the
# sweep above is plotted, error against wall time and against right-hand
# sides.

if __name__ == "__main__":
    import os

    import matplotlib
    import matplotlib.ticker

    matplotlib.use("Agg")
    import matplotlib.pyplot as plt

    fig, (ax1, ax2) = plt.subplots(1, 2, figsize=(9, 3.6))
    ax1.loglog(wall, int_error, "o-")
    ax1.set_xlabel("wall time, s")
    ax1.set_ylabel(f"tip error at t = {T_END} s, m")
    for r, w, e in zip(rtols, wall, int_error):
        ax1.annotate(f"{r:.0e}", (w, e), textcoords="offset points", xytext=(4, 4), fontsize=7)
    ax1.axhline(0.1 * target, color="grey", ls="--", lw=0.8)
    ax1.set_title("integration error, N = 8, Radau")
    ax1.xaxis.set_minor_formatter(matplotlib.ticker.NullFormatter())
    ax2.loglog(ns, disc_error, "s-", label="measured")
    ax2.loglog(ns, C / ns**2, "k:", label="C / N$^2$")
    ax2.set_xlabel("segments N")
    ax2.set_ylabel("tip error against N = 32 (extrapolated), m")
    ax2.set_title("discretisation error")
    ax2.set_xticks(ns, [str(n) for n in ns])
    ax2.xaxis.set_minor_formatter(matplotlib.ticker.NullFormatter())
    ax2.legend()
    fig.tight_layout()
    os.makedirs("results", exist_ok=True)
    fig.savefig("results/07_speed_vs_error.png", dpi=120)
    print("wrote results/07_speed_vs_error.png")
