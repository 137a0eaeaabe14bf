"""Command line interface: ``slbasis derive``.

``slbasis derive --p0 "1 - x**2" --p1 "-2*x" [--q0 ...] [--format markdown|latex]`` prints the
derivation report of any problem; ``slbasis derive --family jacobi --param alpha=1/2`` does the
same for a catalogue family (with its textbook standardisation and oracles).
"""

from __future__ import annotations

import argparse
import sys

from .families import families
from .symbolic.problem import SturmLiouville
from .symbolic.report import FORMATS


def _parser() -> argparse.ArgumentParser:
    parser = argparse.ArgumentParser(prog="slbasis", description=__doc__.splitlines()[0])
    sub = parser.add_subparsers(dest="command", required=True)
    derive = sub.add_parser(
        "derive",
        help="derive and verify everything for p0 f'' + p1 f' - q0 f = -lambda f",
        description="Print the derivation report (weight, interval, eigenvalues, norms, "
        "recurrences, ladder operators, the derivative operator of eq. 11, verification).",
    )
    source = derive.add_mutually_exclusive_group(required=True)
    source.add_argument("--p0", help="polynomial p0(x), e.g. '1 - x**2'")
    source.add_argument("--family", choices=sorted(families), help="a catalogue family")
    derive.add_argument("--p1", help="polynomial p1(x), e.g. '-2*x'")
    derive.add_argument("--q0", default="0", help="q0(x) (default 0), e.g. 'x**2'")
    derive.add_argument("--var", default="x", help="independent variable name (default x)")
    derive.add_argument(
        "--params", default="", help="comma-separated parameter symbols, e.g. 'alpha,beta'"
    )
    derive.add_argument(
        "--param",
        action="append",
        default=[],
        metavar="NAME=VALUE",
        help="family parameter value, e.g. alpha=1/2 (repeatable; omitted ones stay symbolic)",
    )
    derive.add_argument("--format", choices=FORMATS, default="markdown")
    derive.add_argument("--nmax", type=int, default=4, help="list P_n for n <= NMAX")
    return parser


def _problem(args: argparse.Namespace) -> SturmLiouville:
    if args.family:
        values = {}
        for item in args.param:
            name, sep, value = item.partition("=")
            if not sep:
                raise ValueError(f"--param expects NAME=VALUE, got {item!r}")
            values[name.strip()] = value.strip()
        return families[args.family](**values)
    if args.p1 is None:
        raise ValueError("--p1 is required with --p0")
    params = [p.strip() for p in args.params.split(",") if p.strip()]
    return SturmLiouville(args.p0, args.p1, args.q0, var=args.var, params=params)


def main(argv: list[str] | None = None) -> int:
    """Entry point of ``slbasis derive``: print the derivation report of a problem.

    Parameters
    ----------
    argv : list of str, optional
        The arguments (default ``sys.argv[1:]``).

    Returns
    -------
    int
        The exit code: 0 ok, 1 failed verification, 2 bad input (message on stderr).
    """
    args = _parser().parse_args(argv)
    try:
        problem = _problem(args)
        text = problem.report(fmt=args.format, nmax=args.nmax)
    except (ValueError, TypeError) as exc:
        print(f"slbasis: error: {exc}", file=sys.stderr)
        return 2
    sys.stdout.write(text)
    return 0 if problem.verify(max(args.nmax, 10)).ok else 1


if __name__ == "__main__":  # pragma: no cover
    raise SystemExit(main())
