"""Probability of false alarm, effective number of pulses and probability of detection.

Seed sections 6.2-6.4, equations [68]-[83] and Tables I-III.

Two methods for P_d, chosen by name (SPEC §4 item 23):

``"exact"``
    The exact probability that the non-coherent sum of ``N`` square-law detected pulses
    exceeds the threshold set for ``P_fa``, for the Swerling 0-4 targets (DiFranco & Rubin,
    *Radar Detection*, 1968, ch. 10; Meyer & Mayer, *Radar Target Detection*, 1973, ch. 3).
    With the noise power per pulse as unit, the noise-only sum is Gamma(N, 1), so the
    threshold is ``T = Q⁻¹(N, P_fa)`` (inverse regularized upper incomplete gamma).  The
    targets of Table III are the chi-square family: the total signal energy over the dwell
    is Gamma-distributed with K degrees of freedom (K = 1, N, 2, 2N for Swerling 1-4, K → ∞
    for Swerling 0).  No Monte Carlo.

``"seed"``
    The seed's Blake-style approximation [78]-[83] with the equivalent number of pulses of
    Table I, the detector efficiency of Table II and the fluctuation loss [83] with K of
    Table III, solved for P_d by iteration on the seed's required S/I.

Choices where the seed is silent or wrong
-----------------------------------------
* **Non-integer N (exact method).**  N_e of [74]-[77] is not an integer.  The exact P_d is
  continued to real N by the chi-square family itself: the noise-only sum is Gamma(N, 1) and
  the detected sum, given the dwell's signal energy X, a non-central gamma of order N (the
  standard continuation, Shnidman 1999).  The Swerling 0-3 closed forms below hold unchanged
  for real N (checked against the term-by-term family sum to 1e-13).  The Swerling 4 form is
  a binomial sum over N + 1 terms and has no real-N counterpart: for non-integer N the mean
  over X ~ Gamma(2N, S/2) of the non-central χ² tail is taken by a
  :data:`SW4_QUADRATURE_NODES`-point Gauss-Hermite rule in the normal quantile of X
  (2e-8 relative against the family sum; monotone in S/I since every node is).  A linear
  interpolation of P_d between ⌊N⌋ and ⌈N⌉, the earlier choice, was up to 1.4 dB off this
  continuation (between N = 1 and 2 at P_d = 0.9, where the lower-N curve dominates).
* **Outside the seed's validity (SPEC §4 item 15).**  [78]-[83] are stated for
  0.1 ≤ P_d ≤ 0.9 and 1e-12 ≤ P_fa ≤ 1e-4.  Blake's g_fa [80] and g_d [81] are fits of the
  normal quantiles Φ⁻¹(1-P_fa) and Φ⁻¹(P_d) on exactly those ranges; outside them each is
  continued by the exact normal quantile, shifted to join the fit continuously at the edge
  of its range.  X0 [79] is floored at 0 (its root g_fa + g_d = 0 is P_d ≈ P_fa, the
  noise-only limit), and the returned P_d is never below P_fa.  The result is defined for
  0 < P_fa ≤ 0.1 and every S/I, finite, in [0, 1], continuous where the formulas are and
  monotone non-decreasing in S/I by construction (bisection with fixed midpoints, see
  :func:`probability_of_detection`); P_d → P_fa as S/I → 0 and P_d → 1 as S/I → ∞.
* **Table I "signal variation".**  In Blake (1980, p. 68) "Gaussian" and "constant" are the
  envelope of the pulse train across the dwell (Gaussian antenna beam vs a rectangular
  train), not the target's fluctuation, which [83] already carries.  It is the keyword
  ``signal_variation`` (default ``"constant"``, the pulse train the exact method and the
  per-pulse S/I at beam centre assume).  Taking "Gaussian" for the fluctuating cases would
  count the fluctuation twice (3 dB too pessimistic for Swerling 1, one pulse).
* **S/I in dB** is clipped to ±:data:`SNR_DB_LIMIT` (beyond it P_d is saturated at P_fa or
  1 to double precision); -inf dB is S/I = 0 and gives P_d = P_fa.  NaN raises.
* **[80] log and [83] sign.**  The "log" of [80] is log10 (Blake 1980): the fit then
  follows Φ⁻¹(1 - P_fa) within 2 % on 1e-12..1e-4, with ln it would miss by up to 65 %.
  The seed says the fluctuation loss "is subtracted from D_0"; L_f of [83] is ≥ 1 in the
  validity range (8.7 dB for Swerling 1 at P_d 0.9, P_fa 1e-6), so the required S/I is
  D_0 L_f (D_0 plus L_f in dB), equivalently L_f subtracted from the available S/I;
  subtracting it from D_0 would make a fluctuating target easier to detect than a steady
  one.
* **[74] units (erratum).**  The seed prints N_n' = [1 + 5 σ_s' θ_b / (6 λ f_rot)] with θ_b
  in degrees and f_rot in rpm: the "6" converts rpm to degrees per second, so that
  θ_b / (6 f_rot) is the time on target t_ot in seconds.  With SI units the coefficient is
  5 alone: N_n' = ⌊1 + 5 σ_s' t_ot / λ⌋, t_ot = θ_b / ω_rot.  This is Nathanson's
  N = 1 + 2√(2π) σ_v t_ot / λ (2√(2π) ≈ 5), and only with 5 do the seed's two branches meet
  at its own switch σ_s'/(λ f_r) = 0.2 ≈ 1/(2√(2π)), where 1 + 5 σ_s' t_ot/λ = 1 + N_n.
  [ ] is the integer part in both branches ("a number between 1 and N_n"), so the
  correlated branch is capped at ⌊N_n⌋ and N_n' is continuous at the switch.
* **N_rc ≤ 0 or P_fa ∉ (0, 1) in [68]-[72] (SPEC §4 item 14)** raise ``ValueError``.
* **N_e < 1 (SPEC §4 item 16)**: :func:`effective_pulses` never returns less than 1.
* **[68]-[72] against [90] (erratum, issue 23 item 5a).**  The seed names t_fa "the mean
  time between false alarms" but sets P_fa = 0.69/n' (Marcum's false-alarm time: the
  probability of at least one false alarm in t_fa is 1/2, i.e. 0.69 false alarms per t_fa
  on average) over n_0 = N_ch N_rc decisions per sweep, while its generator [90] draws
  N_cells P_fa per scan over N_cells = 2π R_inst/(θ_b C_R) cells, without N_ch and with
  R_inst in place of the N_rc gates of an interpulse period.  The emitted rate was
  0.69 R_inst/(N_ch N_rc C_R) / t_fa: 0.46-1.15 / t_fa on the shipped radars.  Here t_fa is
  what the user says it is, the mean time between the false alarms the radar *reports*:
  P_fa = 1/n' (:data:`FALSE_ALARMS_PER_T_FA`), and n_0 = N_ch N_rep counts the decisions
  that can be reported, N_rep = min(N_rc, R_inst/C_R) range gates per sweep
  (:func:`reported_range_cells`: the gates of one interpulse period that fall inside the
  instrumented range; a radar cannot decide in more gates than its interpulse period
  holds, nor report beyond R_inst).
  :func:`shipradar.sensors.false_alarms.noise_false_alarms_per_scan` draws η = N_ch N_rep (2π/θ_b)
  P_fa per revolution, so η = t_scan/t_fa exactly.  The seed's letter stays available as
  ``t_fa_definition="median"`` (P_fa = 0.69/n').
* **MTI cascaded with a bank, [76] against [77] (erratum, issue 23 item 5b).**  The seed
  gives [76] for an MTI and [77] for a bank and is silent on the cascade; taking [77] alone
  ignores the canceller.  A cascade is a sliding canceller (an output per pulse after its
  N_pc fill pulses, Trunk's correlated sequence of [76]) whose outputs the bank integrates
  in disjoint blocks of N_b = N_c - N_pc taps ([77]'s batches), so the non-coherent
  integrator receives (N_n - N_pc)/N_b outputs, correlated only through the canceller's
  N_pc-pulse memory at the block edges: see :func:`effective_pulses`.
"""

