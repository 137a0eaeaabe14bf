# ---
# jupyter:
#   jupytext:
#     formats: py:percent
#     text_representation:
#       extension: .py
#       format_name: percent
#   kernelspec:
#     display_name: Python 3
#     language: python
#     name: python3
# ---

# %% [markdown]
# # A small reproduction of the thesis's Table 1: HD-PBSID vs CT-PBSID vs DT in closed loop
#
# The thesis *Continuous-time system identification with functional basis expansions*
# (§5; "the source" below) compares HD-PBSID (Hermite
# domain) with CT-PBSID (Laguerre domain, refs. [2-4]) on a closed-loop quadrotor model
# with Monte Carlo runs at SNR 50, 20, 10 and 6 dB, and reports the bias and standard
# deviation of the identified eigenvalues (its Table 1) and the eigenvalue clouds at 6 dB
# (its Figure 1).  Its claims:
#
# * at low noise both methods are accurate;
# * HD-PBSID stays accurate and unbiased down to 10 dB, CT-PBSID "encounters difficulties,
#   often resulting in divergent behavior";
# * at 6 dB the HD-PBSID eigenvalues are more tightly clustered, with fewer outliers.
#
# The source's Table 1 (its "Dim 1 / Dim 2" columns are not defined in the summary):
#
# | SNR (dB) | method | bias dim 1 | bias dim 2 | STD dim 1 | STD dim 2 |
# |---|---|---|---|---|---|
# | 50 | Hermite | 0.005854 | 0.00071335 | 0.012384 | 0.0038998 |
# | 50 | Laguerre | 0.00047555 | 6.6732e-5 | 0.00095678 | 0.00017196 |
# | 20 | Hermite | 0.00046385 | 0.0048368 | 0.077576 | 0.035362 |
# | 20 | Laguerre | 0.10017 | 0.0061251 | 0.1052 | 0.0083464 |
# | 10 | Hermite | 0.05526 | 0.027607 | 0.23503 | 0.11277 |
# | 10 | Laguerre | 2.5129 | 0.18066 | 4.6628 | 0.30477 |
# | 6 | Hermite | 0.15335 | 1.8918 | 0.45364 | 0.19165 |
# | 6 | Laguerre | 45.89 | 1.8254 | 227.25 | 1.0726 |
#
# We run the same experiment with `hdpbsid.studies` (the engine behind `hdpbsid study
# table1`): the simulated ANT-X pitch loop of notebook 02, 30 s at 250 Hz, the source's
# Hermite-projected 1-4 Hz sweep ($n_{max,u} = 300$), outputs $q, \theta$, order 3, and for
# each run the **same record** identified by every method with its `identify` defaults:
#
# * `hermite`: HD-PBSID (§3.2);
# * `laguerre`: CT-PBSID, projection onto Laguerre functions (the variant the source
#   found better, §1 and §3.1);
# * `laguerre-filter`: CT-PBSID with the Laguerre filter network;
# * `dt`: discrete-time PBSID of the samples, converted to continuous time.
#
# Bias is $|\overline{\lambda} - \lambda|$ and STD $\sqrt{\overline{|\lambda -
# \overline\lambda|^2}}$ (rad/s) per true eigenvalue over the runs that returned a model:
# the oscillatory pair $-2.92 \pm 3.24i$ and the unstable real pole $+3.08$.  The study
# counts a run as **divergent** when an eigenvalue runs away: its relative error exceeds
# `hdpbsid.studies.base.DIVERGENCE` (10, i.e. off by ten times its magnitude); we also
# count the runs whose worst relative error exceeds 100 % (an eigenvalue on the wrong side
# of the axis, say).  **Failed** runs are those where the method raised (e.g. `dt` when the
# discrete model has no real logarithm).
#
# **Settings.** `HDPBSID_NOTEBOOK_SMALL=1` (the test suite): 2 runs at 50 and 6 dB, without
# `dt` (10-20 s per identification), about 15 s in all.  Default: 10 runs at every SNR
# (about 10 minutes on one core of this machine, dominated by `dt`, whose AIC picks a long
# VARX past).  `HDPBSID_NOTEBOOK_RUNS` and `HDPBSID_NOTEBOOK_JOBS` override the runs and the
# local processes, `HDPBSID_NOTEBOOK_OUT=DIR` keeps the results (resumable, CSV/JSON and
# the study's own figures); `hdpbsid study table1 --runs 100` is the full command-line
# version.
# `HDPBSID_NOTEBOOK_FIGDIR=DIR` writes the figures as PNGs.

