"""Which setting of a tool a comparison reports: robust, best pick, tuned (issue 31).

A tool's runs on one scene and N form *families* (flexmb: the method;
Exudyn: the Newton tolerance; MuJoCo: the integrator; PyDy: scipy's
method), and within a family the settings are ordered by *looseness*
(rtol, or the step size). A setting may have several runs that must all
pass: flexmb's run at ``atol`` and its runs at ``atol`` perturbed in the
last bits (the error at a loose rtol can move by a factor of 50 when atol
changes in its last bit, so one lucky run proves nothing).

- A setting **passes** when every one of its runs finished with error <=
  the target.
- A setting is **robust** when it passes and so does every tighter setting
  of its family on the grid. :func:`robust_setting` is the loosest robust
  setting of a family: a lucky loose setting with a failing tighter one is
  never it.
- The **best pick** is the fastest passing run of any setting, robust or
  not (what a fine grid flatters).
- A tool **tuned** as its documentation allows is its fastest robust
  setting over the families (:func:`tuned`), e.g. Exudyn at the fastest
  Newton tolerance whose robust step meets the target.

Only the standard library here: the peer scripts share ``rounds.py``'s
venv rule (compare.py imports this module in the project's venv).
"""

from __future__ import annotations


def family(row: dict) -> str:
    """The family of a run: its integrator without the parenthesised detail, plus its Newton tolerance if any."""
    fam = str(row.get("integrator") or "").split(" (")[0]
    if row.get("newton_rtol") is not None:
        fam += f" newton {row['newton_rtol']:g}"
    return fam


def looseness(row: dict):
    """Larger is looser: the rtol of a tolerance-controlled run, else the step size (None: a row of no setting)."""
    return row["rtol"] if row.get("rtol") is not None else row.get("h")


def run_passes(row: dict, target: float) -> bool:
    """Whether one run finished with an error at most ``target``."""
    return row.get("status", "finished") == "finished" and row.get("error") is not None and row["error"] <= target


def settings_of(rows) -> dict:
    """The runs grouped by family, then by looseness: ``{family: {looseness: [rows]}}``.

    Rows of no setting (a peer process that exited or timed out) are left out.
    """
    out: dict = {}
    for r in rows:
        if looseness(r) is None:
            continue
        out.setdefault(family(r), {}).setdefault(looseness(r), []).append(r)
    return out


def robust_setting(runs_by_looseness: dict, target: float):
    """The loosest robust setting of one family: its looseness, or None when even the tightest fails.

    Parameters
    ----------
    runs_by_looseness : dict of float to list of dict
        The family's runs by setting (every run of a setting must pass:
        the nominal run and its perturbed-atol twins).
    target : float
        The error target.
    """
    loosest = None
    for value in sorted(runs_by_looseness):  # tightest first: the chain of passing settings
        if not all(run_passes(r, target) for r in runs_by_looseness[value]):
            break
        loosest = value
    return loosest


def robust_chain(runs_by_looseness: dict, target: float) -> list:
    """Every robust setting of one family (the passing chain from the tightest), tightest first."""
    chain = []
    for value in sorted(runs_by_looseness):
        if not all(run_passes(r, target) for r in runs_by_looseness[value]):
            break
        chain.append(value)
    return chain


def nominal(runs: list) -> dict:
    """The run of a setting that is timed: the one at the unperturbed tolerances."""
    return next((r for r in runs if not r.get("atol_perturbation")), runs[0])


def robust_rows(rows, target: float, which: str = "loosest") -> dict:
    """Per family the nominal run of its robust setting: ``{family: row}`` (families with none left out).

    ``which = "loosest"`` takes the loosest robust setting
    (:func:`robust_setting`); ``"fastest"`` the robust setting of least
    ``wall_s`` (a looser setting is not always faster: more steps or
    Jacobian updates can follow from a loose tolerance).
    """
    out = {}
    for fam, by in settings_of(rows).items():
        chain = robust_chain(by, target)
        if not chain:
            continue
        if which == "loosest":
            out[fam] = nominal(by[chain[-1]])
        else:
            timed = [nominal(by[v]) for v in chain if nominal(by[v]).get("wall_s") is not None]
            if timed:
                out[fam] = min(timed, key=lambda r: r["wall_s"])
    return out


def best_pick(rows, target: float):
    """The fastest passing nominal run of any setting (robust or not), or None."""
    ok = [nominal(runs) for by in settings_of(rows).values() for runs in by.values()
          if all(run_passes(r, target) for r in runs) and nominal(runs).get("wall_s") is not None]
    return min(ok, key=lambda r: r["wall_s"]) if ok else None


def tuned(rows, target: float, which: str = "loosest"):
    """The tool tuned as its documentation allows: the fastest of its families' robust settings, or None."""
    cands = [r for r in robust_rows(rows, target, which).values() if r.get("wall_s") is not None]
    return min(cands, key=lambda r: r["wall_s"]) if cands else None