from __future__ import annotations

import enum

import numpy as np
from numpy.typing import ArrayLike, NDArray
from scipy import special

from shipradar.sensors.geometry import (
    pulses_per_beam,
    range_cells,
    reported_range_cells,
    sweep_time,
)

# array types of the private helpers' signatures
_Floats = NDArray[np.float64]
_Ints = NDArray[np.int64]

# ----------------------------------------------------------------------------- constants
#: Number of decision channels per range cell N_ch of [71] (seed 6.2: 2 for any radar).
N_CHANNELS = 2
#: False alarms per t_fa on average: 1 for t_fa the *mean* time between false alarms (the
#: seed's own definition of t_fa and the user's), against the seed's 0.69 of [68]
#: (Marcum's median time; see the module notes).
FALSE_ALARMS_PER_T_FA = 1.0
#: The readings of t_fa in :func:`pfa_from_false_alarm_time`: "mean" (P_fa = 1/n', the
#: default) or "median" (the seed's letter, P_fa = 0.69/n').
T_FA_DEFINITIONS = ("mean", "median")
#: The seed's 0.69 ≈ ln 2 of [68] and of the Bernoulli limit of [92]: P_fa = 0.69/n' makes
#: the probability of at least one false alarm in t_fa equal to 1/2 (Nathanson 1991, p. 82).
LN2_SEED = 0.69
#: [74]: the clutter spectrum decorrelates every pulse when σ_s'/(λ f_r) ≥ 0.2.
DECORRELATED_SPREAD_RATIO = 0.2
#: [74]: N_n' = 1 + 5 σ_s' t_ot / λ with t_ot = θ_b/ω_rot in seconds (the seed's "6" turns its
#: θ_b [deg] / f_rot [rpm] into seconds; it is not part of the coefficient).
CLUTTER_SAMPLES_FACTOR = 5.0
#: [76]: N_e = N_e' / (1 + 0.53 N_pc) (fit of Trunk's results, seed Ref. 25).
MTI_PULSE_FACTOR = 0.53



class Interference(enum.IntEnum):
    """The dominant interference of a decision [66]-[67], the ``interference`` code of a plot
    (its name, lower case, in ``meta.interference_codes``)."""

    NOISE = 0
    CLUTTER = 1
    JAMMING = 2


#: The names of the :class:`Interference` codes, by code (``meta.interference_codes``).
INTERFERENCE_NAMES = tuple(code.name.lower() for code in Interference)

#: Stated validity of the seed's approximation [78]-[83] (seed 6.4).
SEED_PD_RANGE = (0.1, 0.9)
SEED_PFA_RANGE = (1e-12, 1e-4)
#: Largest P_fa the seed method accepts (g_fa stays positive; the exact method takes (0, 1)).
SEED_PFA_MAX = 0.1
#: Seed 6.4: the iterative solution must match the input S/I to 1 %.
SEED_SNR_TOLERANCE = 0.01
#: [80]: g_fa = 2.36 sqrt(-log10 P_fa) - 1.02 (Blake 1980; a fit of Φ⁻¹(1 - P_fa)).
G_FA_SLOPE = 2.36
G_FA_OFFSET = 1.02
#: [81]-[82]: g_d = 1.231 t / sqrt(1 - t²), t = 0.9 (2 P_d - 1).
G_D_SLOPE = 1.231
G_D_T_SCALE = 0.9

#: Table I (Blake 1980, p. 68): H_n / N_e by (signal variation, integrator).  The constant
#: double-loop entry is 1.3347 N_e exp(-3/N_e) (see :func:`equivalent_pulses`).
TABLE_I = {
    ("gaussian", "non_uniform"): 0.626,
    ("gaussian", "uniform"): 0.558,
    ("gaussian", "single_loop"): 0.561,
    ("gaussian", "double_loop"): 0.586,
    ("constant", "non_uniform"): 1.0,
    ("constant", "uniform"): 1.0,
    ("constant", "single_loop"): 1.4299,
    ("constant", "double_loop"): 1.3347,
}
DOUBLE_LOOP_DECAY = 3.0
INTEGRATORS = ("non_uniform", "uniform", "single_loop", "double_loop")
SIGNAL_VARIATIONS = ("constant", "gaussian")
#: Table II: asymptotic efficiency ζ of the envelope detector.
TABLE_II = {"square": 1.0, "linear": 0.915, "log": 0.608}
SWERLING_CASES = (0, 1, 2, 3, 4)

#: S/I beyond ±this [dB] is clipped (P_d is then P_fa or 1 to double precision).
SNR_DB_LIMIT = 300.0
#: Search interval of :func:`required_snr_db` (exact method) [dB].
REQUIRED_SNR_DB_BRACKET = (-200.0, 400.0)
_REQUIRED_SNR_ITERATIONS = 52
#: Seed method: P_d is searched as z = Φ⁻¹(P_d) in [-Z, Z] (Φ(9) = 1 to double precision).
_SEED_Z_MAX = 9.0
#: Bisection steps of the seed method: bracket 18/2^10 in z, then log-linear interpolation;
#: the S/I is met to < 1e-4 relative (measured), against the seed's 1 % (6.4).
_SEED_ITERATIONS = 10
#: gammainc values below this are recomputed by series (log domain) [-].
_TINY = 1e-250
#: Swerling 4 binomial sum: half-width in standard deviations and extra terms.
_SW4_SIGMAS = 12.0
_SW4_EXTRA = 40.0
_SW4_CHUNK = 2_000_000
#: Swerling 4 at non-integer N: Gauss-Hermite nodes in the normal quantile of the dwell's
#: signal energy (reach Φ(±9.5), i.e. miss probabilities down to ~1e-21).
SW4_QUADRATURE_NODES = 48
#: A steady return this many noise standard deviations above the threshold is detected
#: (miss probability < Φ(-40)); keeps ``ncx2.sf`` away from non-centralities (> ~1e19) where
#: it returns NaN.
_SURE_SIGMAS = 40.0