# %%
import os
import time
from pathlib import Path

import matplotlib.pyplot as plt
import numpy as np

import hdpbsid.studies
from hdpbsid.studies.base import DIVERGENCE
from hdpbsid.systems.quadrotor import pitch_model

SMALL = os.environ.get("HDPBSID_NOTEBOOK_SMALL", "0") == "1"
FIGDIR = os.environ.get("HDPBSID_NOTEBOOK_FIGDIR")
RUNS = int(os.environ.get("HDPBSID_NOTEBOOK_RUNS", 2 if SMALL else 10))
JOBS = int(os.environ.get("HDPBSID_NOTEBOOK_JOBS", 1))
# optional results directory: resumable (finished runs are reused), CSV/JSON and the
# study's own PNG figures are written there
OUT = os.environ.get("HDPBSID_NOTEBOOK_OUT")
SNRS = (50.0, 6.0) if SMALL else (50.0, 20.0, 10.0, 6.0)
ALL_METHODS = ("hermite", "laguerre", "laguerre-filter", "dt")
# dt costs 10-20 s per identification (its AIC picks a VARX past of ~76 samples): the
# small settings leave it out
METHODS = ALL_METHODS[:3] if SMALL else ALL_METHODS
LABELS = {
    "hermite": "HD-PBSID (Hermite)",
    "laguerre": "CT-PBSID (Laguerre projection)",
    "laguerre-filter": "CT-PBSID (Laguerre filters)",
    "dt": "DT PBSID + d2c",
}


def save(fig, name):
    """Show the figure; also write it as a PNG when HDPBSID_NOTEBOOK_FIGDIR is set."""
    if FIGDIR:
        Path(FIGDIR).mkdir(parents=True, exist_ok=True)
        fig.savefig(Path(FIGDIR) / f"03_{name}.png", dpi=110, bbox_inches="tight")
    plt.show()


print(f"small settings: {SMALL}; {RUNS} runs per SNR, SNR {SNRS} dB, jobs {JOBS}")
print("study defaults:", hdpbsid.studies.STUDIES["table1"].defaults)

# %% [markdown]
# ## 1. Run the study
#
# Every task draws its noise from `SeedSequence([seed, hash(record settings), run])`, so
# the numbers do not depend on `jobs`, on the order tasks finish in, or on the other
# methods in the study; rerunning with more runs reproduces the first ones.

# %%
t0 = time.perf_counter()
result = hdpbsid.studies.run_study(
    "table1", runs=RUNS, seed=0, jobs=JOBS, out=OUT, progress=False, snrs=SNRS, methods=METHODS
)
print(f"{len(result.records)} identifications in {time.perf_counter() - t0:.1f} s")
print(result.table())

# %% [markdown]
# ## 2. The eigenvalue clouds (the source's Figure 1)
#
# Every run's identified eigenvalues, per method, at the highest and the lowest SNR.  The
# axes are zoomed on the truth: runs far outside are counted in the legend.

# %%
true = np.linalg.eigvals(pitch_model()[0])
summary = {(row["snr_db"], row["method"]): row for row in result.summary}


def clouds(snr):
    """method -> (identified eigenvalues of every successful run, number of failures)."""
    out = {}
    for m in METHODS:
        recs = [r for r in result.records if r["case"]["data"]["snr_db"] == snr]
        recs = [r for r in recs if r["case"]["method"] == m]
        eigs = [complex(a, b) for r in recs if r["ok"] for a, b in r["result"]["eigenvalues"]]
        out[m] = (np.array(eigs), sum(not r["ok"] for r in recs))
    return out


