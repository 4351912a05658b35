//! Root isolation that cannot miss a root: conservative advancement with explicit lower bounds.
//!
//! Every event function `g` is an [`ExpSum`] that is positive while nothing happens; the event is
//! its first zero. On `[τ, τ_max]` we know `B ≥ |g''|` ([`ExpSum::deriv_bound`]), so by Taylor
//! with remainder
//!
//! `g(τ + h) ≥ g(τ) + g'(τ) h − B h²/2 =: L(h)`.
//!
//! `L` is positive on `[0, h*)`, `h* = (g' + √(g'² + 2Bg))/B`, hence `g` has no zero there and we
//! may step to `τ + h*`. No root is skipped, whatever the shape of `g` (grazing included): the
//! only way to stop is `g ≤ tol` with `g' ≤ 0` (a crossing or a touch), or `τ + h* ≥ τ_max` (proof
//! that there is no root). Near a transversal root the steps converge quadratically (the error of
//! `L` is `O(h²)`); at a tangency (`g = g' = 0`) they shrink geometrically by `√2 − 1`, so a touch
//! is found in a few dozen steps.
//!
//! `B` is the smaller of two bounds: the amplitudes `Ω²|Ĥ| + ω_n²|D̂|e^{−ατ}` (+ `2|c2|`), valid
//! on the whole interval, and the envelope of the oscillating parts taken together,
//! `|Z₂(τ)| + ω_n²|D̂|e^{−ατ}(α + |ω_d − Ω|)H` (+ `2|c2|`), valid on `[τ, τ + H]` (see
//! [`envelope`]; `H` is the horizon of the cubic proof below, and that step is capped at `H`).
//! Near resonance the steady and transient parts of the bar motion cancel, and the envelope is
//! several times smaller than the sum of the amplitudes.
//!
//! A second proof is used alongside: within a horizon `H`, `g(τ+h) ≥ g + g'h + (g''/2 − B₃H/6)h²`
//! (`B₃ ≥ |g'''|`), with `H` just beyond the zero of the local quadratic model, which makes the
//! steps Newton-like near a root; the longer of the proven steps is taken. All event functions
//! of a segment are stepped together (the step is the shortest proven one), so the work is
//! bounded by the earliest event. Each evaluation proves its function positive up to `τ + hᵢ`;
//! that proof stays valid, so a function proven beyond the step the others allow is not
//! evaluated again until the step would reach its proven end (then the longer of the old and the
//! fresh proof counts).
//!
//! The search stops at the first of: `g ≤ tol` with `g' ≤ 0`; a proven-free step below the time
//! resolution while approaching; or a bracket `[τ + h*, τ + h_up]` below the time resolution,
//! where `h_up` is where an upper bound reaches 0: `g + g'h + Bh²/2`, or within the horizon
//! `g + g'h + (g''/2 + B₃H/6)h²` (if its zero is `≤ H`). Then a zero certainly lies in the
//! bracket and `τ + h*` is returned, so the reported event is never past the zero; it is returned
//! only when no other function's proven step is shorter (none of them can vanish first).
//!
//! **Bounded work over an interval without a root.** The steps above prove that no root is
//! missed, but their number over an interval is bounded only by its length: where `g ≥ m > 0`,
//! `|g'| ≤ V` and `|g''| ≤ B`, every proven step is at least `h_min = 2m/(V + √(V² + 2Bm))`, so a
//! root-free interval of length `T` costs up to `T/h_min` steps, with `h_min` a fraction of a
//! forcing period for an oscillating bar. A segment without events (a frictionless ball that
//! never meets a wall, a ball stuck for good) is one search over the whole rest of the run,
//! and that search used to stop with an error after 1e5 steps (~1e5 half periods, t ≈ 28–115 s
//! on the paper's bar; issue #7 A3). Hence the search horizon: after [`SEARCH_HORIZON_ITER`]
//! steps the search returns [`Root::Horizon`] at its last proven point `τ_h > t0` (every step
//! advanced `τ` and was proven root-free, so no root lies in `[t0, τ_h)`); the solver ends the
//! segment there without an event and starts the same mode afresh from the closed-form state at
//! `τ_h`. The work of one search is bounded by a constant, the work of a run by
//! `T/h_min + (number of events + restarts) × const`, and a search that needed fewer steps is
//! unchanged bit for bit (the horizon is the former cap).
//!
//! **Slow beat (a lightly damped bar near resonance).** With `ε = −α + i(ω_d − Ω)` small, the
//! steady part `Ĥe^{iΩτ}` and the transient part `D̂e^{λτ}` of the bar motion are each
//! `~F0/(2MΩ|ε|)` (metres for an undamped bar at ratio 1 + 1e-7) and nearly cancel: their sum is
//! the beat `Ĥe^{iΩτ}(1 − e^{ετ}) + …`, of size `~F0 τ/(2MΩ)` while `|ε|τ ≪ 1`. The amplitude
//! bound `Ω²|Ĥ| + ω_n²|D̂|` then exceeds `|g''|` by `~1/(|ε|τ)` (1e5 in the reported case), the
//! proven steps shrink by its square root, and even a run of 0.06 s reached the step cap.
//! The envelope `|Z₂(τ)| + ω_n²|D̂|e^{−ατ}(α + |ω_d − Ω|)s` (see [`envelope`]) is the
//! cancellation-free bound: `Z₂` is the second derivative of the two parts taken together
//! (computed from their phasors, to an absolute rounding of `8ε_mach` times the amplitude bound,
//! which is added), and the drift term is the beat's own growth, `|D̂||ε|ω_n² s ≈ F0 ω_n s/(2M)`.
//! When `(α + |ω_d − Ω|) ≤ BEAT_RATE·Ω` ([`BEAT_RATE`]) the envelope step is taken on its own
//! horizon `H_e` = the step with the envelope without drift (no proof with a larger bound can
//! reach further), with the drift at its largest on `[τ, τ + H_e]`; the resulting step is
//! `≤ H_e`, so the bound holds on all of it. Elsewhere (the paper's bar is 10× above the rate)
//! the envelope step stays capped at 8 amplitude steps as before. The closed form itself is
//! still the sum of the two parts, so its values carry an absolute rounding of
//! `~ε_mach F0/(MΩ|ε|)`, and so do the event positions. Measured on the paper's bar with
//! `ζ = 0` over 10 s: largest penetration 5e-15 m at `|ε|/Ω = 1e-7`, 4e-14 m at 1e-8, 8e-13 m
//! at 1e-9; at 1e-10 and closer it exceeds the 1e-12 m confinement tolerance (2e-12 m to
//! 3e-9 m; `check_invariants` reports it). Closer to an undamped resonance the secular form
//! `−Ĥε e^{iΩτ}(e^{ετ} − 1)/ε` (finite as `ε → 0`, with `(e^{ετ} − 1)/ε` from a series) would
//! be needed as a term of its own in [`ExpSum`], with its bounds and integrals; it is not
//! implemented.
//!
//! **Departure.** A segment often starts *on* the zero set of one of its functions (the wall just
//! hit, `ẇ = 0` just crossed, a wall just released). There `g(0) = 0` analytically, and round-off
//! of 1e-15 in its leading Taylor coefficients would create a spurious root and an endless event
//! loop. The mode logic knows the order `k` of the zero and that `g` departs positively, so the
//! leading coefficients `g(0) … g^(k−1)(0)` are set to 0 and `g^(k)(0)` is clamped to `≥ 0`. With
//! `B_{k+2} ≥ |g^(k+2)|` on the interval,
//!
//! `g(h) ≥ h^k (A + b h − c h²)`, `A = max(g^(k)(0), 0)/k!`, `b = g^(k+1)(0)/(k+1)!`, `c = B_{k+2}/(k+2)!`.
//!
//! With `A ≥ 0`, `c > 0`, the coefficient signs `(+, ±, −)` change exactly once, so by Descartes'
//! rule the bracket has exactly one positive root `h₁ = (b + √(b² + 4Ac))/(2c)`; `g > 0` on
//! `(0, h₁)`. We take the first step to `h₁/2` (the bound is strictly positive there) and continue
//! with the advancement above. E.g. a tangential wall release (`w = ±l_g`, `ẇ = 0`, `ẅ ≈ 0`,
//! jerk ≠ 0) has `k = 2`; an impact with `ẇ+ ≠ 0` has `k = 1`; the friction switch `ẇ = 0` has `k = 1`.
//! If the clamped coefficients give no positive bracket (`A = 0`, `b ≤ 0`), the departure is not
//! confirmed and the event is reported at once; the mode logic then decides again (bounded by the
//! event limit).