# ----------------------------------------------------------------------------- [68]-[73]
def pfa_from_false_alarm_time(
    t_fa_s: ArrayLike,
    beamwidth_rad: ArrayLike,
    scan_period_s: ArrayLike,
    prf_hz: ArrayLike,
    pulse_width_s: ArrayLike,
    n_channels: ArrayLike = N_CHANNELS,
    *,
    instrumented_range_m: ArrayLike | None = None,
    t_fa_definition: str = "mean",
) -> NDArray[np.float64]:
    """Probability of false alarm from the mean time between false alarms, seed [68]-[72].

    P_fa = k / n',  n' = n_0 t_fa / t_swp,  t_swp = θ_b t_scan / (2π),  n_0 = N_ch N_rep,

    with k = 1 (t_fa the mean time between false alarms; the seed's [68] has k = 0.69) and
    N_rep = min(N_rc, R_inst/C_R) the reported gates (:func:`reported_range_cells`; the
    seed's [71] has N_rc).  Erratum, issue 23 item 5a (module notes): with both, the noise
    false alarms of :func:`shipradar.sensors.false_alarms.noise_false_alarms_per_scan` come at
    exactly 1/t_fa.

    Parameters
    ----------
    t_fa_s : array_like
        Mean time between false alarms t_fa [s], > 0.
    beamwidth_rad : array_like
        Horizontal 3 dB beamwidth θ_b [rad].
    scan_period_s : array_like
        Time of one revolution t_scan [s].
    prf_hz : array_like
        Pulse repetition frequency f_r [Hz].
    pulse_width_s : array_like
        Compressed pulse length τ' [s].
    n_channels : array_like, optional
        Decision channels per range cell N_ch [-] (seed: :data:`N_CHANNELS` = 2).
    instrumented_range_m : array_like, optional
        R_inst [m]: decisions in gates beyond it are not reported and do not count.  None:
        every gate of the interpulse period (N_rc, the seed's n_0) -- the same for a radar
        whose R_inst is at least its unambiguous range (every shipped radar).
    t_fa_definition : {"mean", "median"}, optional
        ``"mean"``: one false alarm per t_fa on average, P_fa = 1/n'.  ``"median"``: the
        seed's letter, P_fa = 0.69/n' (probability 1/2 of at least one false alarm in t_fa;
        Marcum's false-alarm time), 0.69 false alarms per t_fa.

    Returns
    -------
    ndarray
        P_fa [-], in (0, 1).

    Raises
    ------
    ValueError
        If N_rc ≤ 0 (f_r τ' ≥ 1/2), an input is not positive, ``t_fa_definition`` is
        unknown, or the result is not in (0, 1) (n' ≤ k: t_fa shorter than about one
        sweep; SPEC §4 item 14).
    """
    if t_fa_definition not in T_FA_DEFINITIONS:
        raise ValueError(f"pfa_from_false_alarm_time: t_fa_definition must be one of "
                         f"{T_FA_DEFINITIONS}, got {t_fa_definition!r}")
    t_fa = np.asarray(t_fa_s, dtype=np.float64)
    n_ch = np.asarray(n_channels, dtype=np.float64)
    _require_positive("t_fa_s", t_fa)
    _require_positive("n_channels", n_ch)
    t_swp = sweep_time(beamwidth_rad, scan_period_s)
    n_0 = n_ch * reported_range_cells(prf_hz, pulse_width_s, instrumented_range_m)
    n_prime = n_0 * t_fa / t_swp
    k = FALSE_ALARMS_PER_T_FA if t_fa_definition == "mean" else LN2_SEED
    pfa = k / n_prime
    if np.any(~((pfa > 0) & (pfa < 1))):
        bad = np.asarray(pfa)[~((pfa > 0) & (pfa < 1))].flat[0]
        raise ValueError(
            f"pfa_from_false_alarm_time: P_fa = {k:g} / n' must be in (0, 1), got {bad:g} "
            "(false alarm time too short for the number of opportunities n')"
        )
    return pfa


