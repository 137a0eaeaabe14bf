"""The ``hdpbsid frf`` and ``hdpbsid input`` commands (registered by :mod:`hdpbsid.cli`).

``hdpbsid frf FILE --inputs U --outputs Y [--dt DT] [--period N --skip P] [--reference R]
[--fit [--order N]] [--model MODEL.json]``: the frequency response and coherence of a
record (Welch H1, from a reference in closed loop, or the exact lines of a periodic
record), written to ``OUT/frf.csv`` with its 95 % region, and a Bode figure
``OUT/frf.png``: magnitude and phase of the estimate with its region, the model (fitted
to it with ``--fit`` by :func:`hdpbsid.frequency.fit.identify_frequency`, or read from
``--model``, e.g. a model of ``hdpbsid identify``) with its 95 % band from the parameter
covariance (:func:`hdpbsid.models.uncertainty.response_band`), and the coherence with its bounds.

``hdpbsid input KIND --dt DT --samples N ...``: an input design from
:mod:`hdpbsid.design.inputs` written to ``OUT/input.csv`` (columns ``t, u1, ...``) with its figure.
"""

from __future__ import annotations

import argparse
from pathlib import Path
from typing import Any, TextIO

COMMANDS = ("frf", "input")


def add_parsers(sub: Any) -> None:
    """Register the ``frf`` and ``input`` commands on the ``hdpbsid`` subparsers.

    Parameters
    ----------
    sub : argparse._SubParsersAction
        The ``add_subparsers()`` object of the ``hdpbsid`` parser.
    """
    _add_frf_parser(sub)
    _add_input_parser(sub)


def _add_frf_parser(sub: Any) -> None:
    """The ``frf`` command's arguments."""
    f = sub.add_parser(
        "frf",
        help="frequency response, coherence and a model from frequency data",
        description="Non-parametric frequency response of a record (hdpbsid.frequency) "
        "with its 95 %% region and coherence; optionally a model fitted to it.",
    )
    f.add_argument("file", metavar="FILE")
    f.add_argument("--inputs", nargs="+", required=True, metavar="COLS")
    f.add_argument("--outputs", nargs="+", required=True, metavar="COLS")
    f.add_argument("--time", default=None, help="time column (default t)")
    f.add_argument("--dt", type=float, default=None, help="sampling interval (no time column)")
    f.add_argument("--fs", type=float, default=None, help="sampling rate (no time column)")
    f.add_argument("--delimiter", default=None, help="CSV delimiter (default: sniffed)")
    f.add_argument(
        "--reference",
        nargs="+",
        default=None,
        metavar="COLS",
        help="reference columns (closed loop: H = S_yr S_ur^-1)",
    )
    f.add_argument(
        "--period",
        type=int,
        default=None,
        help="samples per period of a periodic input (exact DFT lines)",
    )
    f.add_argument("--skip", type=int, default=1, help="periods skipped (default 1)")
    f.add_argument("--nperseg", type=int, default=None, help="Welch segment length")
    f.add_argument("--fit", action="store_true", help="identify a model from the estimate")
    f.add_argument("--order", type=int, default=None, help="model order (default: chosen)")
    f.add_argument(
        "--model",
        default=None,
        metavar="MODEL.json",
        help="a saved model drawn over the estimate (with its band when it has a covariance)",
    )
    f.add_argument("--out", default="hdpbsid-frf", help="output directory")
    f.add_argument("--no-plot", action="store_true", help="do not write the figure")


def _add_input_parser(sub: Any) -> None:
    """The ``input`` command's arguments."""
    i = sub.add_parser(
        "input",
        help="design an input signal (PRBS, random binary, multisine, chirp, Hermite sweep)",
        description="Write an input design of hdpbsid.design.inputs to OUT/input.csv.",
    )
    i.add_argument(
        "kind", choices=("prbs", "rbs", "multisine", "chirp", "logchirp", "hermite-sweep")
    )
    i.add_argument("--dt", type=float, required=True, help="sampling interval (s)")
    i.add_argument(
        "--samples",
        type=int,
        default=None,
        help="samples (period for multisine; 2^order - 1 bits for prbs)",
    )
    i.add_argument(
        "--band",
        type=float,
        nargs=2,
        default=None,
        metavar=("F_LO", "F_HI"),
        help="band in Hz (multisine, rbs; f0 f1 for sweeps)",
    )
    i.add_argument("--order", type=int, default=10, help="PRBS register length (default 10)")
    i.add_argument("--clock", type=float, default=None, help="random binary clock (s)")
    i.add_argument("--periods", type=int, default=1, help="periods (prbs, multisine)")
    i.add_argument("--channels", type=int, default=1, help="inputs (default 1)")
    i.add_argument("--amplitude", type=float, default=1.0, help="peak value (default 1)")
    i.add_argument("--n-max-u", type=int, default=300, help="Hermite terms (hermite-sweep)")
    i.add_argument("--seed", type=int, default=0, help="random seed (rbs)")
    i.add_argument("--out", default="hdpbsid-input", help="output directory")
    i.add_argument("--no-plot", action="store_true", help="do not write the figure")