shown_snrs = (SNRS[0], SNRS[-1])
fig, axes = plt.subplots(1, 2, figsize=(12, 6.5))
box = (-6.5, 6.5, -5.5, 5.5)  # zoom: re in [-6.5, 6.5], im in [-5.5, 5.5] rad/s
markers = {"hermite": "o", "laguerre": "s", "laguerre-filter": "^", "dt": "D"}
for ax, snr in zip(axes, shown_snrs, strict=True):
    ax.plot(true.real, true.imag, "x", color="0.3", ms=16, mew=1.5, zorder=1, label="true")
    for c, (m, (eigs, failed)) in enumerate(clouds(snr).items()):
        inside = (
            (eigs.real > box[0])
            & (eigs.real < box[1])
            & (eigs.imag > box[2])
            & (eigs.imag < box[3])
        )
        label = f"{LABELS[m]}: {np.sum(~inside)} outside view, {failed} failed runs"
        ax.plot(
            eigs.real[inside],
            eigs.imag[inside],
            markers[m],
            color=f"C{c}",
            mfc="none",
            ms=7,
            alpha=0.8,
            zorder=3,
            label=label,
        )
    ax.set_xlim(box[0], box[1])
    ax.set_ylim(box[2], box[3])
    ax.axvline(0, color="0.6", lw=0.8)
    ax.set_xlabel("Re λ [rad/s]")
    ax.set_ylabel("Im λ [rad/s]")
    ax.set_title(f"SNR {snr:g} dB, {RUNS} runs")
    ax.grid(alpha=0.3)
    ax.legend(fontsize=8, loc="upper center", bbox_to_anchor=(0.5, -0.14))
fig.suptitle("Identified open-loop eigenvalues of the closed-loop quadrotor (order 3)")
fig.tight_layout()
save(fig, "clouds")

# %% [markdown]
# ## 3. Bias and STD against SNR (the source's Table 1, as curves)
#
# Both matter: a method can be consistently wrong (small STD, large bias).

# %%
fig, axes = plt.subplots(2, 2, figsize=(12, 7.5), sharex=True, sharey="row")
for col, (tag, name) in enumerate(
    (("pair", "oscillatory pair −2.92 ± 3.24i"), ("real", "unstable real pole +3.08"))
):
    for row, stat in enumerate(("bias", "std")):
        ax = axes[row, col]
        for c, m in enumerate(METHODS):
            ys = [summary[(s, m)][f"{stat} {tag}"] for s in SNRS]
            ys = [np.nan if v is None else v for v in ys]
            ax.semilogy(SNRS, ys, markers[m] + "-", color=f"C{c}", label=LABELS[m])
        ax.set_title(f"{stat.upper() if stat == 'std' else 'Bias'} of the {name}")
        ax.grid(alpha=0.3, which="both")
        if col == 0:
            ax.set_ylabel(f"{'STD' if stat == 'std' else 'bias'} over runs [rad/s]")
        if row == 1:
            ax.set_xlabel("SNR [dB]")
axes[0, 0].invert_xaxis()
axes[0, 0].legend(fontsize=8)
fig.suptitle("Bias and spread of the identified eigenvalues (missing points: every run failed)")
fig.tight_layout()
save(fig, "bias_std")

# %% [markdown]
# ## 4. What we measure, against the source's claims
#
# The checks below are qualitative and robust to the few runs of the small settings; the
# numbers above are the measurement.

# %%
hi, lo = SNRS[0], SNRS[-1]
her_hi, her_lo = summary[(hi, "hermite")], summary[(lo, "hermite")]
lag_hi, lag_lo = summary[(hi, "laguerre")], summary[(lo, "laguerre")]

# 50 dB: HD-PBSID is accurate (measured: median worst error ~0.1-0.2 %); 2 % leaves room
assert her_hi["failed"] == 0 and her_hi["divergent"] == 0
assert her_hi["median err"] < 0.02, her_hi
# 6 dB: HD-PBSID's median worst error is below CT-PBSID's (projection).  The median, not the
# STD: with the 2 runs of the small settings a standard deviation is one difference of two
# draws (measured STD ratios 0.4-1e-4 between environments), while the median errors were
# 0.44 vs 3.7 (HD, CT) in the same runs
assert her_lo["median err"] < lag_lo["median err"], (her_lo, lag_lo)