# ----------------------------------------------------------------------------- [74]-[77]
# long: 72 of its lines are the docstring; the code is [73]-[77] and the MTI-bank terms, one chain
def effective_pulses(
    n_pulses: ArrayLike,
    *,
    clutter_dominated: ArrayLike = False,
    clutter_velocity_spread_mps: ArrayLike = 0.0,
    wavelength_m: ArrayLike = 1.0,
    prf_hz: ArrayLike = 1.0,
    beamwidth_rad: ArrayLike = 1.0,
    rotation_rate_rad_s: ArrayLike = 1.0,
    pulses_per_frequency: ArrayLike = np.inf,
    mti_order: ArrayLike = 0,
    n_coherent: ArrayLike = 1,
) -> NDArray[np.float64]:
    """Effective number of pulses for non-coherent integration N_e, seed [73]-[77].

    Noise or jamming dominated (``clutter_dominated`` False): N_e = N_n [73] (the seed
    assumes the clutter filters are switched off).  Clutter dominated:

    * N_n' = ⌊N_n⌋ if σ_s'/(λ f_r) ≥ 0.2, else ⌊1 + 5 σ_s' t_ot / λ⌋ with the time on
      target t_ot = θ_b/ω_rot [s] [74] (the seed's "6" is its rpm-to-degrees/s conversion,
      see the module notes), capped at ⌊N_n⌋;
    * N_e' = max(N_n / N_fc, N_n') with frequency agility [75];
    * with a filter bank or coherent integrator alone (``n_coherent`` N_c > 1, no MTI):
      N_e = N_n / N_c [77];
    * with an N_pc-order MTI alone: N_e = N_e' / (1 + 0.53 N_pc) [76];
    * with an N_pc-order MTI feeding a bank, the cascade's N_c pulses being the canceller's
      N_pc + 1 convolved with the bank's N_b = N_c - N_pc taps ([61], the convention of
      the I_F table): N_e = (N_n - N_pc) / (N_b (1 + 0.53 N_pc / N_b²));
    * otherwise N_e'.

    The cascade (erratum, issue 23 item 5b; the seed gives no rule and the code used to
    apply [77] alone, as if the canceller were not there).  The canceller slides along the
    dwell: after its N_pc fill pulses it gives one output per pulse, N_n - N_pc in all,
    adjacent ones correlated (Trunk, seed Ref. 25: the loss 1 + 0.53 N_pc of [76]).  The
    bank integrates these outputs coherently in disjoint blocks of N_b (the batches of
    [77]; Nathanson 1991, ch. 9; the MTD's canceller-then-DFT, Skolnik 2001, §3.6), so
    (N_n - N_pc)/N_b outputs reach the non-coherent integrator.  Two adjacent blocks share
    input pulses only through the canceller's N_pc-pulse memory, so the correlation of [76]
    falls with the block length; 1 + 0.53 N_pc / N_b² keeps [76]'s value at N_b = 1 and
    tends to 1 as N_b grows, like the exact factor 1 + Σ_{m≠0} |ρ(m)|² of the cascade's
    own weights at a stride of N_b pulses, averaged over the bank's filters (1.000-1.12
    for Hann or Hamming windows at N_b ≥ 3 and N_pc ≤ 6, where the interpolation gives
    1.002-1.35; within 25 % of it, checked in ``tests/test_detection.py``).  Limits:
    N_pc = 0 gives [77]; N_b = 1 (a one-tap bank: the canceller alone) gives [76] applied
    to the canceller's N_n - N_pc outputs, i.e. [76] with decorrelated pulses (N_e' = N_n),
    the premise under which [76] is stated, less the N_pc fill pulses that its long-train
    fit ignores.  For the shipped Giraffe
    ``mti_bank`` (N_n = 25, N_pc = 1, N_c = 8): 3.392 instead of [77]'s 3.125 (the old
    value read N_c as a batch that restarts the canceller every N_c pulses).  Like [77],
    this counts the processor's outputs and not the clutter's own independent samples
    N_e' of [74]-[75]; the seed does the same for a bank.

    The result is never below 1 (SPEC §4 item 16).

    Parameters
    ----------
    n_pulses : array_like
        Pulses per beam sweep N_n of [73] [-].
    clutter_dominated : array_like of bool
        Whether clutter is the dominant interference (per element).
    clutter_velocity_spread_mps : array_like
        Standard deviation of the clutter velocity spectrum σ_s' [m/s], ≥ 0.
    wavelength_m : array_like
        Radar wavelength λ [m].
    prf_hz : array_like
        Pulse repetition frequency f_r [Hz].
    beamwidth_rad : array_like
        Horizontal 3 dB beamwidth θ_b [rad].
    rotation_rate_rad_s : array_like
        Antenna rotation rate ω_rot [rad/s]; θ_b/ω_rot is the time on target.
    pulses_per_frequency : array_like
        Pulses before a frequency change N_fc [-] (1 = pulse-to-pulse agility; default inf:
        a fixed frequency, N_n / N_fc = 0).
    mti_order : array_like
        Order N_pc of the MTI canceller [-] (0: no MTI; it uses N_pc + 1 pulses).
    n_coherent : array_like
        Pulses integrated coherently N_c [-] (1: none).  Behind an MTI it counts the whole
        cascade (the canceller's fill pulses and the bank's taps, > N_pc), as the
        scenario's ``processor.n_coherent`` of an ``mti_bank`` does.

    Returns
    -------
    ndarray
        N_e [-], ≥ 1, broadcast over all arguments.
    """
    n_n = np.asarray(n_pulses, dtype=np.float64)
    dominated = np.asarray(clutter_dominated, dtype=bool)
    sigma = np.asarray(clutter_velocity_spread_mps, dtype=np.float64)
    lam = np.asarray(wavelength_m, dtype=np.float64)
    f_r = np.asarray(prf_hz, dtype=np.float64)
    theta = np.asarray(beamwidth_rad, dtype=np.float64)
    omega = np.asarray(rotation_rate_rad_s, dtype=np.float64)
    n_fc = np.asarray(pulses_per_frequency, dtype=np.float64)
    n_pc = np.asarray(mti_order, dtype=np.float64)
    n_c = np.asarray(n_coherent, dtype=np.float64)
    for name, arr in (
        ("wavelength_m", lam),
        ("prf_hz", f_r),
        ("beamwidth_rad", theta),
        ("rotation_rate_rad_s", omega),
        ("n_coherent", n_c),
    ):
        _require_positive(name, arr)
    if np.any(~(n_fc > 0)):
        raise ValueError("effective_pulses: pulses_per_frequency must be > 0 (inf: no agility)")
    if np.any(~(n_n >= 0)) or np.any(~(sigma >= 0)) or np.any(~(n_pc >= 0)):
        raise ValueError(
            "effective_pulses: n_pulses, clutter_velocity_spread_mps and mti_order must be >= 0"
        )
    decorrelated = sigma / (lam * f_r) >= DECORRELATED_SPREAD_RATIO
    n_clutter = np.where(
        decorrelated,
        np.floor(n_n),
        np.floor(1.0 + CLUTTER_SAMPLES_FACTOR * sigma * theta / (lam * omega)),
    )
    n_clutter = np.minimum(n_clutter, np.floor(n_n))  # "a number between 1 and N_n"
    n_e_prime = np.maximum(n_n / n_fc, n_clutter)  # [75]
    bank = n_c > 1.0
    if np.any(bank & ~(n_c > n_pc)):
        raise ValueError(
            "effective_pulses: an MTI feeding a bank needs n_coherent > mti_order (the bank's "
            "taps are n_coherent - mti_order)"
        )
    # the cascade (N_pc = 0: [77]); its block correlation, see the docstring
    n_taps = np.where(bank, n_c - n_pc, 1.0)
    n_e_bank = (n_n - n_pc) / (n_taps * (1.0 + MTI_PULSE_FACTOR * n_pc / n_taps**2))
    n_e_clutter = np.where(bank, n_e_bank, n_e_prime / (1.0 + MTI_PULSE_FACTOR * n_pc))
    return np.maximum(np.where(dominated, n_e_clutter, n_n), 1.0)


