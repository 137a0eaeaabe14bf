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
# # Experiment design and the frequency domain: from an input to a model checked on a Bode plot
#
# A flight-test identification campaign starts by designing the excitation and ends by
# comparing the model with a non-parametric frequency response and its coherence.  This
# notebook walks that path on the Rao-Garnier benchmark
# $G(s) = \frac{-6400 s + 1600}{s^4 + 5 s^3 + 408 s^2 + 416 s + 1600}$ (modes at 2 and
# 20 rad/s, a non-minimum-phase zero), whose truth is known:
#
# 1. design inputs (`hdpbsid.design.inputs`): a low-crest-factor multisine, a PRBS, the thesis's
#    Hermite-projected sweep;
# 2. simulate a record at 20 dB;
# 3. estimate the frequency response and coherence (`hdpbsid.frequency`): exact lines of
#    the periodic record, and Welch's H1 for comparison;
# 4. identify a model from the frequency response (`identify_frequency`) and in the time
#    domain (`hdpbsid.identify`), and compare both with the estimate and the truth.
#
# The command-line equivalent: `hdpbsid input multisine --dt 0.01 --samples 2048 --band
# 0.04 8 --periods 12`, then `hdpbsid frf rec.csv --inputs u --outputs y --period 2048
# --skip 2 --fit`.
#
# **Settings.** `HDPBSID_NOTEBOOK_SMALL=1` (the test suite) uses fewer periods;
# `HDPBSID_NOTEBOOK_FIGDIR=DIR` writes the figures as PNGs.

# %%
import os
from pathlib import Path

import matplotlib.pyplot as plt
import numpy as np
from scipy.linalg import block_diag

import hdpbsid
from hdpbsid.design import inputs
from hdpbsid.frequency import fit as frequency
from hdpbsid.models.metrics import eigenvalue_errors
from hdpbsid.systems import add_noise

SMALL = os.environ.get("HDPBSID_NOTEBOOK_SMALL", "0") == "1"
FIGDIR = os.environ.get("HDPBSID_NOTEBOOK_FIGDIR")
PERIODS = 6 if SMALL else 12


def save(fig, name):
    """Show the figure; also write it as a PNG when HDPBSID_NOTEBOOK_FIGDIR is set."""
    if FIGDIR:
        Path(FIGDIR).mkdir(parents=True, exist_ok=True)
        fig.savefig(Path(FIGDIR) / f"05_{name}.png", dpi=110, bbox_inches="tight")
    plt.show()


# the Rao-Garnier system in real modal form: (s^2 + s + 4)(s^2 + 4 s + 400) below, the
# numerator -6400 s + 1600 split in partial fractions (c1 s + d1)/(...) + (c2 s + d2)/(...)
M = np.array([[1, 0, 1, 0], [4, 1, 1, 1], [400, 4, 4, 1], [0, 400, 0, 4]], float)
c1, d1, c2, d2 = np.linalg.solve(M, [0, 0, -6400, 1600])
A = block_diag([[0, 1], [-4, -1]], [[0, 1], [-400, -4]])
B = np.array([[0.0], [1], [0], [1]])
C = np.array([[d1, c1, d2, c2]])
truth = hdpbsid.StateSpaceModel(A, B, C, np.zeros((1, 1)), np.zeros((4, 1)))
print("true eigenvalues:", np.round(truth.eigenvalues, 4))
assert abs(truth.frequency_response([1e-9])[0, 0, 0] - 1) < 1e-6  # G(0) = 1

# %% [markdown]
# ## 1. Inputs
#
# A multisine on 0.04-8 Hz (0.25-50 rad/s: both modes and a decade around them) with a
# period of 2048 samples at dt = 0.01 s (20.48 s, lines every 0.049 Hz).  Schroeder's
# phases give a crest factor of about 1.7; the clipping algorithm brings it below 1.5, so
# the same peak (actuator limit) carries more power.  A PRBS and the Hermite-projected
# sweep of the thesis are shown for comparison.

# %%
dt, n = 0.01, 2048
schroeder = inputs.multisine(n, dt, (0.04, 8.0), phases="schroeder")
design = inputs.multisine(n, dt, (0.04, 8.0), periods=PERIODS)
print(
    f"{design.lines[0].size} lines; crest factor: Schroeder {schroeder.crest_factor[0]:.3f}, "
    f"after clipping {design.crest_factor[0]:.3f}"
)
assert design.crest_factor[0] < schroeder.crest_factor[0]
save(inputs.plot_input(design), "multisine")

prbs = inputs.prbs(9, dt, clock=2)
sweep = inputs.hermite_sweep(3001, dt, 0.05, 8.0, n_max_u=400 if not SMALL else 300)
fig, axes = plt.subplots(2, 2, figsize=(10, 5), layout="constrained")
inputs.plot_input(prbs, axes[:, 0])
inputs.plot_input(sweep, axes[:, 1])
save(fig, "prbs_and_sweep")

# %% [markdown]
# ## 2. A record at 20 dB
#
# The multisine is band-limited, so its response is simulated on a ten times finer grid
# (first-order hold: its error at 8 Hz is $(\omega h)^2 / 12 \approx 10^{-4}$) and sampled;
# white noise 20 dB below the output's power is added.