use super::expsum::{ExpSum, Trig};

/// Outcome of one search.
#[derive(Debug, Clone, Copy, PartialEq)]
pub enum Root {
    /// First zero at this `τ` (`g ≤ tol`, `g' ≤ 0`).
    At(f64),
    /// Proven positive on the whole interval.
    None,
    /// The search horizon: [`SEARCH_HORIZON_ITER`] steps were taken without reaching a zero or
    /// the end; every function is proven positive on `[t0, τ)`, `τ > t0`. The caller ends the
    /// segment there without an event and searches on from the closed-form state at `τ`.
    Horizon(f64),
}

/// Work bound of one search: after this many proven steps it stops at its proven point
/// ([`Root::Horizon`]). This is the former iteration cap (then an error): a search that needs
/// fewer steps is unchanged, bit for bit. A 2 s paper run needs at most a few thousand.
pub const SEARCH_HORIZON_ITER: u32 = 100_000;

/// The relative beat/decay rate `(α + |ω_d − Ω|)/Ω` below which a search treats the bar motion
/// as a slow beat of two nearly cancelling parts (see the module docs). The paper's bar
/// (`ζ = 0.01`, ratios 0.95–1.05) is ten times above it.
pub const BEAT_RATE: f64 = 1e-3;

/// One event function of a joint search.
#[derive(Debug, Clone, Copy)]
pub struct Cand {
    /// The function, positive while nothing happens.
    pub g: ExpSum,
    /// Order of its known zero at the start (0: none).
    pub order: usize,
    /// Absolute tolerance on `g`.
    pub tol: f64,
}

impl Cand {
    /// `g` with the order of its known zero at the start and its tolerance.
    pub fn new(g: ExpSum, order: usize, tol: f64) -> Cand {
        Cand { g, order, tol }
    }
}