# ----------------------------------------------------------------------------- P_d: public
def probability_of_detection(
    snr_db: ArrayLike,
    pfa: ArrayLike,
    n_pulses: ArrayLike,
    swerling: ArrayLike,
    method: str = "exact",
    *,
    integrator: str = "uniform",
    detector: str = "square",
    signal_variation: str = "constant",
) -> NDArray[np.float64] | float:
    """Probability of detection of a Swerling 0-4 target, seed [78]-[83] or exact.

    Parameters
    ----------
    snr_db : array_like
        Per-pulse signal-to-interference ratio S/I [dB]; -inf allowed (S/I = 0); clipped
        to ±:data:`SNR_DB_LIMIT`.
    pfa : array_like
        Probability of false alarm [-]: in (0, 1) for ``"exact"``, (0, 0.1] for ``"seed"``.
    n_pulses : array_like
        Pulses integrated non-coherently, N_e [-], real, ≥ 1 (non-integer: see the module
        notes).
    swerling : array_like of int
        Swerling case, 0 (steady) to 4.
    method : {"exact", "seed"}
        ``"exact"``: square-law detector, uniform non-coherent integration, exact Swerling
        0-4 (DiFranco & Rubin 1968; Meyer & Mayer 1973).  ``"seed"``: [78]-[83] with Tables
        I-III, solved to better than the seed's 1 % of S/I (measured: 1e-4).
    integrator : {"non_uniform", "uniform", "single_loop", "double_loop"}
        Table I integrator (``"seed"`` only; ``"exact"`` requires ``"uniform"``).
    detector : {"square", "linear", "log"}
        Table II envelope detector (``"seed"`` only; ``"exact"`` requires ``"square"``).
    signal_variation : {"constant", "gaussian"}
        Table I pulse-train envelope (``"seed"`` only), see the module notes.

    Returns
    -------
    ndarray or float
        P_d [-], finite, in [P_fa, 1] and non-decreasing in S/I (the seed method exactly,
        by construction; the exact method up to rounding, below 1e-14); a float for scalar
        inputs.

    Notes
    -----
    Exact closed forms used (S per-pulse S/I, T = Q⁻¹(N, P_fa), P(a, x) and Q(a, x) the
    regularized incomplete gammas):

    * Swerling 0: P_d = Q_M(√(2NS), √(2T)) as the non-central χ² survival function with 2N
      degrees of freedom and non-centrality 2NS.
    * Swerling 1: P_d = P_fa + c^{1-N} e^{-(1-c)T} P(N, cT), c = NS/(1+NS) (an algebraic
      rearrangement of DiFranco & Rubin eq. 10-77 without the Q(N-1, ·) term).
    * Swerling 2: P_d = Q(N, T/(1+S)).
    * Swerling 3: P_d = P_fa + e^{-T/β} c^{1-N} [(2-c) P(N, cT) + D(N, cT)/β],
      β = 1 + NS/2, c = 1 - 1/β, D(N, x) = x P(N, x) - N P(N+1, x) ≥ 0.
    * Swerling 4: P_d = Σ_m Bin(m; N, r) Q(N+m, T/β), β = 1 + S/2, r = 1 - 1/β.

    The forms hold for real N (Swerling 4 at non-integer N: see the module notes).  A steady
    target more than 40 standard deviations above the threshold (√(2NS) - √(2T) > 40) has
    P_d = 1: this also keeps ``ncx2.sf`` away from the non-centralities (~1e19) where it
    returns NaN.  Small terms are formed in the log
    domain (series for P(N, x) where it underflows), so the results stay accurate (1e-9
    against the term-by-term chi-square family sum) and warning-free from S/I = -50 to
    +100 dB, P_fa = 1e-15 to 0.1 and N = 1 to 10⁴.

    The seed method solves D_0(P_d) L_f(P_d) = S/I for P_d by bisection on z = Φ⁻¹(P_d)
    with fixed midpoints (hence monotone in S/I whatever the formula does), followed by a
    log-linear interpolation inside the last bracket.
    """
    snr, pfa_a, n_a, sw = _broadcast_inputs(snr_db, pfa, n_pulses, swerling, method)
    if method == "exact":
        _require_exact_receiver(integrator, detector)
        out = _pd_exact(snr, pfa_a, n_a, sw)
    else:
        h_n, zeta = _seed_parameters(n_a, integrator, detector, signal_variation)
        out = _pd_seed(snr, pfa_a, n_a, sw, h_n, zeta)
    return out if out.ndim else float(out)


def required_snr_db(
    pd: ArrayLike,
    pfa: ArrayLike,
    n_pulses: ArrayLike,
    swerling: ArrayLike,
    method: str = "exact",
    *,
    integrator: str = "uniform",
    detector: str = "square",
    signal_variation: str = "constant",
) -> NDArray[np.float64] | float:
    """Per-pulse S/I needed for a probability of detection: inverse of
    :func:`probability_of_detection`.

    Parameters
    ----------
    pd : array_like
        Wanted probability of detection [-], in [0, 1].
    pfa, n_pulses, swerling, method, integrator, detector, signal_variation
        As in :func:`probability_of_detection`.

    Returns
    -------
    ndarray or float
        Required per-pulse S/I [dB].  -inf where P_d ≤ P_fa (no signal is needed), +inf
        where P_d = 1.  ``"exact"``: vectorized bisection in dB on
        :data:`REQUIRED_SNR_DB_BRACKET` to ~1e-13 dB (results beyond the bracket are
        clipped to it).  ``"seed"``: the closed form D_0 L_f of [78]-[83] (Blake's
        procedure), with the extensions of the module notes outside its validity.
    """
    pd_a, pfa_a, n_a, sw = _broadcast_inputs(0.0, pfa, n_pulses, swerling, method, pd=pd)
    if method == "exact":
        _require_exact_receiver(integrator, detector)
        out = _required_exact(pd_a, pfa_a, n_a, sw)
    else:
        h_n, zeta = _seed_parameters(n_a, integrator, detector, signal_variation)
        z = special.ndtri(pd_a)  # ∓inf at P_d = 0 or 1, handled below
        lo = z <= -_SEED_Z_MAX
        hi = z >= _SEED_Z_MAX
        z_c = np.clip(z, -_SEED_Z_MAX, _SEED_Z_MAX)
        req = _seed_required_snr(z_c, g_fa(pfa_a), 1.0 / fluctuation_k(sw, n_a), h_n, zeta)
        out = np.full(req.shape, -np.inf)
        pos = req > 0
        out[pos] = 10.0 * np.log10(req[pos])
        out = np.where(hi, np.inf, np.where(lo | (pd_a <= pfa_a), -np.inf, out))
    return out if out.ndim else float(out)


def equivalent_pulses(
    n_pulses: ArrayLike, integrator: str = "uniform", signal_variation: str = "constant"
) -> NDArray[np.float64]:
    """Equivalent number of pulses integrated H_n, seed Table I (Blake 1980, p. 68).

    Parameters
    ----------
    n_pulses : array_like
        Pulses integrated N_e [-], ≥ 1.
    integrator : {"non_uniform", "uniform", "single_loop", "double_loop"}
        Integrator weighting.
    signal_variation : {"constant", "gaussian"}
        Envelope of the pulse train (Gaussian beam or constant).

    Returns
    -------
    ndarray
        H_n [-]; the constant double-loop entry 1.3347 N_e exp(-3/N_e) is small for N_e of a
        few pulses (0.066 at N_e = 1), as tabulated.
    """
    if integrator not in INTEGRATORS:
        raise ValueError(f"integrator must be one of {INTEGRATORS}, got {integrator!r}")
    if signal_variation not in SIGNAL_VARIATIONS:
        raise ValueError(
            f"signal_variation must be one of {SIGNAL_VARIATIONS}, got {signal_variation!r}"
        )
    n = np.asarray(n_pulses, dtype=np.float64)
    h = TABLE_I[(signal_variation, integrator)] * n
    if (signal_variation, integrator) == ("constant", "double_loop"):
        h = h * np.exp(-DOUBLE_LOOP_DECAY / n)
    return h


