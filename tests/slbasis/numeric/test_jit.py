"""The first call does not wait for numba (:mod:`slbasis.numeric.jit`).

With an empty kernel cache the engine ``"auto"`` runs numpy and a background process
fills the cache; the kernels listed for that process are the ones the library's calls
use.  Cache states are made in fresh interpreters with their own empty
``NUMBA_CACHE_DIR`` (a ``tmp_path``), so the repository's cache is never read or changed.
"""

from __future__ import annotations

import json
import os
import subprocess
import sys

import numpy as np
import pytest

pytest.importorskip("numba")

from slbasis.numeric import engine  # noqa: E402 (after the numba check)


def _run(code: str, cache_dir) -> dict:
    """Run ``code`` (which prints one JSON line last) with numba's cache in ``cache_dir``."""
    env = dict(os.environ, NUMBA_CACHE_DIR=str(cache_dir))
    for switch in ("SLBASIS_NO_NUMBA", "NUMBA_DISABLE_JIT"):
        env.pop(switch, None)
    out = subprocess.run(
        [sys.executable, "-c", code], env=env, capture_output=True, text=True, timeout=600
    )
    assert out.returncode == 0, out.stderr
    return json.loads(out.stdout.strip().splitlines()[-1])


def test_auto_runs_numpy_while_the_kernels_compile(tmp_path):
    """Empty cache: the projection is the numpy engine's, bit for bit, and the background
    compilation has started (stopped here to spare the machine)."""
    code = """
import json
import numpy as np
import slbasis
from slbasis.numeric import engine, jit
B = slbasis.basis("hermite", N=64, t_span=(0.0, 10.0))
t = np.linspace(0.0, 10.0, 4001)
y = np.sin(t)
assert engine.work(64, t.size) >= engine._AUTO_MIN_WORK  # large enough for numba
auto = B.project(t, y, engine="auto")
ref = B.project(t, y, engine="numpy")
proc = jit._process["proc"]
started = proc is not None and proc is not False
ready = jit.ready(engine._compiled())  # still compiling
if started:
    proc.terminate()
    proc.wait()
print(json.dumps({"same": bool(np.array_equal(auto, ref)), "started": started, "ready": ready}))
"""
    got = _run(code, tmp_path)
    assert got == {"same": True, "started": True, "ready": False}


def test_warm_fills_the_cache_the_next_process_uses(tmp_path):
    """After :func:`jit.warm` of a module, a fresh process finds it ready and its calls
    compile nothing (numba's compile events counted)."""
    module = "hdpbsid.models.recursion_kernels"
    before = _run(
        "import json, importlib\nfrom slbasis.numeric import jit\n"
        f"m = importlib.import_module({module!r})\n"
        "cold = jit.cached(m)\nn = jit.warm(m)\n"
        "print(json.dumps({'cold_cached': cold, 'compiled': n}))",
        tmp_path,
    )
    assert before == {"cold_cached": False, "compiled": 2}
    after = _run(
        """
import json
import numpy as np
from numba.core import event
import hdpbsid.models.recursion as rec
from slbasis.numeric import jit
compiles = []
class Count(event.Listener):
    def on_start(self, ev):
        pass
    def on_end(self, ev):
        compiles.append(ev.data["dispatcher"].py_func.__name__)
with event.install_listener("numba:compile", Count()):
    kernels = rec._kernels("auto")
    F = np.array([[0.9, 0.1], [0.0, 0.5]])
    rec.linear_recursion(F, np.ones((49, 2)), np.zeros(2), engine="auto")
print(json.dumps({"uses_kernels": kernels is not None, "compiles": compiles}))
""",
        tmp_path,
    )
    assert after == {"uses_kernels": True, "compiles": []}


# short noisy records: the basis-size rule's warning is expected and beside the point here
@pytest.mark.filterwarnings("ignore:hermite. the basis-size rule:RuntimeWarning")
@pytest.mark.skipif(
    engine._disabled(), reason="NUMBA_DISABLE_JIT or SLBASIS_NO_NUMBA: nothing is compiled"
)
def test_warm_signatures_cover_the_library_calls(monkeypatch):
    """Every signature the library's calls compile is one the background process
    compiles ahead (else the first such call would wait): projections on one and on
    several threads, an identification with its refinement, systems with real and with
    complex modes."""
    import hdpbsid
    import hdpbsid.models.recursion_kernels as recursion
    import hdpbsid.refine.pem_kernels as pem
    import slbasis
    import slbasis.numeric.compiled as compiled
    from hdpbsid.systems import second_order, simulate_zoh
    from slbasis.numeric import jit
    from slbasis.runtime import num_threads

    monkeypatch.setattr(jit, "ready", lambda module: True)  # compile on the call
    B = slbasis.basis("hermite", N=64, t_span=(0.0, 10.0))
    t = np.linspace(0.0, 10.0, 40001)  # 2 threads x 1.3e6 values: above the thread threshold
    with num_threads(2):
        B.project(t, np.column_stack([np.sin(t), np.cos(t)]))
    B.project(t[:4001], np.sin(t[:4001]))
    B.eval(t[:4001])
    rng = np.random.default_rng(3)
    A, Bm, C, D = second_order()
    tt = np.arange(1500) * 0.01
    for Am in (A, np.diag([-1.0, -3.0])):  # complex and real modes
        u = np.convolve(rng.standard_normal(tt.size), np.ones(25) / 25, mode="same")  # ~2 Hz
        y = simulate_zoh(Am, Bm, C, D, tt, u)
        y = y + 0.01 * rng.standard_normal(y.shape)
        hdpbsid.identify(tt, u, y, order=2, method="hermite", refine="pem")
    assert len(pem.sensitivity_regressors.signatures) == 2  # both kinds of modes ran
    for module in (compiled, pem, recursion):
        for name, listed in module.WARM_SIGNATURES.items():
            used = getattr(module, name).signatures
            missing = [s for s in used if tuple(s) not in [tuple(x) for x in listed]]
            assert not missing, f"{module.__name__}.{name}: {missing}"
