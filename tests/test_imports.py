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


def _run(code: str) -> str:
    out = subprocess.run(
        [sys.executable, "-c", code], capture_output=True, text=True, check=True, timeout=120
    )
    return out.stdout.strip().splitlines()[-1]


def test_package_import_and_help_load_no_scipy_and_no_method():
    """``import hdpbsid`` and ``hdpbsid --help`` load neither scipy nor a module of the
    library's computations (the names are imported on first use)."""
    probe = (
        "import json, sys\n{code}\n"
        "print(json.dumps(sorted(m for m in sys.modules if m == 'scipy' or "
        "m.startswith(('scipy.', 'hdpbsid.identify', 'hdpbsid.methods', 'hdpbsid.models.model')))))"
    )
    assert json.loads(_run(probe.format(code="import hdpbsid"))) == []
    help_code = (
        "import contextlib, io\nfrom hdpbsid.cli import main\n"
        "with contextlib.redirect_stdout(io.StringIO()):\n    main(['--help'])"
    )
    assert json.loads(_run(probe.format(code=help_code))) == []


def test_every_public_name_resolves_and_identify_stays_the_function():
    """Each name of ``__all__`` (and the lazy basis methods) is the object of its defining
    module; importing the submodule ``hdpbsid.identify`` from elsewhere first does not
    replace the function ``hdpbsid.identify``."""
    code = (
        "import importlib, json, hdpbsid\n"
        "import hdpbsid.cli  # no library module yet\n"
        "from hdpbsid.identify import identify  # the submodule, loaded by another path\n"
        "bad = [n for n, m in hdpbsid._EXPORTS.items()\n"
        "       if getattr(hdpbsid, n) is not getattr(importlib.import_module(m, 'hdpbsid'), n)]\n"
        "missing = sorted(set(hdpbsid.__all__) - set(hdpbsid._EXPORTS))\n"
        "print(json.dumps([bad, missing, callable(hdpbsid.identify),\n"
        "    hdpbsid.identify.__module__, hdpbsid.methods.__name__,\n"
        "    'identify_hermite' in dir(hdpbsid)]))"
    )
    assert json.loads(_run(code)) == [
        [],
        [],
        True,
        "hdpbsid.identify",
        "hdpbsid.methods",
        True,
    ]


def test_the_package_pickles_by_reference():
    # joblib's workers receive tasks through cloudpickle, which finds a module's reducer
    # by its exact type: a function that names the package must still travel
    import pickle

    import cloudpickle  # a dependency of joblib

    import hdpbsid

    def task():
        return hdpbsid.identify

    assert cloudpickle.loads(cloudpickle.dumps(task))() is hdpbsid.identify
    assert pickle.loads(pickle.dumps(hdpbsid)) is hdpbsid


def test_help_and_usage_errors_load_no_numpy():
    """``hdpbsid --help``, a command's ``--help`` and a usage error print without numpy:
    numpy loads OpenBLAS, which starts its threads at load, a cost a help text need not
    pay (the commands that compute import it)."""
    probe = (
        "import contextlib, io, json, sys\nfrom hdpbsid.cli import main\n"
        "codes = []\n"
        "for argv in (['--help'], ['identify', '--help'], ['frf', '--help'], ['nonsense']):\n"
        "    with contextlib.redirect_stdout(io.StringIO()), "
        "contextlib.redirect_stderr(io.StringIO()):\n"
        "        try:\n            codes.append(main(argv))\n"
        "        except SystemExit as exc:\n            codes.append(exc.code)\n"
        "print(json.dumps([codes, 'numpy' in sys.modules]))"
    )
    codes, numpy_loaded = json.loads(_run(probe))
    assert codes[-1] == 2  # the usage error is reported as one (the probe ran the parser)
    assert numpy_loaded is False