def fluctuation_k(swerling: ArrayLike, n_pulses: ArrayLike) -> NDArray[np.float64]:
    """Degrees of freedom K of the chi-square target family, seed Table III.

    Parameters
    ----------
    swerling : array_like of int
        Swerling case 0-4.
    n_pulses : array_like
        Pulses integrated N_e [-].

    Returns
    -------
    ndarray
        K [-]: inf (steady), 1, N_e, 2, 2 N_e for Swerling 0-4.
    """
    sw = np.asarray(swerling)
    n = np.asarray(n_pulses, dtype=np.float64)
    return np.select(
        [sw == 0, sw == 1, sw == 2, sw == 3], [np.inf, 1.0, n, 2.0], default=2.0 * n
    ).astype(np.float64)


# ----------------------------------------------------------------------------- validation
def _require_positive(name: str, arr: np.ndarray) -> None:
    if np.any(~(arr > 0)) or np.any(~np.isfinite(arr)):
        bad = arr[~((arr > 0) & np.isfinite(arr))].flat[0] if arr.ndim else float(arr)
        raise ValueError(f"{name} must be finite and > 0, got {bad:g}")


def _require_exact_receiver(integrator: str, detector: str) -> None:
    if integrator != "uniform" or detector != "square":
        raise ValueError(
            "method='exact' models a square-law detector with uniform non-coherent "
            f"integration; got integrator={integrator!r}, detector={detector!r} "
            "(use method='seed' for Tables I-II)"
        )


def _broadcast_inputs(
    snr_db: ArrayLike, pfa: ArrayLike, n_pulses: ArrayLike, swerling: ArrayLike, method: str,
    pd: ArrayLike | None = None,
) -> tuple[NDArray[np.float64], NDArray[np.float64], NDArray[np.float64], NDArray[np.int64]]:
    if method not in ("exact", "seed"):
        raise ValueError(f"method must be 'exact' or 'seed', got {method!r}")
    first = snr_db if pd is None else pd
    a, p, n, s = np.broadcast_arrays(
        np.asarray(first, dtype=np.float64),
        np.asarray(pfa, dtype=np.float64),
        np.asarray(n_pulses, dtype=np.float64),
        np.asarray(swerling),
    )
    if np.any(np.isnan(a)):
        raise ValueError(f"{'snr_db' if pd is None else 'pd'} must not be NaN")
    if pd is not None and np.any((a < 0) | (a > 1)):
        raise ValueError(f"pd must be in [0, 1], got {a[(a < 0) | (a > 1)].flat[0]:g}")
    pfa_max = 1.0 if method == "exact" else SEED_PFA_MAX
    if np.any(~((p > 0) & (p < 1) & (p <= pfa_max))):
        bad = p[~((p > 0) & (p < 1) & (p <= pfa_max))].flat[0]
        interval = "(0, 1)" if method == "exact" else f"(0, {SEED_PFA_MAX}]"
        raise ValueError(f"pfa must be in {interval} for method={method!r}, got {bad:g}")
    if np.any(~((n >= 1) & np.isfinite(n))):
        raise ValueError(f"n_pulses must be finite and >= 1, got {n[~(n >= 1)].flat[0]:g}")
    if not np.all(np.isin(s, SWERLING_CASES)):
        bad = s[~np.isin(s, SWERLING_CASES)].flat[0]
        raise ValueError(f"swerling must be one of {SWERLING_CASES}, got {bad}")
    if pd is None:
        a = np.clip(a, -SNR_DB_LIMIT, SNR_DB_LIMIT)
    return a.copy(), p.copy(), n.copy(), s.astype(np.int64)


# ----------------------------------------------------------------------------- exact
def _log_poisson(a: NDArray[np.float64], x: NDArray[np.float64]) -> NDArray[np.float64]:
    """ln(x^a e^{-x} / Γ(a+1)), x > 0."""
    log_gamma: NDArray[np.float64] = special.gammaln(a + 1.0)  # scipy is untyped
    return a * np.log(x) - x - log_gamma


def _series(a: np.ndarray, x: np.ndarray, weighted: bool) -> np.ndarray:
    """Σ_k w_k x^k / ((a+1)(a+2)…(a+k+j)) for x < a + 1, positive terms only.

    ``weighted`` False: M(1, a+1, x) = Σ_k x^k/(a+1)_k (so P(a, x) = pois(a; x) M).
    ``weighted`` True:  Σ_k (k+1) x^k/(a+1)_{k+1} (so D(a, x) = pois(a; x) x Σ).
    """
    total = np.zeros(a.shape)
    if weighted:
        term = 1.0 / (a + 1.0)
        k = 0
        while True:
            total = total + (k + 1) * term
            k += 1
            term = term * x / (a + k + 1.0)
            if np.all((k + 1) * term <= 1e-17 * total) or k > 100_000:
                return total
    term = np.ones(a.shape)
    k = 0
    while True:
        total = total + term
        k += 1
        term = term * x / (a + k)
        if np.all(term <= 1e-17 * total) or k > 100_000:
            return total


def _log_gammainc(a: np.ndarray, x: np.ndarray) -> np.ndarray:
    """ln P(a, x) for a ≥ 1, x > 0, accurate where P underflows (then x < a)."""
    p = special.gammainc(a, x)
    small = p < _TINY
    out = np.log(np.where(small, 1.0, p))
    if np.any(small):
        a_s, x_s = a[small], x[small]
        out[small] = _log_poisson(a_s, x_s) + np.log(_series(a_s, x_s, weighted=False))
    return out


def _log_d(a: np.ndarray, x: np.ndarray) -> np.ndarray:
    """ln D(a, x), D = x P(a, x) - a P(a+1, x) = ∫_0^x (x-u) g_a(u) du > 0."""
    out = np.empty(a.shape)
    low = x < 0.5 * a
    if np.any(low):
        a_l, x_l = a[low], x[low]
        out[low] = _log_poisson(a_l, x_l) + np.log(x_l) + np.log(_series(a_l, x_l, weighted=True))
    high = ~low
    if np.any(high):
        a_h, x_h = a[high], x[high]
        log_pois = _log_poisson(a_h, x_h)
        p = special.gammainc(a_h, x_h)
        # D = (x - a) P(a, x) + a pois(a; x): no cancellation for x ≥ a, at most a factor
        # ~a between the two terms for a/2 ≤ x < a.
        d = (x_h - a_h) * p + a_h * np.exp(log_pois)
        ok = (p >= _TINY) & (d > 0)
        res = np.log(np.where(ok, d, 1.0))
        if np.any(~ok):
            a_b, x_b = a_h[~ok], x_h[~ok]
            m1 = _series(a_b, x_b, weighted=False)
            res[~ok] = _log_poisson(a_b, x_b) + np.log((x_b - a_b) * m1 + a_b)
        out[high] = res
    return out