def run(args: argparse.Namespace, out: TextIO) -> int:
    """Run the ``frf`` or ``input`` command.

    ``frf`` reads a record (:func:`hdpbsid.data.io.read_record`), estimates its frequency
    response (:func:`hdpbsid.frequency.fit.frf_periodic` with ``--period``, else
    :func:`~hdpbsid.frequency.fit.frf_welch`) and optionally fits a model to it;
    ``input`` designs an excitation (:mod:`hdpbsid.design.inputs`).

    Parameters
    ----------
    args : argparse.Namespace
        The parsed command line (``args.command`` is ``"frf"`` or ``"input"``).
    out : file-like
        Where the text report goes.

    Returns
    -------
    int
        The exit code, 0; errors raise (the CLI turns them into messages).

    Raises
    ------
    ValueError
        From the readers and estimators on a bad file, column or setting.
    """
    if args.command == "frf":
        return _run_frf(args, out)
    return _run_input(args, out)


def _run_frf(args: argparse.Namespace, out: TextIO) -> int:
    import numpy as np

    from hdpbsid.frequency import (
        fit as frequency,  # here: the parsers (--help) need none of the library
    )

    if args.fit and args.model:  # before any reading or estimation
        raise ValueError("give --fit or --model, not both")
    rec, est = _frf_estimate(args, frequency)
    model = frequency.identify_frequency(est, order=args.order) if args.fit else None
    if args.model:
        from hdpbsid.models.model_io import load_model

        model = load_model(args.model)
    outdir = Path(args.out)
    outdir.mkdir(parents=True, exist_ok=True)
    cols = _frf_columns(est, rec.inputs, rec.outputs)
    names = list(cols)
    np.savetxt(
        outdir / "frf.csv",
        np.column_stack([cols[k] for k in names]),
        delimiter=",",
        header=",".join(names),
        comments="",
    )
    print(
        f"{est.method}: {est.w.size} lines, {est.w.min():.4g}-{est.w.max():.4g} rad/s "
        f"-> {outdir / 'frf.csv'}",
        file=out,
    )
    if model is not None:
        eig = ", ".join(f"{e:.4g}" for e in model.eigenvalues)
        print(f"model: order {model.n}, eigenvalues {eig}", file=out)
    if not args.no_plot:
        _save_figure(lambda: frequency.plot_frf(est, model), outdir / "frf.png")
    return 0


def _frf_estimate(args: argparse.Namespace, frequency: Any) -> tuple[Any, Any]:
    """The record of ``args.file`` and its FRF: averaged over periods (``--period``) or
    Welch's estimate, with the reference columns as instruments (``--reference``)."""
    import numpy as np

    from hdpbsid.data.io import read_record

    time = args.time if (args.time or args.dt is not None or args.fs is not None) else "t"

    def read(inputs: list[str], outputs: list[str]) -> Any:
        return read_record(
            args.file, inputs, outputs, time=time, dt=args.dt, fs=args.fs,
            delimiter=args.delimiter,
        )  # fmt: skip

    rec = read(args.inputs, args.outputs)
    dt = float(np.mean(np.diff(rec.t)))
    if args.period is not None:
        return rec, frequency.frf_periodic(rec.u, rec.y, dt, args.period, skip=args.skip)
    r = read([], args.reference).y if args.reference else None
    return rec, frequency.frf_welch(rec.u, rec.y, dt, r=r, nperseg=args.nperseg)