/// Departure step: `g > 0` is proven on `(t0, t0 + h₁)`; returns `h₁/2`, or `None` if the
/// clamped Taylor bracket does not confirm the departure.
/// `rh`, `rd` bound the harmonic and decaying amplitudes `|Ĥ|`, `|D̂|` (as in the search); the
/// bound on `|g^(k+2)|` is then [`ExpSum::deriv_bound`]'s, without its `hypot`s and `exp`.
fn departure_step(g: &ExpSum, order: usize, t0: f64, rh: f64, rd: f64) -> Option<f64> {
    const FACT: [f64; 6] = [1.0, 1.0, 2.0, 6.0, 24.0, 120.0];
    let trig = Trig::new(t0, g.om, g.al, g.wd);
    let d: [f64; 5] = g.derivs_t(&trig);
    let k = order.min(3);
    let a = d[k].max(0.0) / FACT[k];
    let b = d[k + 1] / FACT[k + 1];
    // |g^(n)| ≤ poly + Ωⁿ|Ĥ| + ω_nⁿ|D̂|e^{−αt0} on [t0, ∞), n = k + 2 ≥ 3 (no polynomial part).
    let n = (k + 2) as i32;
    let decay = if t0 == 0.0 { 1.0 } else { (-g.al * t0).exp() };
    let wn = (g.al * g.al + g.wd * g.wd).sqrt();
    let bound = (g.om.powi(n) * rh + wn.powi(n) * decay * rd) * (1.0 + 1e-12);
    let c = bound / FACT[k + 2];
    let h1 = if c > 0.0 {
        (b + (b * b + 4.0 * a * c).sqrt()) / (2.0 * c)
    } else if b < 0.0 {
        a / -b
    } else if a > 0.0 || b > 0.0 {
        f64::INFINITY
    } else {
        0.0
    };
    if h1.is_nan() || h1 <= 0.0 {
        None
    } else {
        Some(0.5 * h1)
    }
}

/// Functions a search keeps on the stack; more go to the run's [`Scratch`].
const INLINE_FNS: usize = 4;

/// Per-run scratch space of the searches with more than 4 functions (fewer live on the stack):
/// the bounds and proof state of each function. It grows to the largest number of functions a
/// search has had and is reused, so a search allocates nothing once the run has seen its
/// largest candidate set, and no candidate is ever dropped.
#[derive(Debug, Clone, Default)]
pub struct Scratch {
    bounds: Vec<FnBounds>,
    proof: Vec<FnProof>,
}

/// Constant parts of the derivative bounds of one function over a search.
#[derive(Debug, Clone, Copy, Default)]
struct FnBounds {
    /// `|g''|` bound: constant part, and decaying amplitude (times `e^{−ατ}`).
    bconst: f64,
    bdec: f64,
    /// The same for `|g'''|`.
    b3const: f64,
    b3dec: f64,
    /// Drift rate of the envelope (times `e^{−ατ}` and the horizon).
    bdrift: f64,
}

/// What is proven about one function so far in a search.
#[derive(Debug, Clone, Copy, Default)]
struct FnProof {
    /// Proven positive up to here by its departure bracket.
    free_until: f64,
    /// Proven positive up to here by an evaluation.
    proven: f64,
}

/// First zero among several functions sharing the frequencies of the first one, in
/// `[t0, t_max]`: returns the root and the index of the function. All functions are stepped
/// together (the step is the smallest proven root-free step), so the work is bounded by the
/// earliest event, not by the interval.
pub fn first_root_multi(cands: &[Cand], t0: f64, t_max: f64, tol_t: f64) -> (Root, usize) {
    let (r, i, _) = first_root_multi_trig(cands, t0, t_max, tol_t, &mut Scratch::default());
    (r, i)
}

