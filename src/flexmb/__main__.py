"""``python -m flexmb`` runs the command line."""

from .cli import console

console()