# %%
up = 10
fine = inputs.multisine(n * up, dt / up, (0.04, 8.0), periods=PERIODS, iterations=50)
t, u = fine.t[::up], fine.u[::up]
y_clean = truth.simulate(fine.t, fine.u, method="foh")[::up]
y, _ = add_noise(y_clean, 20.0, np.random.default_rng(0))

# %% [markdown]
# ## 3. Frequency response and coherence
#
# Over whole periods the DFT lines are exact (no leakage) and the scatter of the periods
# gives each line's variance; the first two periods (the transient) are skipped.  Welch's
# H1 on the same record leaks (segments are not whole periods) and is shown for contrast.

# %%
frf = frequency.frf_periodic(u, y, dt, n, skip=2)
welch = frequency.frf_welch(u, y, dt, nperseg=n)
G = truth.frequency_response(frf.w)[0, 0]
rel = np.abs(frf.H[0, 0] / G - 1)
print(f"periodic: {frf.w.size} lines, median relative error {np.median(rel):.4f}")
inside = np.abs(frf.H[0, 0] - G) < frf.confidence_radius(0.05)[0, 0]
print(f"95 % circles holding the truth: {inside.mean():.2f}")
assert inside.mean() > 0.8
save(frequency.plot_frf(frf), "frf_periodic")

# %% [markdown]
# ## 4. Models from the frequency response and from the time record
#
# `identify_frequency` starts from the frequency-domain subspace method and refines by
# weighted least squares (weights: each line's standard deviation from the periods); the
# order is chosen on held-out lines.  The time-domain `identify` runs on the same record.

# %%
model_f = frequency.identify_frequency(frf)
print("frequency-domain model:", model_f)
print("order selection:", [(r["order"], round(r["z"], 1)) for r in model_f.options["selection"]])
err_f = eigenvalue_errors(model_f.eigenvalues, truth.eigenvalues)
print(f"largest eigenvalue error: {100 * err_f.max():.3f} %")
assert model_f.n == 4 and err_f.max() < 0.02

keep = slice(2 * n, None)  # the same steady-state part
model_t = hdpbsid.identify(t[keep] - t[keep][0], u[keep], y[keep], order=4, method="dt")
err_t = eigenvalue_errors(model_t.eigenvalues, truth.eigenvalues)
print(f"time-domain model (dt, order 4): largest eigenvalue error {100 * err_t.max():.3f} %")

# %%
fig = frequency.plot_frf(frf, model_f)
G_t = model_t.frequency_response(frf.w)[0, 0]
fig.axes[0].semilogx(frf.w, 20 * np.log10(np.abs(G_t)), "--", lw=1, label="time-domain model")
fig.axes[0].legend(fontsize=8)
save(fig, "models_over_frf")

# %% [markdown]
# The frequency-domain fit uses what the periodic design makes possible: the noise
# variance of every line, hence a maximum-likelihood weighting and confidence regions a
# reviewer can read on the Bode plot.  The time-domain methods need no periodic input
# and work in closed loop; the two agree on this record.

# %% [markdown]
# ## A dead time, and the model's band
#
# The same record through an actuator with a dead time of 0.13 s (13 samples): the phase
# of the estimate falls linearly with frequency, which no rational model of order 4
# follows.  `identify(..., delay="auto")` searches the delay on the grid of whole samples
# (the refined frequency-domain fit of `H e^{+jw tau}`, order given; the multisine is
# band-limited, so `delay_hold="bandlimited"` fits continuous-time models, where a held
# input would be fitted by discrete-time ones), shifts the input and tells the model its
# dead time.  With a fourth-order model the profile is flat over a few samples: the
# estimate is within one sample here, the resolution of these data.  `refine="pem"`
# gives the parameter covariance, and `plot_frf` draws the model's 95 % band (delta
# method) over the estimate.

# %%
TAU = 0.13
delayed = hdpbsid.StateSpaceModel(A, B, C, np.zeros((1, 1)), np.zeros((4, 1)), delay=TAU)
y_d0 = delayed.simulate(fine.t, fine.u, method="foh")[::up]
y_d, _ = add_noise(y_d0, 20.0, np.random.default_rng(1))
tk = t[keep] - t[keep][0]
model_d = hdpbsid.identify(
    tk, u[keep], y_d[keep], order=4, method="dt", refine="pem", delay="auto", max_delay=0.3,
    delay_hold="bandlimited",
)  # fmt: skip
err_d = eigenvalue_errors(model_d.eigenvalues, truth.eigenvalues)
print(f"estimated dead time {model_d.delay[0]:.3f} s (true {TAU}); largest eigenvalue error "
      f"{100 * err_d.max():.3f} % (without the delay: {100 * err_t.max():.3f} %)")  # fmt: skip
assert abs(model_d.delay[0] - TAU) <= 0.01 + 1e-9  # one sample, the estimate's resolution

# %%
frf_d = frequency.frf_periodic(u, y_d, dt, n, skip=2)
save(frequency.plot_frf(frf_d, model_d), "delay_band")