print(f"divergent: worst relative error > {DIVERGENCE:g}")
for snr in SNRS:
    for m in METHODS:
        row = summary[(snr, m)]
        recs = [r for r in result.records if r["case"]["method"] == m and r["ok"]]
        recs = [r for r in recs if r["case"]["data"]["snr_db"] == snr]
        over = sum(r["result"]["max_error"] > 1 for r in recs)
        print(
            f"{snr:4g} dB  {LABELS[m]:32s} failed {row['failed']}/{row['n']}, divergent "
            f"{row['divergent']}, worst error > 100 %: {over}, median worst error "
            f"{100 * row['median err']:.3g} %"
        )
print(
    f"\nCT-PBSID (projection) at {hi:g} dB: median worst error "
    f"{100 * lag_hi['median err']:.3g} %, divergent {lag_hi['divergent']}/{lag_hi['n']}"
)

# %% [markdown]
# **Reading the numbers.** Measured with the default settings (10 runs per SNR, seed 0;
# the small settings show the 50 and 6 dB rows on 2 runs):
#
# Median worst relative error over the runs; in brackets the runs with worst error
# > 100 % and, after the slash, the divergent ones (> 1000 %):
#
# | SNR | HD-PBSID | CT-PBSID projection | CT-PBSID filters | DT |
# |---|---|---|---|---|
# | 50 dB | 0.13 % (0 / 0) | 3000 % (6 / 6) | 0.47 % (0 / 0) | 0.61 % (0 / 0) |
# | 20 dB | 5.4 % (0 / 0) | 1.5e5 % (10 / 10) | 290 % (10 / 1) | 10 of 10 failed |
# | 10 dB | 60 % (1 / 0) | 1.5e5 % (10 / 10) | 4100 % (10 / 6) | 10 of 10 failed |
# | 6 dB | 123 % (8 / 0) | 1.6e5 % (10 / 10) | 5800 % (10 / 10) | 10 of 10 failed |
#
# * **The source's ranking holds at every SNR**: HD-PBSID is the only method that stays
#   accurate at 20 dB and the only one without divergent runs below it, and at 6 dB the
#   spread of its oscillatory pair (STD 0.41 rad/s; the source: 0.45) is about 7000 times
#   below CT-PBSID's with the projection (2855) and 300 times below the filters' (140).  At
#   20 dB its pair STD, 0.079 rad/s, is the source's 0.078.
# * **Its absolute claims do not all hold here.**  The source finds HD-PBSID "accurate and
#   unbiased, even at SNR = 10 dB".  We measure a growing bias of the *unstable* real pole
#   $+3.08$ (2.0 rad/s at 10 dB, 3.6 rad/s at 6 dB: the estimates fall near 0, see the
#   right panel of the clouds), so that 8 of 10 runs have a worst error above 100 % at
#   6 dB, although none runs away.  The source's plant and loop differ from ours (its
#   Table 1 system is not given in the summary).  In ours the sensor noise on $q, \theta$
#   feeds back through the rate PID into the identified input; we have not isolated the
#   cause of the bias.
# * **CT-PBSID with the Laguerre projection** runs away already at 50 dB in 6 of 10 runs,
#   although its default Laguerre pole (half the data bandwidth) is a sensible 11 rad/s
#   there; the errors are erratic (0.1 % to 66 000 % from run to run).  Below 50 dB the
#   white sensor noise pushes the pole to ~390 rad/s.  The source finds this method the
#   most accurate at 50 dB, so this points at our implementation, not at the basis.
# * **CT-PBSID with Laguerre filters** and **DT PBSID** are accurate at 50 dB only; `dt`
#   fails at 20 dB and below because its discrete model gets a negative real eigenvalue,
#   which has no continuous-time counterpart.
#
# Before quoting a table, rerun with more runs (`HDPBSID_NOTEBOOK_RUNS=100`, or
# `hdpbsid study table1 --runs 100 --jobs 2`).