def _threshold(n: _Floats, pfa: _Floats) -> _Floats:
    """``special.gammainccinv(n, pfa)`` element by element (1-D arrays): the threshold T of
    P_fa over N pulses, worked out once per distinct N when one P_fa and a few N values
    serve many contacts (a scene's looks have 2-3 N_e; gammainccinv is ~0.2 µs an element),
    the same numbers."""
    if n.size >= 64 and pfa.shape == n.shape:
        p0 = pfa[0]
        if (pfa == p0).all():
            values, inverse = np.unique(n, return_inverse=True)
            if values.size * 8 <= n.size:
                once: _Floats = special.gammainccinv(values, p0)
                return once.take(inverse.ravel())
    t: _Floats = special.gammainccinv(n, pfa)
    return t


def _pd_exact_closed(s: _Floats, pfa: _Floats, n: _Floats, sw: _Ints) -> _Floats:
    """Exact P_d, closed forms (1-D arrays, s > 0; n real for Swerling 0-3, integer for 4)."""
    t = _threshold(n, pfa)
    out = np.empty(s.shape)
    m = sw == 0
    if np.any(m):
        out[m] = _steady_pd(n[m] * s[m], t[m], n[m])
    m = sw == 2
    if np.any(m):
        out[m] = special.gammaincc(n[m], t[m] / (1.0 + s[m]))
    m = sw == 1
    if np.any(m):
        nn, tt, ns = n[m], t[m], n[m] * s[m]
        log_c = -np.log1p(1.0 / ns)
        c = ns / (1.0 + ns)
        log_term = -tt / (1.0 + ns) + (1.0 - nn) * log_c + _log_gammainc(nn, c * tt)
        out[m] = pfa[m] + np.exp(log_term)
    m = sw == 3
    if np.any(m):
        nn, tt, half = n[m], t[m], 0.5 * n[m] * s[m]
        beta = 1.0 + half
        log_c = -np.log1p(1.0 / half)
        c = half / beta
        log_a = -tt / beta + (1.0 - nn) * log_c
        x = c * tt
        t1 = np.exp(log_a + np.log(2.0 - c) + _log_gammainc(nn, x))
        t2 = np.exp(log_a + _log_d(nn, x) - np.log(beta))
        out[m] = pfa[m] + t1 + t2
    m = sw == 4
    if np.any(m):
        out[m] = _pd_swerling4(s[m], t[m], n[m])
    return np.clip(out, pfa, 1.0)


def _steady_pd(energy: _Floats, t: _Floats, n: _Floats) -> _Floats:
    """P(Gamma-noise sum of order n plus steady energy > t): ncx2.sf(2t; 2n, 2 energy)."""
    from scipy import stats  # imported here: 0.2-0.5 s that a run without this model skips

    nc = 2.0 * energy
    sure = np.sqrt(nc) - np.sqrt(2.0 * t) > _SURE_SIGMAS
    return np.where(sure, 1.0, stats.ncx2.sf(2.0 * t, 2.0 * n, np.where(sure, 1.0, nc)))


