"""Start-up: the heavy modules are imported where they are used, not by ``import hdpbsid``.

Each check runs in a fresh interpreter (``sys.modules`` of the test process already holds
everything), so it observes exactly what an import or a ``--help`` pulls in.
"""

from __future__ import annotations

import json
import subprocess
import sys

import pytest

#: imported only by the calls that need them: sympy by derivations, scipy.signal /
#: scipy.stats / scipy.optimize by the functions that filter, test or minimise,
#: matplotlib by plots, numba by the first compiled call
HEAVY = ("sympy", "scipy.signal", "scipy.stats", "scipy.optimize", "matplotlib", "numba")


def _loaded_after(code: str) -> list[str]:
    """The modules of :data:`HEAVY` in ``sys.modules`` after running ``code`` afresh."""
    probe = (
        f"{code}\nimport json, sys\nprint(json.dumps([m for m in {HEAVY!r} if m in sys.modules]))"
    )
    out = subprocess.run(
        [sys.executable, "-c", probe], capture_output=True, text=True, check=True, timeout=120
    )
    return json.loads(out.stdout.strip().splitlines()[-1])


@pytest.mark.parametrize("module", ["hdpbsid", "slbasis", "hdpbsid.identify", "hdpbsid.cli"])
def test_import_leaves_heavy_modules_alone(module):
    assert _loaded_after(f"import {module}") == []


def test_help_leaves_heavy_modules_alone():
    code = (
        "import contextlib, io\n"
        "from hdpbsid.cli import main\n"
        "with contextlib.redirect_stdout(io.StringIO()):\n"
        "    try:\n"
        "        main(['--help'])\n"
        "    except SystemExit:\n"
        "        pass"
    )
    assert _loaded_after(code) == []


def test_derivation_still_imports_sympy_on_demand():
    # the lazy attribute and the catalogue's builders bring sympy in when they are used
    code = "import slbasis\nassert slbasis.families.legendre().eigenvalue() is not None"
    assert _loaded_after(code) == ["sympy"]
    code = "import slbasis\nassert slbasis.SturmLiouville.__name__ == 'SturmLiouville'"
    assert _loaded_after(code) == ["sympy"]