/// [`first_root_multi`] with the run's [`Scratch`], also returning the transcendentals at the
/// root when they were computed there (the caller evaluates the state at the root with them).
pub fn first_root_multi_trig(
    cands: &[Cand],
    t0: f64,
    t_max: f64,
    tol_t: f64,
    scratch: &mut Scratch,
) -> (Root, usize, Option<Trig>) {
    let Some(first) = cands.first() else {
        return (Root::None, 0, None);
    };
    let (om, al, wd) = (first.g.om, first.g.al, first.g.wd);
    let wn2 = al * al + wd * wd;
    let wn = wn2.sqrt();
    let tau = t0;
    // Per-function bounds and proofs: on the stack for the usual few functions, in the run's
    // scratch beyond that (never truncated).
    let n = cands.len();
    let mut inline_b = [FnBounds::default(); INLINE_FNS];
    let mut inline_p = [FnProof::default(); INLINE_FNS];
    let (bounds, proof): (&mut [FnBounds], &mut [FnProof]) = if n <= INLINE_FNS {
        (&mut inline_b[..n], &mut inline_p[..n])
    } else {
        scratch.bounds.resize(n, FnBounds::default());
        scratch.proof.resize(n, FnProof::default());
        (&mut scratch.bounds[..n], &mut scratch.proof[..n])
    };
    for i in 0..n {
        let c = &cands[i];
        // Amplitudes (the relative margin covers the rounding of the bounds themselves).
        let rh = (c.g.a * c.g.a + c.g.b * c.g.b).sqrt() * (1.0 + 1e-12);
        let rd = (c.g.p * c.g.p + c.g.q * c.g.q).sqrt() * (1.0 + 1e-12);
        bounds[i] = FnBounds {
            bconst: 2.0 * c.g.c2.abs() * (1.0 + 1e-12) + om * om * rh,
            bdec: wn2 * rd,
            b3const: om * om * om * rh,
            b3dec: wn2 * wn2.sqrt() * rd,
            bdrift: wn2 * rd * (al + (wd - om).abs()) * (1.0 + 1e-12),
        };
        // Departing functions are proven positive up to `free_until` by their Taylor bracket.
        let mut free_until = t0;
        if c.order > 0 {
            match departure_step(&c.g, c.order, t0, rh, rd) {
                Some(h) => free_until = t0 + h,
                None => return (Root::At(t0), i, None),
            }
        }
        proof[i] = FnProof {
            free_until,
            proven: t0,
        };
    }
    // Slow beat: the steady and transient parts of the bar motion are each far larger than
    // their sum for ~1/(α + |ω_d − Ω|) ≥ 1000/Ω (a lightly damped bar near resonance). The
    // advancement is compiled for each case, so the usual one pays nothing for the other.
    let search = Advance {
        cands,
        bounds,
        t_max,
        tol_t,
        om,
        al,
        wd,
        wn,
    };
    if al + (wd - om).abs() <= BEAT_RATE * om {
        search.run::<true>(proof, tau)
    } else {
        search.run::<false>(proof, tau)
    }
}

/// Whether [`first_root_multi_trig`] on `[0, t_max]` would return [`Root::None`] in its first
/// iteration, decided from that iteration's own proof alone: each function's quadratic step
/// with the amplitude bound at `τ = 0` (where the transcendentals are free) reaches `t_max`
/// (a function departing from a zero, order > 0, gives `false`). The full search takes a step at least as long
/// from the same numbers (the longer of several proofs), so `true` means exactly its answer,
/// `(Root::None, 0, None)`, and the proof that no function reaches zero on the interval; on
/// `false` the caller runs the full search. For short intervals (the pieces of a cutting run,
/// ~1/32 of a period) this is most searches, at a fraction of the full iteration's cost (no
/// envelope, no cubic horizon).
#[inline(never)]
pub fn first_step_clears(cands: &[Cand], t_max: f64, tol_t: f64) -> bool {
    let Some(first) = cands.first() else {
        return true;
    };
    let (om, al, wd) = (first.g.om, first.g.al, first.g.wd);
    let wn2 = al * al + wd * wd;
    let trig = Trig::new(0.0, om, al, wd);
    let decay = 1.0 + trig.em1;
    for c in cands {
        // A function departing from a zero (right after an event) is left to the full search,
        // whose departure bracket stays inlined there (the harmonic run's hot path).
        if c.order > 0 {
            return false;
        }
        // The same bounds, to the bit, as the full search's set-up.
        let rh = (c.g.a * c.g.a + c.g.b * c.g.b).sqrt() * (1.0 + 1e-12);
        let rd = (c.g.p * c.g.p + c.g.q * c.g.q).sqrt() * (1.0 + 1e-12);
        let [f, f1]: [f64; 2] = c.g.derivs_t(&trig);
        if f <= c.tol && f1 <= 0.0 {
            return false;
        }
        let bconst = 2.0 * c.g.c2.abs() * (1.0 + 1e-12) + om * om * rh;
        let h = quad_step(f.max(0.0), f1, bconst + wn2 * rd * decay);
        // The full search stops at a step below the time resolution while approaching.
        if f1 < 0.0 && h <= tol_t {
            return false;
        }
        // Short of the end, or NaN (incomparable): not cleared.
        if h.partial_cmp(&t_max).is_none_or(|o| o.is_lt()) {
            return false;
        }
    }
    true
}

/// The advancement of one search over its functions, from their bounds.
struct Advance<'a> {
    cands: &'a [Cand],
    bounds: &'a [FnBounds],
    t_max: f64,
    tol_t: f64,
    om: f64,
    al: f64,
    wd: f64,
    wn: f64,
}