def _pd_swerling4_real_n(s: _Floats, t: _Floats, n: _Floats) -> _Floats:
    """Swerling 4 at real N: E[ncx2.sf(2T; 2N, 2X)], X ~ Gamma(2N, S/2), Gauss-Hermite."""
    v, w = special.roots_hermitenorm(SW4_QUADRATURE_NODES)
    w = w / np.sqrt(2.0 * np.pi)
    upper = special.ndtr(-v)[None, :]  # X at the normal quantile v, through the upper tail
    out = np.empty(s.shape)
    step = max(1, _SW4_CHUNK // SW4_QUADRATURE_NODES)
    for i in range(0, s.size, step):  # chunks bound the memory
        sl = slice(i, i + step)
        x = special.gammainccinv(2.0 * n[sl, None], upper) * (0.5 * s[sl, None])
        out[sl] = _steady_pd(x, t[sl, None], n[sl, None]) @ w
    return out


def _pd_swerling4(s: _Floats, t: _Floats, n: _Floats) -> _Floats:
    """Σ_m Bin(m; N, r) Q(N+m, T/β) over the binomial's bulk (±12σ + 40 terms)."""
    half = 0.5 * s
    x = t / (1.0 + half)
    log_r = np.log(half) - np.log1p(half)
    log_1mr = -np.log1p(half)
    r = half / (1.0 + half)
    mean = n * r
    sd = np.sqrt(n * r * (1.0 - r))
    m_lo = np.maximum(np.floor(mean - _SW4_SIGMAS * sd - _SW4_EXTRA), 0.0)
    m_hi = np.minimum(np.ceil(mean + _SW4_SIGMAS * sd + _SW4_EXTRA), n)
    width = int(np.max(m_hi - m_lo)) + 1
    out = np.empty(s.shape)
    step = max(1, _SW4_CHUNK // width)
    offsets = np.arange(width, dtype=np.float64)
    for i in range(0, s.size, step):  # chunks bound the memory, not a loop over targets
        sl = slice(i, i + step)
        mm = m_lo[sl, None] + offsets[None, :]
        valid = mm <= m_hi[sl, None]
        mm = np.where(valid, mm, m_lo[sl, None])
        nn = n[sl, None]
        log_w = (
            special.gammaln(nn + 1.0)
            - special.gammaln(mm + 1.0)
            - special.gammaln(nn - mm + 1.0)
            + mm * log_r[sl, None]
            + (nn - mm) * log_1mr[sl, None]
        )
        w = np.where(valid, np.exp(log_w - np.max(log_w, axis=1, keepdims=True)), 0.0)
        # normalized: the mass outside the window is < 1e-30, while the rounding of the
        # large gammaln terms (common to a row) would otherwise leave Σw = 1 ± 1e-11
        w = w / np.sum(w, axis=1, keepdims=True)
        out[sl] = np.sum(w * special.gammaincc(nn + mm, x[sl, None]), axis=1)
    return out


def _pd_exact(snr_db: _Floats, pfa: _Floats, n: _Floats, sw: _Ints) -> _Floats:
    shape = snr_db.shape
    s = np.power(10.0, snr_db.ravel() / 10.0)
    p, nn, ss = pfa.ravel(), n.ravel(), sw.ravel()
    out: NDArray[np.float64] = p.copy()  # S/I = 0 (-inf dB): P_d = P_fa
    pos = s > 0
    real_sw4 = pos & (ss == 4) & (nn != np.floor(nn))
    closed = pos & ~real_sw4
    if np.any(closed):
        out[closed] = _pd_exact_closed(s[closed], p[closed], nn[closed], ss[closed])
    if np.any(real_sw4):
        t = special.gammainccinv(nn[real_sw4], p[real_sw4])
        pd4 = _pd_swerling4_real_n(s[real_sw4], t, nn[real_sw4])
        out[real_sw4] = np.clip(pd4, p[real_sw4], 1.0)
    return out.reshape(shape)


def _required_exact(pd: _Floats, pfa: _Floats, n: _Floats, sw: _Ints) -> _Floats:
    shape = pd.shape
    pd, pfa, n, sw = pd.ravel(), pfa.ravel(), n.ravel(), sw.ravel()
    out = np.full(pd.shape, -np.inf)
    out[pd >= 1.0] = np.inf
    todo = (pd > pfa) & (pd < 1.0)
    if np.any(todo):
        target, p_t, n_t, s_t = pd[todo], pfa[todo], n[todo], sw[todo]
        lo = np.full(target.shape, REQUIRED_SNR_DB_BRACKET[0])
        hi = np.full(target.shape, REQUIRED_SNR_DB_BRACKET[1])
        for _ in range(_REQUIRED_SNR_ITERATIONS):
            mid = 0.5 * (lo + hi)
            below = _pd_exact(mid, p_t, n_t, s_t) < target
            lo = np.where(below, mid, lo)
            hi = np.where(below, hi, mid)
        out[todo] = 0.5 * (lo + hi)
    return out.reshape(shape)


# ----------------------------------------------------------------------------- seed
def _seed_parameters(
    n: NDArray[np.float64], integrator: str, detector: str, signal_variation: str
) -> tuple[NDArray[np.float64], float]:
    if detector not in TABLE_II:
        raise ValueError(f"detector must be one of {tuple(TABLE_II)}, got {detector!r}")
    return equivalent_pulses(n, integrator, signal_variation), TABLE_II[detector]


def g_fa(pfa: ArrayLike) -> NDArray[np.float64]:
    """Blake's false-alarm quantile g_fa = 2.36 sqrt(-log10 P_fa) - 1.02, seed [80].

    Parameters
    ----------
    pfa : array_like
        Probability of false alarm [-], in (0, 1).

    Returns
    -------
    ndarray
        g_fa [-].  Outside 1e-12 ≤ P_fa ≤ 1e-4 (the fit's range) the exact normal quantile
        Φ⁻¹(1 - P_fa) is used, shifted to join the fit continuously at the nearest edge.
    """
    p = np.asarray(pfa, dtype=np.float64)
    p_c = np.clip(p, *SEED_PFA_RANGE)
    blake = G_FA_SLOPE * np.sqrt(-np.log10(p_c)) - G_FA_OFFSET
    normal_shift: NDArray[np.float64] = special.ndtri(p_c) - special.ndtri(p)  # scipy is untyped
    return blake + normal_shift


def g_d(z: ArrayLike) -> NDArray[np.float64]:
    """Blake's detection quantile g_d = 1.231 t / sqrt(1 - t²), t = 0.9 (2 P_d - 1), [81]-[82].

    Parameters
    ----------
    z : array_like
        Φ⁻¹(P_d), the normal quantile of the probability of detection [-] (the argument is
        z rather than P_d so that P_d near 0 and 1 keeps its precision).

    Returns
    -------
    ndarray
        g_d [-].  Outside 0.1 ≤ P_d ≤ 0.9 the exact quantile z is used, shifted to join the
        fit continuously at the nearest edge, so g_d → ±∞ as P_d → 1 or 0.
    """
    z = np.asarray(z, dtype=np.float64)
    z_c: _Floats = np.clip(z, special.ndtri(SEED_PD_RANGE[0]), special.ndtri(SEED_PD_RANGE[1]))
    t: NDArray[np.float64] = G_D_T_SCALE * (2.0 * special.ndtr(z_c) - 1.0)  # scipy is untyped
    return G_D_SLOPE * t / np.sqrt(1.0 - t * t) + (z - z_c)


def _seed_required_snr(
    z: _Floats, gf: _Floats, inv_k: _Floats, h_n: _Floats, zeta: float
) -> NDArray[np.float64]:
    """D_0 [78] times L_f [83] at P_d = Φ(z): the seed's required per-pulse S/I (linear).

    ``gf`` is g_fa [80] and ``inv_k`` 1/K of Table III (0 for the steady target), both
    computed once outside the iteration.
    """
    gd = g_d(z)
    x0 = np.square(np.maximum(gf + gd, 0.0))  # [79], floored at the noise-only limit
    a = x0 / (4.0 * h_n)
    d0 = a + np.sqrt(a * a + x0 / (zeta * h_n))  # [78] rearranged: finite at X0 = 0
    base = -special.log_ndtr(z) * (1.0 + gd / gf)
    positive = base > 0
    log_lf = -inv_k * np.log(np.where(positive, base, 1.0))  # [83]
    # base <= 0 only where g_d <= -g_fa (X0 = 0, P_d below about P_fa): no signal needed
    return np.where(positive | (inv_k == 0), d0 * np.exp(log_lf), 0.0)


def _pd_seed(
    snr_db: _Floats, pfa: _Floats, n: _Floats, sw: _Ints, h_n: _Floats, zeta: float
) -> NDArray[np.float64]:
    shape = snr_db.shape
    s = np.power(10.0, snr_db.ravel() / 10.0)
    p, hh = pfa.ravel(), np.broadcast_to(h_n, shape).ravel()
    gf = g_fa(p)
    inv_k = 1.0 / fluctuation_k(sw.ravel(), n.ravel())
    lo = np.full(s.shape, -_SEED_Z_MAX)
    hi = np.full(s.shape, _SEED_Z_MAX)
    for _ in range(_SEED_ITERATIONS):
        mid = 0.5 * (lo + hi)
        below = _seed_required_snr(mid, gf, inv_k, hh, zeta) < s
        lo = np.where(below, mid, lo)
        hi = np.where(below, hi, mid)
    f_lo = _seed_required_snr(lo, gf, inv_k, hh, zeta)
    f_hi = _seed_required_snr(hi, gf, inv_k, hh, zeta)
    # log-linear interpolation inside the final bracket: monotone in S/I within a bracket
    ok = (f_lo > 0) & (f_hi > f_lo) & (s > 0)
    num = np.log(np.where(ok, s, 1.0)) - np.log(np.where(ok, f_lo, 1.0))
    den = np.log(np.where(ok, f_hi, 2.0)) - np.log(np.where(ok, f_lo, 1.0))
    frac = np.where(ok, np.clip(num / den, 0.0, 1.0), 0.0)
    z = lo + frac * (hi - lo)
    pd: NDArray[np.float64] = np.clip(np.maximum(special.ndtr(z), p), 0.0, 1.0)  # scipy is untyped
    return pd.reshape(shape)


__all__ = [
    "DECORRELATED_SPREAD_RATIO",
    "FALSE_ALARMS_PER_T_FA",
    "LN2_SEED",
    "N_CHANNELS",
    "SEED_PD_RANGE",
    "SEED_PFA_RANGE",
    "TABLE_I",
    "TABLE_II",
    "T_FA_DEFINITIONS",
    "effective_pulses",
    "equivalent_pulses",
    "fluctuation_k",
    "g_d",
    "g_fa",
    "pfa_from_false_alarm_time",
    "probability_of_detection",
    "Interference",
    "INTERFERENCE_NAMES",
    "pulses_per_beam",
    "range_cells",
    "reported_range_cells",
    "required_snr_db",
    "sweep_time",
]
