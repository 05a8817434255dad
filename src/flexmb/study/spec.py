"""How a study names its parameters: values and specs from text (the key paths they set: :mod:`flexmb.scene.keys`)."""

from __future__ import annotations

import tomllib

import numpy as np

from ..errors import FlexmbError
from ..scene.metrics import _plain
from .sampling import DISTRIBUTIONS, Distribution

__all__ = ['parse_spec', 'parse_value']


def parse_value(text: str):
    """A TOML value from its text (``2`` is an integer, ``2.0`` a float, ``"x"`` or bare ``x`` a string).

    Parameters
    ----------
    text : str
        The value as written after ``=`` in a TOML file.

    Returns
    -------
    int, float, bool, str or list
        The value.

    Examples
    --------
    >>> from flexmb.study import parse_value
    >>> parse_value("4"), parse_value("2e11"), parse_value("true"), parse_value("Radau")
    (4, 200000000000.0, True, 'Radau')
    """
    text = text.strip()
    try:
        return tomllib.loads(f"v = {text}")["v"]
    except tomllib.TOMLDecodeError:
        try:
            return float(text)  # TOML rejects "1." and ".5"
        except ValueError:
            return text


def parse_spec(text: str):
    """Parse a parameter spec of the ``flexmb study --vary KEY=SPEC`` option.

    Parameters
    ----------
    text : str
        One of

        * ``v1,v2,...``: a list of values (TOML syntax: ``4`` is an integer,
          ``4.0`` a float);
        * ``lin:START:STOP:NUM``: ``NUM`` equally spaced values, ends included;
        * ``log:START:STOP:NUM``: ``NUM`` logarithmically spaced values;
        * ``uniform:LOW:HIGH``, ``loguniform:LOW:HIGH``, ``normal:MEAN:STD``:
          a random parameter, sampled ``samples`` times (Latin hypercube or
          Monte Carlo, with a seed).

    Returns
    -------
    list or Distribution
        The values, or the distribution to sample.

    Raises
    ------
    FlexmbError
        If the spec cannot be read.

    Examples
    --------
    >>> from flexmb.study import parse_spec
    >>> parse_spec("lin:2:8:4"), parse_spec("log:1e-3:1e-1:3")
    ([2, 4, 6, 8], [0.001, 0.01, 0.1])
    >>> parse_spec("normal:5:0.5")
    Distribution(kind='normal', a=5.0, b=0.5)
    """
    head, _, rest = text.partition(":")
    head = head.strip().lower()
    if head in ("lin", "log"):
        parts = rest.split(":")
        if len(parts) != 3:
            raise FlexmbError(f"spec {text!r}: write {head}:START:STOP:NUM")
        try:
            start, stop, num = float(parts[0]), float(parts[1]), int(parts[2])
        except ValueError:
            raise FlexmbError(f"spec {text!r}: START and STOP must be numbers and NUM an integer") from None
        if num < 1:
            raise FlexmbError(f"spec {text!r}: NUM must be >= 1, got {num}")
        if head == "log" and not (start > 0 and stop > 0):
            raise FlexmbError(f"spec {text!r}: a logarithmic range needs START and STOP > 0")
        values = np.linspace(start, stop, num) if head == "lin" else np.geomspace(start, stop, num)
        integral = all(isinstance(parse_value(p), int) for p in parts[:2])
        if integral and np.all(values == np.round(values)):
            return [int(round(v)) for v in values]
        return [float(v) for v in values]
    if head in DISTRIBUTIONS:
        parts = rest.split(":")
        if len(parts) != 2:
            raise FlexmbError(f"spec {text!r}: write {head}:A:B ({DISTRIBUTIONS[head][1]})")
        try:
            return Distribution(head, float(parts[0]), float(parts[1]))
        except ValueError:
            raise FlexmbError(f"spec {text!r}: A and B must be numbers") from None
    values = _split_list(text)
    if not values:
        raise FlexmbError(f"spec {text!r}: no values")
    return [parse_value(v) for v in values]


def _split_list(text: str) -> list[str]:
    """Split ``a,b,[1,2],"x,y"`` at the top-level commas."""
    out, depth, quote, cur = [], 0, None, ""
    for ch in text:
        if quote:
            quote = None if ch == quote else quote
        elif ch in "\"'":
            quote = ch
        elif ch in "[{":
            depth += 1
        elif ch in "]}":
            depth -= 1
        elif ch == "," and depth == 0:
            out.append(cur)
            cur = ""
            continue
        cur += ch
    out.append(cur)
    return [v.strip() for v in out if v.strip()]


def _as_spec(key: str, spec):
    """A list of plain Python values or a Distribution, from what the user gave."""
    if isinstance(spec, str):
        return parse_spec(spec)
    if isinstance(spec, Distribution):
        return spec
    values = list(np.atleast_1d(np.asarray(spec, dtype=object))) if not isinstance(spec, (list, tuple)) \
        else list(spec)
    if not values:
        raise FlexmbError(f"parameter {key!r}: no values")
    return [_plain(v) for v in values]