impl Advance<'_> {
    /// Step all functions together from `tau`; `BEAT`: the bar motion is a slow beat.
    #[inline(always)]
    fn run<const BEAT: bool>(
        &self,
        proof: &mut [FnProof],
        tau: f64,
    ) -> (Root, usize, Option<Trig>) {
        let Advance {
            cands,
            bounds,
            t_max,
            tol_t,
            om,
            al,
            wd,
            wn,
        } = *self;
        let n = cands.len();
        let bounds = &bounds[..n];
        let proof = &mut proof[..n];
        let env = Envelope::new(om, al, wd);
        // Every evaluation proves its function positive on [τ, τ + hᵢ); `proven` keeps the
        // furthest such point. A function proven beyond the step the others allow need not be
        // evaluated again (its proof still holds); one that would limit the step is evaluated
        // afresh and the longer of the two proofs is kept.
        let mut tau = tau;
        for _ in 0..SEARCH_HORIZON_ITER {
            let trig = Trig::new(tau, om, al, wd);
            let decay = 1.0 + trig.em1;
            let mut st = Step {
                h: f64::INFINITY,
                imin: 0,
                bracket: None,
            };
            // One evaluation of function `i` at τ: `Err(root)` or its proven step and whether the
            // zero is bracketed to the time resolution just after it.
            let eval = |c: &Cand, bd: &FnBounds, prev: f64| -> Result<(f64, bool), Root> {
                let [f, f1, f2]: [f64; 3] = c.g.derivs_t(&trig);
                if f <= c.tol && f1 <= 0.0 {
                    return Err(Root::At(tau));
                }
                let f = f.max(0.0);
                // Quadratic bound with B ≥ |g''| on the rest of the interval …
                let b_amp = bd.bconst + bd.bdec * decay;
                // … or with the envelope of the oscillating parts taken together: at τ+s,
                // H'' + D'' = Re[e^{iΩs}(Z + λ²D̂e^{λτ}(e^{(−α+iδ)s} − 1))], Z = −Ω²Ĥe^{iΩτ} + λ²D̂e^{λτ},
                // δ = ω_d − Ω, so |g''| ≤ 2|c2| + |Z| + ω_n²|D̂|e^{−ατ}(α + |δ|)s. Near resonance the
                // steady and transient parts cancel and |Z| ≪ Ω²|Ĥ| + ω_n²|D̂|.
                let g = &c.g;
                let e = decay;
                let ph = env.phasors(g, &trig);
                let round = 8.0 * f64::EPSILON * b_amp;
                let bz = (2.0 * g.c2.abs() + env.z2(&ph)) * (1.0 + 1e-12) + round;
                let h2_amp = quad_step(f, f1, b_amp);
                // … and, within a horizon H, the cubic bound with the actual g'':
                // g(τ+h) ≥ g + g'h + (g''/2 − B₃H/6) h² for h ≤ H. Both are proofs; take the longer.
                // H is set a little beyond the zero of the local quadratic model, so that near a
                // root the step lands next to it (Newton-like), far from one it is long.
                let h_model = if f2 < 0.0 {
                    quad_step(f, f1, -f2)
                } else if f1 < 0.0 && f1 * f1 >= 2.0 * f2 * f {
                    2.0 * f / (-f1 + (f1 * f1 - 2.0 * f2 * f).sqrt())
                } else {
                    f64::INFINITY
                };
                // Severe cancellation (see `beat`): the amplitude bound is useless, so the envelope
                // step is taken on its own horizon, `H_e` = the step the envelope allows without
                // its drift (no proven step can be longer), the drift at its largest there; the
                // step is ≤ H_e, so the bound holds on it.
                let h2_base = if BEAT {
                    let h_e = quad_step(f, f1, bz);
                    if h_e.is_finite() && h_e > h2_amp {
                        h2_amp.max(quad_step(f, f1, bz + bd.bdrift * e * h_e).min(h_e))
                    } else {
                        h2_amp
                    }
                } else {
                    h2_amp
                };
                // (Capped with the amplitude step: H does not wait for the envelope.)
                let big_h = (1.1 * h_model).min(8.0 * h2_base);
                // The envelope step over the same horizon: valid on [0, H] with the drift term at
                // its largest there. Only worth it when the envelope is the smaller bound
                // (quad_step is non-increasing in the bound) and H reaches beyond the amplitude step.
                let h2 = if b_amp > bz && big_h > h2_base {
                    h2_base.max(quad_step(f, f1, bz + bd.bdrift * e * big_h).min(big_h))
                } else {
                    h2_base
                };
                // Upper bound within the horizon (cubic step only): g ≤ f + f1 h + c_up h² on
                // [0, H], c_up = f2/2 + B₃H/6, since B₃h³/6 ≤ B₃Hh²/6 there.
                let mut c_up = f64::INFINITY;
                let h3 = if big_h.is_finite() && big_h > h2_base {
                    // |g'''| on [τ, τ+H]: amplitude bound, or the envelope as for g'' above.
                    let b3_amp = bd.b3const + bd.b3dec * decay;
                    let round3 = 8.0 * f64::EPSILON * b3_amp;
                    let b3_env = env.z3(&ph) * (1.0 + 1e-12) + round3 + bd.bdrift * wn * e * big_h;
                    let b3 = b3_amp.min(b3_env);
                    c_up = 0.5 * f2 + b3 * big_h / 6.0;
                    let b_eff = b3 * big_h / 3.0 - f2;
                    quad_step(f, f1, b_eff.max(0.0)).min(big_h)
                } else {
                    0.0
                };
                // An earlier proof may reach further.
                let hi = h2.max(h3).max(prev);
                let mut bracketed = false;
                if f1 < 0.0 {
                    if hi <= tol_t {
                        // Within the time resolution of the zero, approaching it: it is here.
                        return Err(Root::At(tau));
                    }
                    // Upper bound g ≤ f + f1 h + B h²/2: if it reaches 0 by `h_up`, a zero lies in
                    // [τ + hi, τ + h_up]; once that bracket is below the time resolution, stop at
                    // its proven-free left end (if no other function may vanish before it).
                    let disc = f1 * f1 - 2.0 * b_amp * f;
                    if disc >= 0.0 {
                        let h_up = 2.0 * f / (-f1 + disc.sqrt());
                        bracketed = h_up - hi <= tol_t && tau + hi < t_max;
                    }
                    // The same with the cubic upper bound (valid up to H), which brackets the zero
                    // to the resolution from much farther away; tried only when the bracket width,
                    // about (c_up − f2/2 + B₃H/6)·hi²/|f1| = B₃H·hi²/(3|f1|), may be that small.
                    if !bracketed
                        && c_up.is_finite()
                        && (c_up - 0.5 * f2) * hi * hi <= 4.0 * tol_t * -f1
                    {
                        let d3 = f1 * f1 - 4.0 * c_up * f;
                        if d3 >= 0.0 {
                            let h_up3 = 2.0 * f / (-f1 + d3.sqrt());
                            bracketed = h_up3 <= big_h && h_up3 - hi <= tol_t && tau + hi < t_max;
                        }
                    }
                }
                Ok((hi, bracketed))
            };
            // Functions whose earlier proof still holds, to be compared with the step of the
            // others (bit i; from the 64th on they are simply evaluated again, which is valid).
            let mut pending = 0u64;
            for i in 0..n {
                let pf = &mut proof[i];
                if pf.free_until > tau {
                    st.take(i, pf.free_until - tau, false);
                } else if pf.proven > tau && i < 64 {
                    pending |= 1 << i;
                } else {
                    let prev = if pf.proven > tau {
                        pf.proven - tau
                    } else {
                        0.0
                    };
                    match eval(&cands[i], &bounds[i], prev) {
                        Ok((hi, br)) => {
                            pf.proven = tau + hi;
                            st.take(i, hi, br);
                        }
                        Err(r) => return (r, i, Some(trig)),
                    }
                }
            }
            while pending != 0 {
                let i = pending.trailing_zeros() as usize;
                pending &= pending - 1;
                let pf = &mut proof[i];
                let hl = pf.proven - tau;
                if hl >= st.h {
                    // Proven beyond the step: not limiting, no evaluation needed.
                    st.take(i, hl, false);
                    continue;
                }
                match eval(&cands[i], &bounds[i], hl) {
                    Ok((hi, br)) => {
                        pf.proven = tau + hi;
                        st.take(i, hi, br);
                    }
                    Err(r) => return (r, i, Some(trig)),
                }
            }
            if let Some((i, hb)) = st.bracket {
                if hb <= st.h {
                    return (Root::At(tau + hb), i, None);
                }
            }
            let next = tau + st.h;
            if next >= t_max {
                return (Root::None, 0, None);
            }
            if next <= tau {
                return (Root::At(tau), st.imin, Some(trig));
            }
            tau = next;
        }
        // Every step so far was proven root-free and strictly advanced τ (`next > tau` above).
        (Root::Horizon(tau), 0, None)
    }
}

