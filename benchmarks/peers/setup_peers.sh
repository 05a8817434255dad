#!/usr/bin/env bash
# Create the peers' virtual environment (separate from flexmb's) and install
# the peer tools from PyPI: exudyn, pydy + sympy (+ cython for pydy's
# compiled code), numpy, scipy, and mujoco (skip it with PEERS_MUJOCO=0).
#
# Usage: bash benchmarks/peers/setup_peers.sh [VENV_DIR]   (default /work/venv-peers)
# Takes about 1-2 minutes. Prints the installed versions at the end.
set -euo pipefail
VENV="${1:-/work/venv-peers}"
PY="${PYTHON:-python3}"
if [ ! -x "$VENV/bin/python" ]; then
    "$PY" -m venv "$VENV"
fi
"$VENV/bin/python" -m pip install -q --upgrade pip
"$VENV/bin/python" -m pip install -q "exudyn>=1.13" "pydy>=0.9" "sympy>=1.12" "numpy" "scipy" "cython" "setuptools"
if [ "${PEERS_MUJOCO:-1}" = "1" ]; then
    "$VENV/bin/python" -m pip install -q mujoco
fi
"$VENV/bin/python" - <<'PYEOF'
import importlib
for name in ("exudyn", "pydy", "sympy", "numpy", "scipy", "Cython", "mujoco"):
    try:
        mod = importlib.import_module(name)
        print(f"{name:8s} {getattr(mod, '__version__', '?')}")
    except Exception as exc:  # noqa: BLE001 - report what is missing
        print(f"{name:8s} not installed ({type(exc).__name__})")
PYEOF
