"""The exit handler (flexmb._exit): garbage is finalized at exit as without it; it is registered once."""

from __future__ import annotations

import subprocess
import sys

#: a new process: garbage cycles with finalizers, made before and after importing flexmb, and by an atexit handler
#: registered before flexmb's (it runs after flexmb's handler)
SCRIPT = r"""
import atexit, gc, sys

class Cycle:
    def __init__(self, name):
        self.name, self.me = name, self
    def __del__(self):
        print("finalized", self.name, flush=True)

def late_garbage():
    Cycle("made by an earlier handler")
atexit.register(late_garbage)
Cycle("before the import")
gc.disable()  # nothing collected before the exit
import flexmb, flexmb._exit
n = atexit._ncallbacks()
flexmb._exit.install()
assert atexit._ncallbacks() == n, "installed twice"
Cycle("after the import")
with open(sys.argv[1], "w") as f:
    f.write("written")
"""


def test_garbage_is_finalized_at_exit(tmp_path):
    out = subprocess.run([sys.executable, "-c", SCRIPT, str(tmp_path / "f.txt")], capture_output=True, text=True,
                         timeout=300)
    assert out.returncode == 0, out.stderr[-2000:]
    done = {line for line in out.stdout.splitlines() if line.startswith("finalized")}
    assert done == {"finalized before the import", "finalized after the import",
                    "finalized made by an earlier handler"}, out.stdout
    assert (tmp_path / "f.txt").read_text() == "written"