/// The shortest proven step of one iteration, the function giving it, and the earliest
/// bracketed zero.
struct Step {
    h: f64,
    imin: usize,
    bracket: Option<(usize, f64)>,
}

impl Step {
    fn take(&mut self, i: usize, hi: f64, bracketed: bool) {
        if bracketed && self.bracket.is_none_or(|(_, b)| hi < b) {
            self.bracket = Some((i, hi));
        }
        if hi < self.h {
            self.h = hi;
            self.imin = i;
        }
    }
}

/// The powers `(iΩ)^n`, `λ^n` (`n = 2, 3`) of one search, for the envelopes of its functions.
#[derive(Debug, Clone, Copy)]
struct Envelope {
    om2: f64,
    om3: f64,
    l2: (f64, f64),
    l3: (f64, f64),
}

impl Envelope {
    fn new(om: f64, al: f64, wd: f64) -> Envelope {
        let (l2r, l2i) = (al * al - wd * wd, -2.0 * al * wd);
        Envelope {
            om2: om * om,
            om3: om * om * om,
            l2: (l2r, l2i),
            l3: (-al * l2r - wd * l2i, wd * l2r - al * l2i),
        }
    }

    /// `Ĥ e^{iΩτ}` and `D̂ e^{λτ}` as `[hr, hi, dr, di]`.
    #[inline]
    fn phasors(&self, g: &ExpSum, trig: &Trig) -> [f64; 4] {
        let e = 1.0 + trig.em1;
        [
            g.a * trig.ch + g.b * trig.sh,
            g.a * trig.sh - g.b * trig.ch,
            e * (g.p * trig.cd + g.q * trig.sd),
            e * (g.p * trig.sd - g.q * trig.cd),
        ]
    }

    /// `|Z₂| = |(iΩ)²Ĥe^{iΩτ} + λ²D̂e^{λτ}|`, with `(iΩ)² = −Ω²`.
    #[inline]
    fn z2(&self, &[hr, hi, dr, di]: &[f64; 4]) -> f64 {
        let (l2r, l2i) = self.l2;
        let z2r = -self.om2 * hr + (l2r * dr - l2i * di);
        let z2i = -self.om2 * hi + (l2r * di + l2i * dr);
        (z2r * z2r + z2i * z2i).sqrt()
    }