def _frf_columns(est: Any, inputs: list[str], outputs: list[str]) -> dict[str, Any]:
    """The columns of ``frf.csv``: frequency, then per output and input the magnitude
    (dB), the phase (degrees) and the 95 % confidence radius when the estimate has a
    variance, and per output the coherence when it has one."""
    import numpy as np

    cols: dict[str, Any] = {"w_rad_s": est.w}
    radius = est.confidence_radius() if est.variance is not None else None
    for i, yn in enumerate(outputs):
        for j, un in enumerate(inputs):
            H = est.H[i, j]
            cols[f"mag_db_{yn}_{un}"] = 20 * np.log10(np.abs(H))
            cols[f"phase_deg_{yn}_{un}"] = np.degrees(np.angle(H))
            if radius is not None:
                cols[f"radius95_{yn}_{un}"] = radius[i, j]
        if est.coherence is not None:
            cols[f"coherence_{yn}"] = est.coherence[i]
    return cols


def _save_figure(draw: Any, path: Path) -> None:
    """Draw (``draw()`` returns the figure) with the file backend, save, close."""
    import matplotlib

    matplotlib.use("Agg")
    import matplotlib.pyplot as plt

    fig = draw()
    fig.savefig(path, dpi=120)
    plt.close(fig)


def _run_input(args: argparse.Namespace, out: TextIO) -> int:
    import numpy as np

    from hdpbsid.design import inputs

    d = _DESIGNS[args.kind](args, inputs)
    outdir = Path(args.out)
    outdir.mkdir(parents=True, exist_ok=True)
    header = ",".join(["t"] + [f"u{j + 1}" for j in range(d.m)])
    np.savetxt(
        outdir / "input.csv", np.column_stack([d.t, d.u]), delimiter=",", header=header, comments=""
    )
    cf = ", ".join(f"{c:.3f}" for c in d.crest_factor)
    print(
        f"{d.kind}: {d.u.shape[0]} samples, {d.m} channel(s), crest factor {cf} "
        f"-> {outdir / 'input.csv'}",
        file=out,
    )
    if not args.no_plot:
        _save_figure(lambda: inputs.plot_input(d), outdir / "input.png")
    return 0


def _band(args: argparse.Namespace) -> tuple[float, ...] | None:
    """``--band`` as a tuple, or ``None``."""
    return tuple(args.band) if args.band is not None else None


def _prbs(args: argparse.Namespace, inputs: Any) -> Any:
    """A maximum-length binary sequence (``prbs``)."""
    return inputs.prbs(
        args.order, args.dt, periods=args.periods, amplitude=args.amplitude, channels=args.channels
    )


def _rbs(args: argparse.Namespace, inputs: Any) -> Any:
    """A random binary signal (``rbs``)."""
    import numpy as np

    return inputs.random_binary(
        _need(args.samples, "--samples"),
        args.dt,
        rng=np.random.default_rng(args.seed),
        clock=args.clock,
        band=_band(args),
        amplitude=args.amplitude,
        channels=args.channels,
    )


def _multisine(args: argparse.Namespace, inputs: Any) -> Any:
    """A multisine over ``--band`` (``multisine``)."""
    return inputs.multisine(
        _need(args.samples, "--samples"),
        args.dt,
        _need(_band(args), "--band"),
        periods=args.periods,
        amplitude=args.amplitude,
        channels=args.channels,
    )


def _chirp(args: argparse.Namespace, inputs: Any) -> Any:
    """A linear (``chirp``) or logarithmic (``logchirp``) sweep over ``--band``."""
    f0, f1 = _need(_band(args), "--band")
    return inputs.chirp(
        _need(args.samples, "--samples"),
        args.dt,
        f0,
        f1,
        amplitude=args.amplitude,
        method="linear" if args.kind == "chirp" else "logarithmic",
    )


def _hermite_sweep(args: argparse.Namespace, inputs: Any) -> Any:
    """A sweep projected on Hermite functions (``hermite-sweep``)."""
    f0, f1 = _need(_band(args), "--band")
    return inputs.hermite_sweep(
        _need(args.samples, "--samples"),
        args.dt,
        f0,
        f1,
        n_max_u=args.n_max_u,
        amplitude=args.amplitude,
    )


#: the design of each ``hdpbsid input KIND`` (:mod:`hdpbsid.design.inputs`) from the arguments
_DESIGNS = {
    "prbs": _prbs,
    "rbs": _rbs,
    "multisine": _multisine,
    "chirp": _chirp,
    "logchirp": _chirp,
    "hermite-sweep": _hermite_sweep,
}


def _need(value: Any, flag: str) -> Any:
    if value is None:
        raise ValueError(f"{flag} is required for this input kind")
    return value