    /// `|Z₃| = |(iΩ)³Ĥe^{iΩτ} + λ³D̂e^{λτ}|`, with `(iΩ)³ = −iΩ³`.
    #[inline]
    fn z3(&self, &[hr, hi, dr, di]: &[f64; 4]) -> f64 {
        let (l3r, l3i) = self.l3;
        let z3r = self.om3 * hi + (l3r * dr - l3i * di);
        let z3i = -self.om3 * hr + (l3r * di + l3i * dr);
        (z3r * z3r + z3i * z3i).sqrt()
    }
}

/// `(|Z₂|, |Z₃|)`: the envelopes at `τ` of the second and third derivatives of the oscillating
/// parts taken together, `Z_n = (iΩ)^n Ĥ e^{iΩτ} + λ^n D̂ e^{λτ}` (`Ĥ = a − ib`, `D̂ = p − iq`,
/// `λ = −α + iω_d`). On `[τ, τ+s]`, `|H^(n) + D^(n)| ≤ |Z_n| + ω_n^n |D̂| e^{−ατ}(α + |ω_d − Ω|) s`,
/// because `e^{λ(τ+s)} = e^{λτ} e^{iΩs} e^{(−α + i(ω_d − Ω))s}` and `|e^z − 1| ≤ |z|` for `Re z ≤ 0`.
pub fn envelope(g: &ExpSum, trig: &Trig) -> (f64, f64) {
    let env = Envelope::new(g.om, g.al, g.wd);
    let ph = env.phasors(g, trig);
    (env.z2(&ph), env.z3(&ph))
}

/// Smallest positive root of `f + f1 h − b h²/2` (`f ≥ 0`, `b ≥ 0`), infinite if none.
#[inline]
fn quad_step(f: f64, f1: f64, b: f64) -> f64 {
    if b > 0.0 {
        let disc = (f1 * f1 + 2.0 * b * f).sqrt();
        if f1 < 0.0 {
            // Same root, written without cancellation.
            2.0 * f / (disc - f1)
        } else {
            (f1 + disc) / b
        }
    } else if f1 < 0.0 {
        f / -f1
    } else {
        f64::INFINITY
    }
}

/// First zero of `g` in `[t0, t_max]`, `g` positive just after `t0`. `order` is the order of the
/// known zero at `t0` (0: `g(t0) > 0`, no departure logic). `tol` is an absolute tolerance on
/// `g`, `tol_t` the time resolution (a zero closer than that, approached, is taken as reached).
pub fn first_root(g: &ExpSum, order: usize, t0: f64, t_max: f64, tol: f64, tol_t: f64) -> Root {
    first_root_multi(&[Cand { g: *g, order, tol }], t0, t_max, tol_t).0
}

#[cfg(test)]
mod tests {
    use super::*;

    /// The first-step certificate answers exactly as the full search, and what it claims holds:
    /// no function that starts positive comes near zero on a fine sampling of the interval.
    /// Pseudo-random sets of 1–5 functions (a fifth departing from a zero) on intervals from a
    /// hundredth of a radian to a few periods; both outcomes must be common.
    #[test]
    fn first_step_certificate_gives_the_full_search_answer() {
        let mut seed = 0x2545_f491_4f6c_dd1d_u64;
        let mut rnd = || {
            seed ^= seed << 13;
            seed ^= seed >> 7;
            seed ^= seed << 17;
            (seed >> 11) as f64 / (1u64 << 53) as f64
        };
        let (mut cleared, mut searched) = (0, 0);
        for _ in 0..20_000 {
            let (om, al, wd) = (1.0 + 4.0 * rnd(), 0.3 * rnd(), 1.0 + 4.0 * rnd());
            let n = 1 + (5.0 * rnd()) as usize;
            let cands: Vec<Cand> = (0..n)
                .map(|_| {
                    let (a, b, p, q) = (rnd() - 0.5, rnd() - 0.5, rnd() - 0.5, rnd() - 0.5);
                    let order = usize::from(rnd() < 0.2);
                    let f0 = if order == 1 { 0.0 } else { 2.0 * rnd() - 0.2 };
                    let g = ExpSum {
                        f0,
                        k0: f0 - a - p,
                        c1: rnd() - 0.5,
                        c2: 0.5 * (rnd() - 0.5),
                        a,
                        b,
                        om,
                        p,
                        q,
                        al,
                        wd,
                    };
                    Cand::new(g, order, 1e-15)
                })
                .collect();
            let t_max = 10f64.powf(-2.0 + 2.5 * rnd());
            let tol_t = 1e-15;
            let full = first_root_multi_trig(&cands, 0.0, t_max, tol_t, &mut Scratch::default());
            if !first_step_clears(&cands, t_max, tol_t) {
                searched += 1;
                continue;
            }
            cleared += 1;
            assert!(
                matches!(full, (Root::None, 0, None)),
                "certified root-free, the full search says {:?}",
                (full.0, full.1)
            );
            for c in cands.iter().filter(|c| c.order == 0 && c.g.f0 > 0.0) {
                for i in 0..=200 {
                    let x = t_max * i as f64 / 200.0;
                    assert!(c.g.value(x) > 0.0, "{:?} at {x}", c.g);
                }
            }
        }
        assert!(cleared > 2000 && searched > 2000, "{cleared} {searched}");
    }

    #[test]
    fn envelope_bounds_hold_on_the_interval() {
        // Near resonance (the case it is made for) and away from it, damped.
        for (om, al, wd) in [(5.0, 0.05, 5.01), (3.0, 0.3, 5.0)] {
            let g = ExpSum {
                f0: 0.1,
                k0: 0.0,
                c1: 0.0,
                c2: 0.0,
                a: 0.7,
                b: -0.4,
                om,
                p: -0.6,
                q: 0.35,
                al,
                wd,
            };
            let wn = (al * al + wd * wd).sqrt();
            let rd = g.p.hypot(g.q);
            for &tau in &[0.0, 0.37, 2.9] {
                let tr = Trig::new(tau, om, al, wd);
                let (z2, z3) = envelope(&g, &tr);
                let e = (-al * tau).exp();
                let d0: [f64; 4] = g.derivs_t(&tr);
                // At s = 0 the envelope bounds the actual derivatives.
                assert!(d0[2].abs() <= z2 * (1.0 + 1e-12));
                assert!(d0[3].abs() <= z3 * (1.0 + 1e-12));
                for i in 0..=400 {
                    let s = 1.5 * i as f64 / 400.0;
                    let d: [f64; 4] = g.derivs(tau + s);
                    let drift = rd * e * (al + (wd - om).abs()) * s;
                    assert!(d[2].abs() <= z2 + wn * wn * drift + 1e-12, "{om} {tau} {s}");
                    assert!(
                        d[3].abs() <= z3 + wn * wn * wn * drift + 1e-12,
                        "{om} {tau} {s}"
                    );
                }
            }
        }
    }

    fn es(f0: f64, c1: f64, c2: f64) -> ExpSum {
        ExpSum {
            f0,
            c1,
            c2,
            om: 1.0,
            al: 0.0,
            wd: 1.0,
            ..Default::default()
        }
    }

    #[test]
    fn parabola_roots() {
        // 1 − τ²: root at 1.
        match first_root(&es(1.0, 0.0, -1.0), 0, 0.0, 10.0, 1e-15, 0.0) {
            Root::At(t) => assert!((t - 1.0).abs() < 1e-14, "{t}"),
            r => panic!("{r:?}"),
        }
        // Touch: (τ − 1)² ≥ 0 touches 0 at 1.
        match first_root(&es(1.0, -2.0, 1.0), 0, 0.0, 10.0, 1e-15, 0.0) {
            Root::At(t) => assert!((t - 1.0).abs() < 1e-7, "{t}"),
            r => panic!("{r:?}"),
        }
        // Near miss by 1e-12: no root.
        assert_eq!(
            first_root(&es(1.0 + 1e-12, -2.0, 1.0), 0, 0.0, 10.0, 1e-15, 0.0),
            Root::None
        );
    }

    /// Bug (B7): the joint search kept its per-function bounds in arrays of 4 and searched only
    /// `cands.len().min(4)` functions, so a fifth event function was silently never looked at.
    #[test]
    fn regression_joint_search_dropped_candidates_beyond_four() {
        // Parabolas 1 + k − τ²: roots at √(1 + k); the last one listed has the earliest root.
        let mut cands: Vec<Cand> = (1..=7)
            .map(|k| Cand::new(es(1.0 + k as f64, 0.0, -1.0), 0, 1e-15))
            .collect();
        cands.push(Cand::new(es(0.25, 0.0, -1.0), 0, 1e-15));
        let mut scratch = Scratch::default();
        let (r, i, _) = first_root_multi_trig(&cands, 0.0, 10.0, 0.0, &mut scratch);
        assert_eq!(i, 7);
        match r {
            Root::At(t) => assert!((t - 0.5).abs() < 1e-14, "{t}"),
            r => panic!("{r:?}"),
        }
        // The scratch is reused by a smaller search without leftovers.
        let (r, i, _) = first_root_multi_trig(&cands[..2], 0.0, 10.0, 0.0, &mut scratch);
        assert_eq!(i, 0);
        assert!(matches!(r, Root::At(t) if (t - 2f64.sqrt()).abs() < 1e-14));
    }

    #[test]
    fn departure_from_a_zero_is_not_a_root() {
        // g = τ − τ²/2 leaves 0 with slope 1 and returns at τ = 2; with round-off in g'(0) < 0
        // clamped by the departure logic.
        let g = es(1e-18, 1.0, -0.5);
        match first_root(&g, 1, 0.0, 10.0, 1e-15, 0.0) {
            Root::At(t) => assert!((t - 2.0).abs() < 1e-12, "{t}"),
            r => panic!("{r:?}"),
        }
        // Tangential departure: g = τ²·(1 − τ) ... approximated by a harmonic: 1 − cos τ leaves
        // 0 quadratically and never returns before 2π.
        let h = ExpSum {
            f0: 0.0,
            a: -1.0,
            om: 1.0,
            al: 0.0,
            wd: 1.0,
            ..Default::default()
        };
        match first_root(&h, 2, 0.0, 10.0, 1e-15, 0.0) {
            Root::At(t) => assert!((t - 2.0 * std::f64::consts::PI).abs() < 1e-6, "{t}"),
            r => panic!("{r:?}"),
        }
    }
}
