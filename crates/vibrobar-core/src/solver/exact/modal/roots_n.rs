//! Root isolation that cannot miss a root, for N-term sums ([`ExpSumN`]): the argument of
//! [`super::roots`] extended term by term.
//!
//! **The proof.** As in the lumped search, every event function `g` is positive while nothing
//! happens, and we step from `τ` to `τ + h` only where a lower bound of `g` is proven positive.
//! Write `g = S + F`, `S` the polynomial, the harmonic and the *slow* terms, `F` the *fast*
//! decaying terms (a set chosen at each step). Each term is bounded by its own amplitude and
//! decay: on `[τ, τ + h]`,
//!
//! * `|F(τ+s)| ≤ R_F := Σ_{k∈fast} |D̂ₖ| e^{−αₖτ}` (a decaying term never exceeds its envelope);
//! * `|S''(τ+s)| ≤ B_S := 2|c2| + Ω²|Ĥ| + Σ_{k∈slow} |λₖ|² |D̂ₖ| e^{−αₖτ}` (`|λₖ|² = αₖ² + ω_k²`,
//!   each derivative of a term multiplies its phasor by `λₖ`; `e^{−αₖ(τ+s)} ≤ e^{−αₖτ}`).
//!
//! Taylor with remainder on `S` and the bound on `F` give, for `0 ≤ h`,
//!
//! `g(τ+h) ≥ (S(τ) − R_F) + S'(τ) h − B_S h²/2 =: L(h)`,
//!
//! with `S(τ) = g(τ) − F(τ)`, `S'(τ) = g'(τ) − F'(τ)` known from the values of the terms at `τ`.
//! If `S(τ) − R_F > 0`, `L > 0` on `[0, h*)` with `h* = ` the positive zero of `L`, so `g` has no
//! zero there. With the empty fast set this is the lumped search's amplitude bound
//! (`B = Σ` over every term); moving the fastest terms to `F` trades their share of `B` (which
//! grows like `ωₖ²`) for a constant offset `R_F` (their size). Far from a root (`g` of the order of
//! the gap) a high mode ringing with an amplitude far below the gap costs nothing, and the step is
//! set by the slow motion, as on the lumped bar; near a root (`g < R_F`) the fast terms cannot be
//! set aside and the full bound takes over (the steps then resolve the fast wiggle, as they must:
//! it could produce the crossing). Every split is a proof; the longest proven step is taken. The
//! splits move terms by decreasing `|λₖ|` one at a time; `S(τ) − R_F` is non-increasing along
//! that sequence (`−Fₖ(τ) − Rₖ ≤ 0`), so the scan stops at the first split without margin.
//! This is the cheap step first: the split costs O(N) per evaluation from values already
//! computed for `g` and `g'`.
//!
//! Rounding: `S(τ)` and `B_S` are formed by subtraction from the totals, so each carries an
//! absolute rounding of a few `ε_mach` times `|g| + Σ Rₖ` (resp. `B`); margins of `8ε_mach·N`
//! times those scales are subtracted from `S − R_F` and added to `B_S`, and every amplitude has
//! the relative margin `1e-12` of the lumped search.
//!
//! **The cheap step first.** The split above still needs every term's value at `τ`, i.e. one
//! `exp` and one `sin_cos` per term and step. A search therefore tries first a fixed fast set,
//! bounded by its amplitudes at the search start, `R_F ≤ Σ_{fast}|D̂ₖ|` (a term only decays),
//! with `S` formed from the slow terms alone (`S(τ) = f(0) − Σ_{fast} pₖ + …` in the
//! cancellation-free form): the same proofs (the quadratic one and the cubic one below, on `S`
//! with `S − R_F` for its value), at the cost of the slow terms' transcendentals only.
//! The fast set is the fastest terms whose amplitudes sum to at most `FAST_FRACTION` (0.1) of every
//! function's largest amplitude (at least one term stays slow), fixed for the search. The cheap
//! step is taken where `S − R_F > R_F/2`; where it falls short the full evaluation above decides
//! that step, and if the function is approaching its zero (`S' ≤ 0`) the search fills every
//! term from then on (near the event every term is needed) and that function takes the full
//! evaluation; the others keep their cheap step (with every term filled it is simply the
//! cheaper proof: on the 4-mode beam as published the wall's full evaluations fall from 2.5 to
//! 1.4 per search, about 2 % of the instructions per event). Measured on the paper's 4-mode beam
//! over 2 s (before the envelope below): 46 500 cheap evaluations and 2 300 failed cheap tests
//! in 36 900 steps without friction; 31 900 and 6 200 in 50 300 steps with the as-published law.
//!
//! **The cubic proof** of the lumped search is kept in the full evaluation: within a horizon
//! `H`, `g(τ+h) ≥ g + g'h + (g''/2 − B₃H/6)h²` with `B₃ = Ω³|Ĥ| + Σ|λₖ|³|D̂ₖ|e^{−αₖτ}`, `H` just
//! beyond the zero of the local quadratic model (Newton-like steps near a root), and its upper
//! bound `g ≤ g + g'h + (g''/2 + B₃H/6)h²` brackets a zero to the time resolution from farther
//! away. `g''` carries a rounding of a few `ε` times the `g''` bound, taken off (added to the
//! upper bound).
//!
//! **Kept from the lumped search, unchanged** (see [`super::roots`] for the arguments): the stop
//! rules (`g ≤ tol` with `g' ≤ 0`; a proven-free step below the time resolution while
//! approaching; a bracket `[τ + h*, τ + h_up]` below the time resolution with
//! `h_up` the zero of an upper bound, `g + g'h + B h²/2` with the full `B`, or the cubic one),
//! so a reported event is never past its zero; the joint search of several functions (the step
//! is the shortest proven one; a function proven beyond it is not evaluated again); the horizon
//! ([`SEARCH_HORIZON_ITER`] steps, then [`Root::Horizon`] at the last proven point, bounded work
//! per search); and the departure rule at a segment start, with the derivative bound of order
//! `k + 2` taken term by term, `Ω^{k+2}|Ĥ| + Σ |λₖ|^{k+2} |D̂ₖ|`. Grazing is the lumped case: at a
//! tangency the proven steps shrink geometrically and the touch is found in a few dozen steps.
//!
//! **The slow beat** (the lumped search's envelope, [`super::roots`], carried over to N terms).
//! Near resonance the harmonic `Ĥe^{iΩτ}` and the mode nearest to it, `D̂ₖe^{λₖτ}`, nearly
//! cancel (the steady and transient parts of that mode), so their amplitude bound
//! `Ω²|Ĥ| + |λₖ|²|D̂ₖ|e^{−αₖτ}` far exceeds their sum. Taken together, on `[τ, τ+s]`,
//! `|H'' + Dₖ''| ≤ |Z₂(τ)| + |λₖ|²|D̂ₖ|e^{−αₖτ}(αₖ + |ω_k − Ω|)s` with
//! `Z₂ = (iΩ)²Ĥe^{iΩτ} + λₖ²D̂ₖe^{λₖτ}` (because `e^{λₖ(τ+s)} = e^{λₖτ}e^{iΩs}e^{(−αₖ+i(ω_k−Ω))s}`
//! and `|e^z − 1| ≤ |z|` for `Re z ≤ 0`), and the same with `Z₃` and `|λₖ|³` for `g'''`. The term
//! `k` is the one with the smallest beat rate `αₖ + |ω_k − Ω|`, chosen once per search; every
//! other term keeps its amplitude bound. The pair's amplitudes are taken off the bound `B` (resp.
//! `B₃`) and the envelope put in, with its drift at its largest over the cubic proof's horizon
//! `H`, and a rounding margin of `8ε` times the bound (the subtraction and the phasors); the
//! step proven with it is capped at `H` (the bound holds only there). This is the lumped
//! search's non-resonant form (the envelope step within `H`), in both the cheap step (when the
//! term is in its slow set) and the full evaluation; the lumped search's own horizon for an
//! undamped resonance (`BEAT_RATE`) is not carried over (the beam has modal damping; near an
//! undamped resonance the searches stay bounded by the horizon, and the closed form's own
//! rounding grows as described there). On the paper's bar at r = 1 (mode 1 at resonance) it
//! halves the steps: 4-mode beam without friction 12.6 → 6.7 per event, one unit mode 8.2 → 5.3.
//! Tested against the search without it on random beating sums with crossings, near touches and
//! near misses (`envelope_search_finds_every_root_the_amplitude_search_finds`).
//!
//! **Cost** (measured, `examples/modal_exact_speed.rs`, 2 s paper-like runs, with the envelope
//! and the per-function cheap step): about 5 proven steps per event on one mode, 7 on the 4-mode
//! beam, 8 on 8 modes without friction (8, 13 and 14 before the envelope); 4.5, 9.5 and 11.5 as
//! published. With the
//! as-published law the relative velocity `ẇ` itself rings with every mode an impact excites
//! (each mode's share of `ẇ` is about equal at the cavity: `Σφₙ²/mₙ` grows like `N`), so the
//! `ẇ = 0` search cannot set the fast terms aside and its steps resolve `ω_N`.
//!
//! **Where the time goes** (callgrind, one 2 s run, 0.1 mm gap, ratio 1; instructions against
//! the lumped `Exact`'s 14.2 M without friction and 15.6 M as published): one unit mode 22.1 M,
//! the 4-mode beam 40.0 M without friction and 70.2 M as published. On the 4-mode as-published
//! run the searches are 79 % of it: the transcendentals (one `exp_m1` and one `sin_cos` per
//! term and step, [`TrigN`]) 37 %, the full evaluation 22 %, the cheap step 9 %, the search's
//! own bookkeeping 11 %; copies of state and sums are below 2 %. The cost is thus steps × terms:
//! what the generic N-term code added over the lumped one (state copies, a call per term, the
//! observer's modal states) has been taken out without changing a bit (tests/
//! modal_exact_golden.rs); what remains would only shrink with fewer steps, i.e. a different
//! step sequence (and so different event times within the tolerances).
//!
//! **Where the steps go, and the levers tried** (callgrind and counts per function on the same
//! runs; none of the variants below was kept). Without friction the two wall searches take
//! 14.5 k evaluations each over 2 300 searches (12 k cheap, 2.5 k full), 16 % more per function
//! than one unit mode (12.5 k, all full); the steps (29 k) are almost one per evaluation, as the
//! approaching wall's short proofs and the receding wall's long ones interleave (on one mode
//! 25 k evaluations fall on 19 k steps). As published, per search the wall takes 5 evaluations
//! (3.5 full, the search being full once `ẇ` approaches) and the `ẇ = 0` function 10 (6 full):
//! 3 within its fast terms' reach (`|ẇ| < Σ_{fast} Rₖ`, about 5 % of `|ẇ|`'s amplitude, where
//! the crossing must be resolved at the top mode's rate), 3 just outside it (proved by the
//! split), 4 cheap. Tried and measured (instructions, 4-mode none / as published, against
//! 40.0 M / 70.2 M): a fast set and a cheap flag per function, filling only the terms each
//! evaluation needs (40.5 M / 70.2 M: every step with `ẇ` already needs every term); the fast
//! fraction 0.05–0.3 and the cheap test's margin 0–2 `R_F` (no better than 0.1 and 0.5, up to
//! +26 %); re-evaluating a function whose proof is still valid on every step, or when its
//! proof ends within 1.5–4 steps (+1 % to +19 %: an evaluation costs about as much as the step
//! it saves); the cubic proof on each split in the full evaluation (17 % fewer full `ẇ`
//! evaluations per search, but about 3 % fewer instructions per search and +1 % without
//! friction). The budget of issue #8 (3× the lumped run's wall time, about 2.7× its
//! instructions on this machine) would need about 42 M instructions as published, i.e. the
//! searches at half their cost: more than any single proven-step refinement above gives.
//!
//! **Third round (issue #8 §8), measured** (callgrind, same runs; `()` observer / the bench's own
//! path `analysis::run_case` with its RMS observer). Kept: the slow-beat envelope above, the
//! cheap step per function, and in `expsum_n` the RMS integral from the segment end's own
//! transcendentals (it was 22 % of the bench's beam run). Instructions, before → after: one unit
//! mode none 22.1 → 19.5 M, as published 25.1 → 21.9 M; 4-mode none 40.1 → 31.5 M (lumped
//! 14.3 M: 2.8× → 2.2×), bench path 49.6 → 38.9 M (lumped 16.3 M: 3.0× → 2.4×); 4-mode as
//! published 70.2 M over 3 281 events → 68.9 M over 3 561 (21.4k → 19.3k per event; lumped 15.8 M
//! over 2 703), bench path 84.4 → 81.9 M (25.7k → 23.0k per event; lumped 18.2 M: 4.6× → 4.5×);
//! 8 modes none 61.1 → 53.0 M. (The 2 s runs are chaotic: a change of the step sequence moves
//! the event count by up to 10 %, hence the per-event figures.) Tried and not kept: the wall
//! as a *monotone companion* of `ẇ = 0` while sliding (the wall `l_g − σw` falls wherever
//! `σẇ > 0`, so its value at a step's end proves the whole step, with a bound on
//! `|(l_g − σw)' + σẇ|` from the coefficients): +12 % as published, since a value at every step
//! end costs more than the wall's own 5 evaluations per search (its proofs are long), even with
//! a Lipschitz skip (+10 %); the departure step at `0.9h₁` instead of `h₁/2` (−1 % per event).
//! **What limits the as-published run**: its events. A trace of the `ẇ = 0` searches shows most
//! friction switches of the beam coming in bursts 10–30 µs apart: the slow part of `ẇ` is near
//! zero and the ringing of the top mode (half period ~24 µs) crosses it again and again; each is
//! a real event of the model (the friction force flips), found by the departure step and about
//! four Newton-like full evaluations (the cubic proof with `B₃ ~ ω_N³` lands short by
//! `B₃h³/6`), which is near what any proof-based search needs. The beam has 1.3× the lumped
//! run's events and each costs its 4 terms (about 3.3× the lumped instructions per event), so
//! without friction the run is within the 3× budget (2.2–2.4× the instructions) and as published
//! it is not (4.4–4.5×); closing that gap needs cheaper full evaluations (all terms: a trig
//! recurrence along the Newton steps, a higher-order proof) rather than fewer proven steps.
//!
//! **Fourth round (issue #8 §8), measured, nothing kept** (callgrind, `()` observer, same runs;
//! instructions, events): lumped 14.3 M none / 15.8 M (2 703) as published; one unit mode
//! 19.5 M (2 263) / 21.8 M (2 754); 4 modes 31.5 M (2 305) / 68.8 M (3 562); 8 modes 53.0 M
//! (2 300) / 430.6 M (12 194: 4.5× the lumped run's events, 35k instructions each, the friction
//! bursts of `ω_8`). Per full evaluation on 4 modes: `TrigN::fill` ~770 instructions (five
//! `sin_cos` of ~80, four libm `exp_m1` of ~45), `eval` ~640; neither has a hot line left
//! (the instructions are spread over the terms' arithmetic). Tried, both with the step's own
//! transcendentals from Taylor series where every `|ω h|, α h ≤ 1/8` and combined with a base
//! point's by angle addition (cancellation-free forms for `cos − 1`, `e^{−αh} − 1`; base = the
//! last point filled directly, so no chain of additions): (1) along the search's full steps:
//! 68.8 M / 3 562 → 67.8 M / 3 462 events, *more* direct fills per event (6.2 against 5.6), as
//! the Newton-like steps near a friction switch are of the order of `1/ω_4` ≈ 1 µs, not below
//! it; 4 modes none +0.5 %. (2) The segment end at a bracketed root (`τ + h`, `h ≤` the time
//! resolution) from the search's last full point instead of a fresh `fill`: it hits at every
//! bracketed event and saves one fill per event, 4 modes none 31.5 → 30.7 M (−2.5 %, same
//! 2 305 events), as published 19.3k → 19.1k per event (−1.3 %), one mode −1.1 % none, 8 modes
//! −2.9 % none; not kept, because it moves every modal golden (the ∫u² of one unit mode
//! without friction by ~1.5e-12 relative over its 87 impacts) for a gain far below the
//! budget's gap. What remains
//! is as the third round says: the as-published beam needs its events found at about half
//! the cost (or a proof that resolves a burst of switches jointly), not a cheaper constant.
//!
//! **Sixth round (issue #8 §8), measured, the same bits** (callgrind, `()` observer, and the
//! bench's own path `examples/modal_exact_profile.rs N LAW 1 case` with the RMS and regime
//! observers; perf for the time). Kept, none changing a result: a full [`TrigN::fill`] takes
//! its terms' half angles four at a time in AVX2 lanes behind runtime detection (the scalar
//! kernel's operations in its order, no FMA; ~790 → ~570 instructions per fill on 4 modes);
//! `∫u²` with buffers sized for the terms in use (zeroing full-capacity buffers per segment);
//! an impact hands the observers its states as formed, not a 0.5 KB copy read back (perf:
//! the copy, and a store-forwarding stall on reading the fresh `ẇ`, ~5 % of the time).
//! Instructions, before → after, `()` observer (the same events and steps): 4 modes none
//! 31.5 → 30.3 M, as published 68.8 → 64.0 M (4.3× → 4.0× the lumped 16.0 M), coulomb
//! 69.6 → 64.8 M (4.3× → 4.0×); one unit mode 19.5 → 19.4 M / 21.9 → 21.7 M; 8 modes
//! 53.0 → 50.5 M / 430.7 → 390.1 M; the bench path (lumped 19.3 / 19.5 M): 4 modes as
//! published 85.9 → 80.3 M (4.4× → 4.2×), coulomb 86.2 → 80.5 M. CPU time of the bench path
//! (user time of 100–200 runs, a machine at load 8–10): 4.4× → 4.05× the lumped run, both
//! laws. With the slow-beat envelope on a split (branch `bspeed`, which moves the beam
//! goldens and is not merged): 55.3 M (3.5×) / 57.0 M (3.5×), the bench path 71.2 M
//! (3.7×) / 72.7 M (3.7×), CPU time 3.4×. Tried and not kept: the cheap step's partial
//! fill in the lanes (1–3 terms: +0.1 %); one lane for a single term (+2 % on one unit
//! mode); fat LTO with one codegen unit (no change). (The bench's wall clock on this shared
//! machine ranged 1.2–10.7× between runs of the same binary: no measure.) Where the time goes now (perf, bench path, 4 modes as
//! published): `eval` 24 %, the fills 20 %, the cheap step 11 %, `∫u²` 10 % (its pairs'
//! `φ₁` series and divisions, the observer's share), the search's own bookkeeping 7 %,
//! `exp_m1` 6 %, the envelope's bounds 4 %: the 3× budget (about 58 M on the bench path)
//! still needs a quarter fewer full steps, which only a different step sequence gives.
//!
//! **Seventh round (issue #8 §8), measured, no result-moving change kept** (callgrind, `()`
//! observer and the bench path as above; per event, since a changed step sequence moves the
//! chaotic 2 s runs' event counts by several %). A trace of every search (4 modes as published):
//! the 1 260 searches ending at a friction switch take 6.1 full evaluations each (mostly 3–4; 231
//! take 10 or more, the ringing hovering just above a near-zero slow part), after a departure
//! step that proves about a third of the way to the next switch (1–5/ω_N away); each of the 2 301
//! impact searches takes about 13.6 evaluations (5.7 cheap, 2.2 full of the wall, 5.6 full of `ẇ`
//! while it nearly touches zero). In units of `1/ω_N` the full evaluations of a switch land at
//! e.g. 2.7 → 0.7 → 0.1 → 4e-3 → 7e-6 → bracketed: *quadratic*, because where the cubic proof's
//! bound is convex (`g''/2 > B₃H/6`) clamping `b_eff` at zero leaves Newton's step `g/|g'|`,
//! which from the convex side lands short every time. So a Newton candidate with a monotonicity
//! proof after it (the brief's first idea) has nothing left to gain: with the convex bound's own
//! root the tail is 0.9 → 0.07 → bracketed (two evaluations), and any candidate must still be
//! bracketed to the time resolution by two-sided bounds, which needs a point within ~5e-4/ω_N of
//! the zero. Tried (commit 7952390, reverted by the next, so the code stays recoverable): (1) the
//! slow-beat envelope on every split of the full evaluation while its term is slow (`|Z₂(τ)|`
//! plus its drift over the split's horizon `8h`, the step capped there: `bspeed`'s idea); (2) the
//! convex cubic step, from the value less its rounding (without that margin an exact double root
//! is stepped over: the parabola test). (2) alone, measured before that margin, about −2.5 % (as
//! published) and −4 % (coulomb) per event; (1) takes the impact searches' full `ẇ` evaluations
//! from 5.6 to 2.7 and the switches' from 6.1 to 5.3; both: as published 64.0 M / 3 561 events →
//! 53.7 M / 3 449 (18.0k → 15.6k per event, 4.0× → 3.35× the lumped run), coulomb 64.8 M / 3 593
//! → 55.6 M / 3 509 (18.0k → 15.9k, 3.45×), none 30.3 → 30.4 M (the same 2 304 events), one unit
//! mode +5 % (19.4 → 20.5 M none); the bench path 80.2 → 69.2 M (3.6×) and 80.5 → 71.1 M (3.6×);
//! CPU time of the bench path (300 runs, five alternating sets, load 3–4) median 3.4× / 3.8×. The
//! split's horizon at 4, 16 or 32 `h` instead of 8: 15.4k–15.8k per event, within the runs'
//! spread. Not kept: short of the 3× budget, and both move every modal golden (the `n1_*` cases
//! too). Kept: a randomized test of the search as it is on bursts of close roots against dense
//! sampling and bisection (`bursts_of_close_roots_match_dense_sampling_and_bisection`). With both
//! the per-event cost (15.6k against the lumped run's 5.9k) goes to the full evaluations 22 %,
//! the fills and `exp_m1` 23 %, the search's own setup and bookkeeping 13 %, the cheap step 12 %:
//! the budget (about 43 M, 12k per event) needs another fifth off, i.e. fewer full evaluations at
//! the hovering near-touches and in the impact searches, not a faster switch.
//!
//! **Eighth round (issue #8 §8): the budget met** (callgrind on the bench's own path, and CPU
//! time of alternating runs; the 2 s runs are chaotic, so costs are also compared per event).
//! Kept, all measured on the 4-mode beam as published at r = 1, 0.1 mm: the seventh round's
//! two proofs (above); the terms' decays from the inlined, bit-identical scalar/AVX2 `exp_m1`
//! ([`super::expsum_n::exp_m1`], libm's `expm1` was 5 % of the time); partial fills in the
//! vector kernels' lanes; the per-basis part of a search kept while the basis is the same
//! (`basis_setup`); `|Z₂|`, `|Z₃|` once per evaluation; a split's square root only where it can
//! win (`improve`); the bracket's square roots only where the step can end at one. Outside
//! the search: the ∫u² of the RMS from a per-basis plan (`SquarePlan`, 4× fewer instructions),
//! `chatter_limit` no longer inlined into `impact` (its ~100 KB stack frame was probed page by
//! page at every impact: a third of `impact`'s time), no 2 KB `TrigN` zeroed per observer sample
//! and no 0.5 KB state copied per event. Bench path 80.2 M → 54.5 M instructions (the lumped run
//! 19.3 M: 4.2× → 2.8×), coulomb 80.5 → 54.4 M (2.8×), frictionless 40.8 → 31.4 M (1.8×).
//! Tried and not kept, measured: (a) a *ladder* of cached step transcendentals composed by angle
//! addition (`e^{λ(τ+h)} = e^{λτ}e^{λh}` with `h` rounded down to 3 mantissa bits and the
//! rounding of `τ + h` corrected to first order): 64 % of the steps are Newton-like approaches,
//! whose quadratic convergence a shortened step breaks, and the rest save less than the steps
//! they add (no gain in instructions). (b) A hint that skips a function's cheap step after it
//! failed away from its zero: −3 % to +2 % per event across r = 0.99–1.02. (c) Higher-order
//! proofs: Taylor bounds of degree 7 (near a zero) and 11 (from a departure) in the scaled step
//! `u = |λ_N| h`, their first zero certified by Bernstein coefficients (Descartes' rule on the
//! interval) and bracketed by the upper bound; tested against the function, they cut the steps
//! by 19 % (25 177 → 20 368), but computing them (1.6k–3.2k instructions per proof) cost as
//! much time as the steps saved (per event ±1 % to +4 %); not kept.
//! (d) The envelope's split horizon from the linear step instead of the split's own root: +1.6 %
//! per event. **At other ratios** the beam's cost is its events: at r = 0.98–0.99 as published
//! its 4th mode rings across `ẇ = 0` in bursts (8 200–9 500 friction switches in 2 s against
//! ~1 200 at r = 1 and 75 at r = 1.01; the lumped run has ~2 600 events), so the run costs about
//! 8–9× the lumped one there (callgrind, bench path: 162 M and 150 M against 18.8 M and 19.1 M) at
//! about the same cost per event; at r = 1.01, 1.8×.

pub use super::super::roots::{Root, SEARCH_HORIZON_ITER};
use super::expsum_n::{ExpSumN, Term, TrigN, MAX_TERMS};

/// Most event functions of one search (free flight has three, the pair modes one or two).
pub const MAX_CANDS: usize = 4;

/// One event function of a joint search.
#[derive(Debug, Clone, Copy)]
pub struct CandN {
    /// The function, positive while nothing happens.
    pub g: ExpSumN,
    /// Order of its known zero at the start (0: none).
    pub order: usize,
    /// Absolute tolerance on `g`.
    pub tol: f64,
}

/// Precomputed bounds of one function.
#[derive(Debug, Clone, Copy)]
struct Pre {
    /// `2|c2| + Ω²|Ĥ|` with margin.
    bconst: f64,
    /// `|Ĥ|` with margin.
    rh: f64,
    /// `|D̂ₖ|` with margin.
    rd: [f64; MAX_TERMS],
    /// Coefficients of the first and second derivatives of each term.
    d1: [Term; MAX_TERMS],
    d2: [Term; MAX_TERMS],
    /// `Ω³|Ĥ|` with margin (the harmonic's share of the `|g'''|` bound).
    b3const: f64,
    /// `Σ_{fast} pₖ` and `Σ_{fast} |D̂ₖ|` of the cheap step's fixed fast set.
    shift: f64,
    rf0: f64,
}

/// The envelope of the harmonic and the term nearest to it taken together (module docs, the
/// slow beat): the powers `(iΩ)ⁿ`, `λⁿ` (`n = 2, 3`) of that term `k`, and its beat rate
/// `α + |ω_d − Ω|`.
#[derive(Debug, Clone, Copy, Default)]
struct EnvN {
    k: usize,
    om2: f64,
    om3: f64,
    l2: (f64, f64),
    l3: (f64, f64),
    rate: f64,
}

impl EnvN {
    /// `(|Z₂|, |Z₃|)` of `g` at `τ`: `Z_n = (iΩ)ⁿĤe^{iΩτ} + λⁿD̂ₖe^{λτ}`, as
    /// [`super::roots::envelope`].
    #[inline]
    fn z23(&self, g: &ExpSumN, tr: &TrigN) -> (f64, f64) {
        let kk = &tr.k[self.k];
        let t = &g.t[self.k];
        let e = 1.0 + kk.em1;
        let hr = g.a * tr.ch + g.b * tr.sh;
        let hi = g.a * tr.sh - g.b * tr.ch;
        let dr = e * (t.p * kk.cd + t.q * kk.sd);
        let di = e * (t.p * kk.sd - t.q * kk.cd);
        let (l2r, l2i) = self.l2;
        let z2r = -self.om2 * hr + (l2r * dr - l2i * di);
        let z2i = -self.om2 * hi + (l2r * di + l2i * dr);
        let (l3r, l3i) = self.l3;
        let z3r = self.om3 * hi + (l3r * dr - l3i * di);
        let z3i = -self.om3 * hr + (l3r * di + l3i * dr);
        (
            (z2r * z2r + z2i * z2i).sqrt(),
            (z3r * z3r + z3i * z3i).sqrt(),
        )
    }
}

#[derive(Debug, Clone, Copy, Default)]
struct FnProof {
    free_until: f64,
    proven: f64,
}

/// Per-run scratch of the searches (fixed capacity, written only where used).
#[derive(Debug, Clone)]
pub struct ScratchN {
    /// The transcendentals at the last point evaluated (the root, when one was found there).
    pub trig: TrigN,
    order: [usize; MAX_TERMS],
    wn2: [f64; MAX_TERMS],
    wn3: [f64; MAX_TERMS],
    pre: [Pre; MAX_CANDS],
    proof: [FnProof; MAX_CANDS],
    v: [f64; MAX_TERMS],
    v1: [f64; MAX_TERMS],
    r: [f64; MAX_TERMS],
    /// Proven steps taken by all searches (for the cost measurement).
    pub steps: u64,
    /// Whether `trig` holds every term (not only the cheap step's slow ones).
    pub trig_full: bool,
    /// Size of the cheap step's fast set (`order[..n_fast]`).
    n_fast: usize,
    /// Cheap steps that proved enough (for the cost measurement).
    pub cheap_ok: u64,
    /// Cheap steps that did not (the search then evaluated every term).
    pub cheap_fail: u64,
    /// The slow-beat envelope of this search, if its basis has a harmonic and an oscillating
    /// term (the one nearest to `Ω`), and whether that term is in the cheap step's slow set.
    env: Option<EnvN>,
    env_slow: bool,
    /// Searches without the envelope (the reference of the tests).
    #[cfg(test)]
    env_off: bool,
    /// The basis the per-basis part was set up for (only its frequencies are read), and with
    /// or without the envelope.
    basis: ExpSumN,
    #[cfg(test)]
    env_off_of_basis: bool,
}

impl Default for ScratchN {
    fn default() -> Self {
        ScratchN {
            trig: TrigN::empty(),
            order: [0; MAX_TERMS],
            wn2: [0.0; MAX_TERMS],
            wn3: [0.0; MAX_TERMS],
            pre: [Pre {
                bconst: 0.0,
                rh: 0.0,
                rd: [0.0; MAX_TERMS],
                d1: [Term::default(); MAX_TERMS],
                d2: [Term::default(); MAX_TERMS],
                b3const: 0.0,
                shift: 0.0,
                rf0: 0.0,
            }; MAX_CANDS],
            proof: [FnProof::default(); MAX_CANDS],
            v: [0.0; MAX_TERMS],
            v1: [0.0; MAX_TERMS],
            r: [0.0; MAX_TERMS],
            steps: 0,
            trig_full: false,
            n_fast: 0,
            cheap_ok: 0,
            cheap_fail: 0,
            env: None,
            env_slow: false,
            #[cfg(test)]
            env_off: false,
            // (No basis: `n = 0` with `Ω = NaN` never equals a search's.)
            basis: ExpSumN::zero(f64::NAN),
            #[cfg(test)]
            env_off_of_basis: false,
        }
    }
}

/// Smallest positive root of `f + f1 h − b h²/2` (`f ≥ 0`, `b ≥ 0`), infinite if none.
#[inline]
fn quad_step(f: f64, f1: f64, b: f64) -> f64 {
    if b > 0.0 {
        let disc = (f1 * f1 + 2.0 * b * f).sqrt();
        if f1 < 0.0 {
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

/// Smallest positive root of `f + f1 h − b h²/2` for `b` of either sign (`f ≥ 0`), infinite if
/// none: with `b < 0` (a convex lower bound) the smaller root of the upward parabola, where
/// `quad_step` with `b` clamped to zero would give only the Newton step `f/|f1|`.
#[inline]
fn quad_step_signed(f: f64, f1: f64, b: f64) -> f64 {
    if b >= 0.0 {
        quad_step(f, f1, b)
    } else if f1 < 0.0 {
        let disc = f1 * f1 + 2.0 * b * f;
        if disc >= 0.0 {
            2.0 * f / (-f1 + disc.sqrt())
        } else {
            f64::INFINITY
        }
    } else {
        f64::INFINITY
    }
}

/// `max(hi, min(quad_step(f, f1, b), cap))`, without the square root where it cannot win:
/// the bound `f + f1 h − b h²/2` (`f ≥ 0`, `b ≥ 0`) is positive exactly before its root, so
/// where it is not positive at `hi` the root does not reach beyond `hi`.
#[inline]
fn improve(hi: f64, f: f64, f1: f64, b: f64, cap: f64) -> f64 {
    if cap <= hi || f + hi * (f1 - 0.5 * b * hi) <= 0.0 {
        return hi;
    }
    hi.max(quad_step(f, f1, b).min(cap))
}

const MARGIN: f64 = 1.0 + 1e-12;

/// Largest share of a function's largest amplitude the cheap step's fast set may carry (module
/// docs): a fast set carrying more would fail the cheap test at every step.
const FAST_FRACTION: f64 = 0.1;

/// Departure step of `g` with a zero of order `order` at `t0` (the rule of [`super::roots`]):
/// `g > 0` is proven on `(t0, t0 + h₁)`; returns `h₁/2`, or `None` if not confirmed.
fn departure_step(g: &ExpSumN, order: usize, pre: &Pre, s: &ScratchN) -> Option<f64> {
    const FACT: [f64; 6] = [1.0, 1.0, 2.0, 6.0, 24.0, 120.0];
    let tr = &s.trig;
    let d: [f64; 5] = g.derivs_t(tr);
    let k = order.min(3);
    let a = d[k].max(0.0) / FACT[k];
    let b = d[k + 1] / FACT[k + 1];
    // `x^(k+2)` from `x²` and `x³` (a departure has a zero of order k ≥ 1: k + 2 is 3, 4 or 5).
    debug_assert!((1..=3).contains(&k));
    let pow = |x2: f64, x3: f64| match k {
        1 => x3,
        2 => x2 * x2,
        _ => x2 * x3,
    };
    let om2 = g.om * g.om;
    let mut bound = pow(om2, om2 * g.om) * pre.rh;
    for kk in 0..g.n {
        bound += pow(s.wn2[kk], s.wn3[kk]) * pre.rd[kk] * (1.0 + tr.k[kk].em1);
    }
    let c = bound * MARGIN / FACT[k + 2];
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

/// The per-basis part of a search (module docs): the terms by decreasing `|λ|` (the order in
/// which they are moved to the fast set), their `|λ|²` and `|λ|³`, and the envelope's term
/// (the one nearest to the harmonic, the smallest beat rate); `s.basis` records the basis.
fn basis_setup(g: &ExpSumN, s: &mut ScratchN) {
    let nt = g.n;
    for k in 0..nt {
        s.wn2[k] = g.t[k].wn2();
        s.wn3[k] = s.wn2[k] * s.wn2[k].sqrt();
        s.order[k] = k;
    }
    for i in 1..nt {
        let mut j = i;
        while j > 0 && s.wn2[s.order[j - 1]] < s.wn2[s.order[j]] {
            s.order.swap(j - 1, j);
            j -= 1;
        }
    }
    s.env = None;
    #[cfg(test)]
    let env_on = !s.env_off;
    #[cfg(not(test))]
    let env_on = true;
    if env_on && g.om > 0.0 {
        let om = g.om;
        let mut best = f64::INFINITY;
        for (k, t) in g.t[..nt].iter().enumerate() {
            let rate = t.al + (t.wd - om).abs();
            if t.wd > 0.0 && rate < best {
                best = rate;
                let (al, wd) = (t.al, t.wd);
                let (l2r, l2i) = (al * al - wd * wd, -2.0 * al * wd);
                s.env = Some(EnvN {
                    k,
                    om2: om * om,
                    om3: om * om * om,
                    l2: (l2r, l2i),
                    l3: (-al * l2r - wd * l2i, wd * l2r - al * l2i),
                    rate: rate * MARGIN,
                });
            }
        }
    }
    s.basis.set_affine(g, 0.0, 0.0);
    #[cfg(test)]
    {
        s.env_off_of_basis = s.env_off;
    }
}

/// First zero among `cands` (all on the basis of the first) in `[t0, t_max]`: the root and the
/// index of its function. When the root was found at an evaluated point, `scratch.trig` holds
/// the transcendentals there (`scratch.trig.tau` equals the root).
pub fn first_root_n(
    cands: &[CandN],
    t0: f64,
    t_max: f64,
    tol_t: f64,
    s: &mut ScratchN,
) -> (Root, usize) {
    let n_c = cands.len();
    assert!(n_c <= MAX_CANDS, "more event functions than MAX_CANDS");
    let Some(first) = cands.first() else {
        return (Root::None, 0);
    };
    let nt = first.g.n;
    // What depends on the basis alone (the order of the terms, their |λ|ⁿ, the envelope's
    // term) is kept from the previous search when the basis is the same (a run has one or
    // two bases).
    #[cfg(test)]
    let same = s.basis.same_basis(&first.g) && s.env_off_of_basis == s.env_off;
    #[cfg(not(test))]
    let same = s.basis.same_basis(&first.g);
    if !same {
        basis_setup(&first.g, s);
    }
    s.trig.fill(t0, &first.g);
    s.trig_full = true;
    for (i, c) in cands.iter().enumerate() {
        debug_assert!(c.g.same_basis(&first.g));
        let g = &c.g;
        let pre = &mut s.pre[i];
        pre.rh = (g.a * g.a + g.b * g.b).sqrt() * MARGIN;
        pre.bconst = 2.0 * g.c2.abs() * MARGIN + g.om * g.om * pre.rh;
        pre.b3const = g.om * g.om * g.om * pre.rh;
        for k in 0..nt {
            pre.rd[k] = g.t[k].amp() * MARGIN;
            pre.d1[k] = g.t[k].deriv();
            pre.d2[k] = pre.d1[k].deriv();
        }
    }
    // The cheap step's fast set (module docs): the fastest terms, as many as keep the sum of
    // their amplitudes below FAST_FRACTION of the largest amplitude of every function (at
    // least one term stays slow).
    let mut n_fast = 0;
    let mut cum = [0.0f64; MAX_CANDS];
    let mut cap = [0.0f64; MAX_CANDS];
    for (c, pre) in cap.iter_mut().zip(&s.pre).take(n_c) {
        *c = FAST_FRACTION * pre.rd[..nt].iter().fold(pre.rh, |a, &b| a.max(b));
    }
    'grow: for j in 0..nt.saturating_sub(1) {
        let k = s.order[j];
        for (i, ci) in cum.iter_mut().enumerate().take(n_c) {
            if *ci + s.pre[i].rd[k] > cap[i] {
                break 'grow;
            }
        }
        for (i, ci) in cum.iter_mut().enumerate().take(n_c) {
            *ci += s.pre[i].rd[k];
        }
        n_fast = j + 1;
    }
    s.n_fast = n_fast;
    s.env_slow = s
        .env
        .is_some_and(|e| s.order[..n_fast].iter().all(|&k| k != e.k));
    for (i, c) in cands.iter().enumerate() {
        let g = &c.g;
        let pre = &mut s.pre[i];
        let (mut shift, mut rf0) = (0.0, 0.0);
        for &k in &s.order[..n_fast] {
            shift += g.t[k].p;
            rf0 += pre.rd[k];
        }
        pre.shift = shift;
        pre.rf0 = rf0 * MARGIN;
        let mut free_until = t0;
        if c.order > 0 {
            match departure_step(g, c.order, &s.pre[i], s) {
                Some(h) => free_until = t0 + h,
                None => return (Root::At(t0), i),
            }
        }
        s.proof[i] = FnProof {
            free_until,
            proven: t0,
        };
    }
    let mut tau = t0;
    // Cheap steps while they prove enough or the function departs (module docs); once a
    // function approaching its zero fails the cheap test, the search evaluates every term.
    let mut cheap = n_fast > 0;
    // Per function: its cheap step is still worth trying (it has not failed while approaching;
    // with every term filled it is then simply the cheaper proof).
    let mut fcheap = [n_fast > 0; MAX_CANDS];
    for _ in 0..SEARCH_HORIZON_ITER {
        s.steps += 1;
        if tau.to_bits() != t0.to_bits() {
            if cheap {
                s.trig
                    .fill_some(tau, &first.g, &s.order[s.n_fast..nt], true);
                s.trig_full = false;
            } else {
                s.trig.fill(tau, &first.g);
                s.trig_full = true;
            }
        }
        let mut st_h = f64::INFINITY;
        let mut st_imin = 0;
        let mut bracket: Option<(usize, f64)> = None;
        let mut take = |i: usize, hi: f64, br: bool, st_h: &mut f64, st_imin: &mut usize| {
            if br && bracket.is_none_or(|(_, b)| hi < b) {
                bracket = Some((i, hi));
            }
            if hi < *st_h {
                *st_h = hi;
                *st_imin = i;
            }
        };
        // Functions whose earlier proof may still hold, compared with the others' step.
        let mut pending = [false; MAX_CANDS];
        for i in 0..n_c {
            let pf = s.proof[i];
            if pf.free_until > tau {
                take(i, pf.free_until - tau, false, &mut st_h, &mut st_imin);
            } else if pf.proven > tau {
                pending[i] = true;
            } else {
                if fcheap[i] {
                    match cheap_eval(&cands[i], i, s, tau, 0.0) {
                        Ok(hi) => {
                            s.cheap_ok += 1;
                            s.proof[i].proven = tau + hi;
                            take(i, hi, false, &mut st_h, &mut st_imin);
                            continue;
                        }
                        Err(approaching) => {
                            if approaching {
                                fcheap[i] = false;
                                cheap = false;
                            }
                            s.cheap_fail += 1;
                        }
                    }
                }
                complete(s, tau, &first.g);
                match eval(&cands[i], i, s, tau, 0.0, t_max, tol_t) {
                    Ok((hi, br)) => {
                        s.proof[i].proven = tau + hi;
                        take(i, hi, br, &mut st_h, &mut st_imin);
                    }
                    Err(r) => return (r, i),
                }
            }
        }
        for i in 0..n_c {
            if !pending[i] {
                continue;
            }
            let hl = s.proof[i].proven - tau;
            if hl >= st_h {
                take(i, hl, false, &mut st_h, &mut st_imin);
                continue;
            }
            if fcheap[i] {
                match cheap_eval(&cands[i], i, s, tau, hl) {
                    Ok(hi) => {
                        s.cheap_ok += 1;
                        s.proof[i].proven = tau + hi;
                        take(i, hi, false, &mut st_h, &mut st_imin);
                        continue;
                    }
                    Err(approaching) => {
                        if approaching {
                            fcheap[i] = false;
                            cheap = false;
                        }
                        s.cheap_fail += 1;
                    }
                }
            }
            complete(s, tau, &first.g);
            match eval(&cands[i], i, s, tau, hl, t_max, tol_t) {
                Ok((hi, br)) => {
                    s.proof[i].proven = tau + hi;
                    take(i, hi, br, &mut st_h, &mut st_imin);
                }
                Err(r) => return (r, i),
            }
        }
        if let Some((i, hb)) = bracket {
            if hb <= st_h {
                return (Root::At(tau + hb), i);
            }
        }
        let next = tau + st_h;
        if next >= t_max {
            return (Root::None, 0);
        }
        if next <= tau {
            return (Root::At(tau), st_imin);
        }
        tau = next;
    }
    (Root::Horizon(tau), 0)
}

/// Fill the fast terms of `s.trig` if only the slow ones are there.
#[inline]
fn complete(s: &mut ScratchN, tau: f64, g: &ExpSumN) {
    if !s.trig_full {
        s.trig.fill_some(tau, g, &s.order[..s.n_fast], false);
        s.trig_full = true;
    }
}

/// The cheap step of function `i` at `τ` from the slow terms only (module docs): the fast set
/// is bounded by its amplitudes at the search start, `R_F ≤ Σ_{fast}|D̂ₖ|` (they only decay),
/// so `g(τ+h) ≥ S(τ) − R_F + S'(τ)h − B_S h²/2` with `S` from the slow terms
/// (`S(τ) = f(0) − Σ_{fast} pₖ + …` in the cancellation-free form). Taken only where the fast
/// set is small against the distance (`S − R_F > R_F/2`), else `Err(approaching)` (the full
/// evaluation decides; `approaching`: `S' ≤ 0`, the search stays full from then on).
#[inline]
fn cheap_eval(c: &CandN, i: usize, s: &ScratchN, tau: f64, prev: f64) -> Result<f64, bool> {
    let g = &c.g;
    let tr = &s.trig;
    let pre = &s.pre[i];
    let base = g.f0 - pre.shift;
    let mut f = base + tau * (g.c1 + tau * g.c2) + g.a * tr.chm1 + g.b * tr.sh;
    let mut f1 = g.c1 + 2.0 * g.c2 * tau + g.om * (g.b * tr.ch - g.a * tr.sh);
    let mut f2 = 2.0 * g.c2 - g.om * g.om * (g.a * tr.ch + g.b * tr.sh);
    let mut bdec = 0.0;
    let mut b3dec = 0.0;
    let mut rsum = 0.0;
    for &k in &s.order[s.n_fast..g.n] {
        let kk = &tr.k[k];
        let t = &g.t[k];
        let e = 1.0 + kk.em1;
        f += t.p * (kk.em1 * kk.cd + kk.cdm1) + t.q * e * kk.sd;
        let d = &pre.d1[k];
        f1 += e * (d.p * kk.cd + d.q * kk.sd);
        let d2 = &pre.d2[k];
        f2 += e * (d2.p * kk.cd + d2.q * kk.sd);
        let r = pre.rd[k] * e;
        bdec += s.wn2[k] * r;
        b3dec += s.wn3[k] * r;
        rsum += r;
    }
    let eps_n = 8.0 * f64::EPSILON * (g.n as f64 + 1.0);
    let lo = f - pre.rf0 - eps_n * (g.f0.abs() + pre.shift.abs() + rsum + pre.rf0 + f.abs());
    // (A NaN fails the test as well.)
    if lo.is_nan() || lo <= 0.5 * pre.rf0 {
        // Approaching (or undecided): the event may be near, the full evaluation takes over.
        return Err(f1.is_nan() || f1 <= 0.0);
    }
    let b = (pre.bconst + bdec) * MARGIN;
    let h2 = quad_step(lo, f1, b);
    // The cubic proof on the slow part (as in `eval`), with `lo` for its value.
    let f2_lo = f2 - eps_n * b;
    let h_model = if f2_lo < 0.0 {
        quad_step(lo, f1, -f2_lo)
    } else if f1 < 0.0 && f1 * f1 >= 2.0 * f2_lo * lo {
        2.0 * lo / (-f1 + (f1 * f1 - 2.0 * f2_lo * lo).sqrt())
    } else {
        f64::INFINITY
    };
    let big_h = (1.1 * h_model).min(8.0 * h2);
    let mut hi = h2;
    if big_h.is_finite() && big_h > h2 {
        let mut b3 = (pre.b3const + b3dec) * MARGIN;
        if let Some(env) = s.env.filter(|_| s.env_slow) {
            let (be, b3e) = env_bounds(&env, env.z23(g, tr), s, tr, pre, b, b3, big_h);
            hi = improve(hi, lo, f1, be, big_h);
            b3 = b3.min(b3e);
        }
        let b_eff = b3 * big_h / 3.0 - f2_lo;
        if b_eff >= 0.0 {
            hi = improve(hi, lo, f1, b_eff, big_h);
        } else {
            // A convex lower bound (as in `eval`): also the polynomial's rounding off.
            let lo_c = lo - eps_n * ((tau * (g.c1 + tau * g.c2)).abs() + pre.rh);
            if lo_c > 0.0 {
                hi = hi.max(quad_step_signed(lo_c, f1, b_eff).min(big_h));
            }
        }
    }
    Ok(hi.max(prev))
}

/// The `|g''|` and `|g'''|` bounds `b`, `b3` (amplitudes, valid everywhere) with the pair of
/// the harmonic and the envelope's term replaced by their envelope at `τ` plus its drift over
/// `[τ, τ + H]` (module docs, the slow beat): valid on `[τ, τ + H]` only. `b` and `b3` contain
/// that pair's amplitudes `Ω²|Ĥ| + |λₖ|²|D̂ₖ|e^{−αₖτ}` (resp. third powers), which are taken off
/// with a rounding margin of `8ε` times the bound.
#[inline]
#[allow(clippy::too_many_arguments)]
fn env_bounds(
    env: &EnvN,
    (z2, z3): (f64, f64),
    s: &ScratchN,
    tr: &TrigN,
    pre: &Pre,
    b: f64,
    b3: f64,
    big_h: f64,
) -> (f64, f64) {
    let k = env.k;
    let rk = pre.rd[k] * (1.0 + tr.k[k].em1);
    let (wn2, wn3) = (s.wn2[k], s.wn3[k]);
    let pair2 = (env.om2 * pre.rh + wn2 * rk) * MARGIN;
    let pair3 = (env.om3 * pre.rh + wn3 * rk) * MARGIN;
    let drift = rk * env.rate * big_h;
    let be = b - pair2 + (z2 + wn2 * drift) * MARGIN + 8.0 * f64::EPSILON * b;
    let b3e = b3 - pair3 + (z3 + wn3 * drift) * MARGIN + 8.0 * f64::EPSILON * b3;
    (be.max(0.0), b3e.max(0.0))
}

/// One evaluation of function `i` at `τ` (transcendentals in `s.trig`): `Err(root)`, or its
/// proven step (at least `prev`, an earlier proof) and whether its zero is bracketed to the
/// time resolution just after it.
#[inline]
fn eval(
    c: &CandN,
    i: usize,
    s: &mut ScratchN,
    tau: f64,
    prev: f64,
    t_max: f64,
    tol_t: f64,
) -> Result<(f64, bool), Root> {
    let g = &c.g;
    let tr = &s.trig;
    let pre = &s.pre[i];
    let n = g.n;
    let mut f = g.f0 + tau * (g.c1 + tau * g.c2) + g.a * tr.chm1 + g.b * tr.sh;
    let mut f1 = g.c1 + 2.0 * g.c2 * tau + g.om * (g.b * tr.ch - g.a * tr.sh);
    let om2 = g.om * g.om;
    let mut f2 = 2.0 * g.c2 - om2 * (g.a * tr.ch + g.b * tr.sh);
    let mut bdec = 0.0;
    let mut b3dec = 0.0;
    let mut rsum = 0.0;
    for k in 0..n {
        let kk = &tr.k[k];
        let t = &g.t[k];
        let e = 1.0 + kk.em1;
        f += t.p * (kk.em1 * kk.cd + kk.cdm1) + t.q * e * kk.sd;
        let d = &pre.d1[k];
        let v1 = e * (d.p * kk.cd + d.q * kk.sd);
        f1 += v1;
        let d2 = &pre.d2[k];
        f2 += e * (d2.p * kk.cd + d2.q * kk.sd);
        let r = pre.rd[k] * e;
        s.v[k] = e * (t.p * kk.cd + t.q * kk.sd);
        s.v1[k] = v1;
        s.r[k] = r;
        bdec += s.wn2[k] * r;
        b3dec += s.wn3[k] * r;
        rsum += r;
    }
    if f <= c.tol && f1 <= 0.0 {
        return Err(Root::At(tau));
    }
    let f = f.max(0.0);
    let b_full = (pre.bconst + bdec) * MARGIN;
    let mut hi = quad_step(f, f1, b_full);
    // Fast terms set aside, fastest first (module docs).
    let eps_n = 8.0 * f64::EPSILON * (n as f64 + 1.0);
    let (mut fs, mut f1s, mut bs, mut rf) = (f, f1, b_full, 0.0);
    let mag = f + rsum;
    // The slow beat on each split while its term is slow (module docs): the pair's amplitudes
    // `pair2` replaced by `|Z₂(τ)|` plus the drift `dr·H` over the split's horizon
    // `H = 8h` (`h` the split's amplitude step); the step so proven is capped at `H`.
    let z23 = s.env.map(|env| env.z23(g, tr));
    let mut envs = s.env.zip(z23).map(|(env, (z2, _))| {
        let k = env.k;
        let wn2 = s.wn2[k];
        let pair2 = (env.om2 * pre.rh + wn2 * s.r[k]) * MARGIN;
        (k, pair2, z2, wn2 * s.r[k] * env.rate)
    });
    for &k in &s.order[..n] {
        fs -= s.v[k];
        f1s -= s.v1[k];
        bs -= s.wn2[k] * s.r[k];
        rf += s.r[k];
        let lo = fs - rf - eps_n * mag;
        if lo <= 0.0 {
            break;
        }
        let bb = bs.max(0.0) + eps_n * b_full;
        if envs.is_some_and(|e| e.0 == k) {
            // The envelope's term is set aside from here on: no pair left in `bs`.
            envs = None;
        }
        if let Some((_, pair2, z2, dr)) = envs {
            let hs = quad_step(lo, f1s, bb);
            hi = hi.max(hs);
            if hs.is_finite() {
                let big_hs = 8.0 * hs;
                let be = bs - pair2
                    + (z2 + dr * big_hs) * MARGIN
                    + (eps_n + 8.0 * f64::EPSILON) * b_full;
                hi = improve(hi, lo, f1s, be.max(0.0), big_hs);
            }
        } else {
            hi = improve(hi, lo, f1s, bb, f64::INFINITY);
        }
    }
    // The cubic proof within a horizon H (the lumped search's): with B₃ ≥ |g'''|,
    // g(τ+h) ≥ g + g'h + (g''/2 − B₃H/6)h² for h ≤ H; H a little beyond the zero of the local
    // quadratic model, so that near a root the steps are Newton-like. `f2` carries a rounding
    // of a few ε times the `g''` bound: that margin is taken off.
    let f2_lo = f2 - eps_n * b_full;
    let h_model = if f2_lo < 0.0 {
        quad_step(f, f1, -f2_lo)
    } else if f1 < 0.0 && f1 * f1 >= 2.0 * f2_lo * f {
        2.0 * f / (-f1 + (f1 * f1 - 2.0 * f2_lo * f).sqrt())
    } else {
        f64::INFINITY
    };
    let big_h = (1.1 * h_model).min(8.0 * hi);
    let mut c_up = f64::INFINITY;
    if big_h.is_finite() && big_h > hi {
        let mut b3 = (pre.b3const + b3dec) * MARGIN;
        if let (Some(env), Some(z)) = (s.env, z23) {
            let (be, b3e) = env_bounds(&env, z, s, tr, pre, b_full, b3, big_h);
            hi = improve(hi, f, f1, be, big_h);
            b3 = b3.min(b3e);
        }
        c_up = 0.5 * (f2 + eps_n * b_full) + b3 * big_h / 6.0;
        let b_eff = b3 * big_h / 3.0 - f2_lo;
        if b_eff >= 0.0 {
            hi = improve(hi, f, f1, b_eff, big_h);
        } else {
            // A convex lower bound: its smaller root, from the value less its rounding (near
            // a double root the discriminant is all rounding).
            let lo = f - eps_n * (mag + g.f0.abs() + (tau * (g.c1 + tau * g.c2)).abs() + pre.rh);
            if lo > 0.0 {
                hi = hi.max(quad_step_signed(lo, f1, b_eff).min(big_h));
            }
        }
    }
    let hi = hi.max(prev);
    let mut bracketed = false;
    // (A convex upper bound's zero is beyond Newton's step f/|f1|: short of it by more than the
    // time resolution, the step cannot end at a bracket; the square roots are skipped.)
    if f1 < 0.0 && hi <= tol_t {
        return Err(Root::At(tau));
    }
    if f1 < 0.0 && (c_up < 0.0 || hi >= (f / -f1) * (1.0 - 1e-9) - tol_t) {
        let disc = f1 * f1 - 2.0 * b_full * f;
        if disc >= 0.0 {
            let h_up = 2.0 * f / (-f1 + disc.sqrt());
            bracketed = h_up - hi <= tol_t && tau + hi < t_max;
        }
        // The same with the cubic upper bound g ≤ f + f1 h + c_up h² (valid up to H).
        if !bracketed && c_up.is_finite() {
            let d3 = f1 * f1 - 4.0 * c_up * f;
            if d3 >= 0.0 {
                let h_up3 = 2.0 * f / (-f1 + d3.sqrt());
                bracketed = h_up3 <= big_h && h_up3 - hi <= tol_t && tau + hi < t_max;
            }
        }
    }
    Ok((hi, bracketed))
}

#[cfg(test)]
mod tests {
    use super::*;

    fn poly(f0: f64, c1: f64, c2: f64) -> ExpSumN {
        let mut g = ExpSumN::zero(1.0);
        g.f0 = f0;
        g.k0 = f0;
        g.c1 = c1;
        g.c2 = c2;
        g
    }

    fn root(g: &ExpSumN, order: usize) -> Root {
        let c = [CandN {
            g: *g,
            order,
            tol: 1e-15,
        }];
        first_root_n(&c, 0.0, 10.0, 0.0, &mut ScratchN::default()).0
    }

    #[test]
    fn parabola_roots_touches_and_near_misses() {
        match root(&poly(1.0, 0.0, -1.0), 0) {
            Root::At(t) => assert!((t - 1.0).abs() < 1e-14, "{t}"),
            r => panic!("{r:?}"),
        }
        match root(&poly(1.0, -2.0, 1.0), 0) {
            Root::At(t) => assert!((t - 1.0).abs() < 1e-7, "{t}"),
            r => panic!("{r:?}"),
        }
        assert_eq!(root(&poly(1.0 + 1e-12, -2.0, 1.0), 0), Root::None);
        // Departure from a zero with round-off in g'(0) < 0: clamped, returns at τ = 2.
        match root(&poly(1e-18, 1.0, -0.5), 1) {
            Root::At(t) => assert!((t - 2.0).abs() < 1e-12, "{t}"),
            r => panic!("{r:?}"),
        }
    }

    /// A fast small wiggle far from the root does not slow the search, and a fast wiggle that
    /// makes the crossing is not missed.
    #[test]
    fn fast_terms_are_set_aside_only_where_they_cannot_cross() {
        // 1 − τ²/4 + 1e-6 sin(1e4 τ): root near 2.
        let mut g = poly(1.0, 0.0, -0.25);
        g.n = 1;
        g.t[0] = Term {
            al: 0.0,
            wd: 1e4,
            p: 0.0,
            q: 1e-6,
        };
        let c = [CandN {
            g,
            order: 0,
            tol: 1e-15,
        }];
        let mut s = ScratchN::default();
        let (r, _) = first_root_n(&c, 0.0, 10.0, 0.0, &mut s);
        let Root::At(t) = r else { panic!("{r:?}") };
        assert!(g.value(t).abs() < 1e-12, "{t}");
        // Dense check that no earlier zero exists.
        for i in 0..200_000 {
            let x = t * i as f64 / 200_000.0;
            assert!(g.value(x) > 0.0, "{x}");
        }
        eprintln!("steps with a 1e4 rad/s wiggle: {}", s.steps);
        assert!(s.steps < 200, "{} steps", s.steps);
        // 0.5e-6 + 1e-6 sin(1e4 τ) − small drift: the wiggle itself crosses early (τ ≈ 3.7e-4).
        let mut h = poly(0.5e-6, -1e-9, 0.0);
        h.n = 1;
        h.t[0] = Term {
            al: 0.0,
            wd: 1e4,
            p: 0.0,
            q: -1e-6,
        };
        let c = [CandN {
            g: h,
            order: 0,
            tol: 1e-21,
        }];
        let (r, _) = first_root_n(&c, 0.0, 10.0, 0.0, &mut ScratchN::default());
        let Root::At(t) = r else { panic!("{r:?}") };
        let want = (0.5f64).asin() / 1e4;
        assert!((t - want).abs() < 1e-9, "{t} {want}");
    }

    /// The slow-beat envelope (module docs) on random sums built to beat: a harmonic and a term
    /// near its frequency that nearly cancel, fast ringing terms, and a constant set so that the
    /// minimum over the interval is just below, at or just above zero (crossings, near touches
    /// and near misses). The search with the envelope must find exactly what the search
    /// without it finds (the same root, or none), and nothing earlier than a dense scan.
    #[test]
    fn envelope_search_finds_every_root_the_amplitude_search_finds() {
        let mut x: u64 = 0x9e37_79b9_7f4a_7c15;
        let mut rnd = move || {
            x = x
                .wrapping_mul(6_364_136_223_846_793_005)
                .wrapping_add(1_442_695_040_888_963_407);
            (x >> 11) as f64 / (1u64 << 53) as f64
        };
        let (mut roots, mut nones, mut fewer_steps) = (0, 0, 0);
        let (mut steps_env, mut steps_ref) = (0u64, 0u64);
        for case in 0..400 {
            let om = 1.0;
            let mut g = ExpSumN::zero(om);
            g.a = 2.0 * rnd() - 1.0;
            g.b = 2.0 * rnd() - 1.0;
            // The beating term: near Ω, lightly damped, nearly cancelling the harmonic.
            // (Alternately close to resonance and farther, with a deeper cancellation.)
            let (detune, damp, cancel) = if case % 2 == 0 {
                (0.02, 0.02, 0.05)
            } else {
                (0.1, 0.05, 0.01)
            };
            let wd = om * (1.0 + detune * (2.0 * rnd() - 1.0));
            let al = damp * rnd();
            let c = 1.0 + cancel * (2.0 * rnd() - 1.0);
            g.t[0] = Term {
                al,
                wd,
                p: -c * g.a,
                q: -c * g.b * om / wd,
            };
            g.n = 1 + (case / 3) % 4;
            for k in 1..g.n {
                g.t[k] = Term {
                    al: 0.05 * rnd(),
                    wd: 3.0 + 30.0 * rnd(),
                    p: 0.02 * (2.0 * rnd() - 1.0),
                    q: 0.02 * (2.0 * rnd() - 1.0),
                };
            }
            g.c1 = 0.002 * (2.0 * rnd() - 1.0);
            g.c2 = -0.0002 * rnd();
            let t_max = 30.0;
            // The dense minimum, and the constant that puts it at `dip` (negative: a crossing).
            let (n_scan, mut lo) = (30_000, f64::INFINITY);
            g.f0 = 0.0;
            g.k0 = 0.0;
            for i in 0..=n_scan {
                lo = lo.min(g.value(t_max * i as f64 / n_scan as f64));
            }
            let dip = [-1e-3, -1e-6, -1e-9, 1e-9, 1e-6, 1e-3][(case / 2) % 6] * (0.5 + rnd());
            // (g(0) = f0 > 0: a minimum at the start is not the case looked for.)
            g.f0 = -lo + dip;
            if g.f0 <= 1e-3 {
                continue;
            }
            let cands = [CandN {
                g,
                order: 0,
                tol: 1e-15,
            }];
            let mut s_env = ScratchN::default();
            let mut s_ref = ScratchN {
                env_off: true,
                ..ScratchN::default()
            };
            let (r_env, _) = first_root_n(&cands, 0.0, t_max, 1e-15, &mut s_env);
            let (r_ref, _) = first_root_n(&cands, 0.0, t_max, 1e-15, &mut s_ref);
            steps_env += s_env.steps;
            steps_ref += s_ref.steps;
            if s_env.steps < s_ref.steps {
                fewer_steps += 1;
            }
            match (r_env, r_ref) {
                (Root::At(a), Root::At(b)) => {
                    // The same zero: a crossing to the time resolution, a touch to the width
                    // its tolerance allows.
                    let tol = if dip.abs() < 1e-8 { 1e-3 } else { 1e-6 };
                    assert!(
                        (a - b).abs() <= tol,
                        "case {case}: {a} vs {b} (dip {dip:e})"
                    );
                    // Nothing earlier on a dense scan.
                    for i in 0..n_scan {
                        let t = a * i as f64 / n_scan as f64;
                        assert!(g.value(t) > -1e-12, "case {case}: g({t}) < 0 before {a}");
                    }
                    roots += 1;
                }
                (Root::None, Root::None) => {
                    assert!(
                        dip > 0.0,
                        "case {case}: a crossing of {dip:e} missed by both"
                    );
                    nones += 1;
                }
                (a, b) => panic!("case {case}: envelope {a:?} vs amplitude {b:?} (dip {dip:e})"),
            }
        }
        eprintln!(
            "envelope: {roots} roots, {nones} none; steps {steps_env} vs {steps_ref} without              ({fewer_steps} searches shorter)"
        );
        assert!(roots > 50 && nones > 50, "{roots} {nones}");
        // The envelope is what makes these searches short (else the test tests nothing).
        assert!(4 * steps_env < 3 * steps_ref, "{steps_env} {steps_ref}");
    }

    /// Bursts of close roots (module docs, where the as-published beam spends its time): a slow
    /// part whose minimum is near zero and fast, lightly damped ringing terms of an amplitude
    /// comparable to its dip, so that the ringing crosses zero again and again; the slow part's
    /// minimum set just below, at or just above zero (crossings, near touches, near misses),
    /// also with a harmonic at resonance with a slow term (the slow beat). Every search, from
    /// the start and from a departure at a known zero, is checked against a brute-force
    /// reference: dense sampling, then bisection of the first sign change. The search's root
    /// is never past the reference's, nothing before it is negative on the dense grid, and at
    /// the root the function is within 1e-9 of the scale of zero (a near touch may stop there);
    /// no search may miss a root where the dense grid sees a negative value.
    #[test]
    // (The grid index also gives the sample's time.)
    #[allow(clippy::needless_range_loop)]
    fn bursts_of_close_roots_match_dense_sampling_and_bisection() {
        let mut x: u64 = 0x2545_f491_4f6c_dd1d;
        let mut rnd = move || {
            x = x
                .wrapping_mul(6_364_136_223_846_793_005)
                .wrapping_add(1_442_695_040_888_963_407);
            (x >> 11) as f64 / (1u64 << 53) as f64
        };
        let (mut roots, mut nones, mut departures, mut earlier) = (0, 0, 0, 0);
        let mut steps = 0u64;
        let mut dense = Vec::new();
        for case in 0..600 {
            let om = 1.0;
            let mut g = ExpSumN::zero(om);
            // Slow part: a parabola with its minimum inside [0, t_max], a harmonic, and (every
            // other case) a slow term beating against the harmonic.
            let t_max = 20.0;
            let tm = t_max * (0.2 + 0.6 * rnd());
            let c2 = 0.01 + 0.02 * rnd();
            g.c2 = c2;
            g.c1 = -2.0 * c2 * tm;
            g.a = 0.1 * (2.0 * rnd() - 1.0);
            g.b = 0.1 * (2.0 * rnd() - 1.0);
            let mut n = 0;
            if case % 2 == 0 {
                let wd = om * (1.0 + 0.02 * (2.0 * rnd() - 1.0));
                let c = 1.0 + 0.05 * (2.0 * rnd() - 1.0);
                g.t[0] = Term {
                    al: 0.02 * rnd(),
                    wd,
                    p: -c * g.a,
                    q: -c * g.b * om / wd,
                };
                n = 1;
            }
            // Fast ringing: 1 to 3 terms, the fastest at 20–200 rad/s, amplitudes of the order
            // of the dip the parabola makes within a few of their periods of its minimum.
            let n_fast = 1 + (case / 2) % 3;
            let amp = 0.02 * (0.2 + rnd());
            for j in 0..n_fast {
                let wd = (20.0 + 180.0 * rnd()) / (1.0 + 2.0 * j as f64);
                let ph = std::f64::consts::TAU * rnd();
                let a = amp * (0.3 + 0.7 * rnd()) / (1.0 + j as f64);
                g.t[n] = Term {
                    al: 0.05 * rnd(),
                    wd,
                    p: a * ph.cos(),
                    q: a * ph.sin(),
                };
                n += 1;
            }
            g.n = n;
            let n_scan = 100_000;
            let grid = |i: usize| t_max * i as f64 / n_scan as f64;
            g.f0 = 0.0;
            g.k0 = 0.0;
            // The grid's increments once (`g.value(t) = f0 + increment`, the same bits as
            // `dense[i]` plus `f0` below).
            dense.clear();
            dense.extend((0..=n_scan).map(|i| g.value(grid(i))));
            let lo = dense.iter().fold(f64::INFINITY, |a, &b| a.min(b));
            let dip =
                [-1e-2, -1e-4, -1e-7, -1e-10, 1e-10, 1e-7, 1e-4][(case / 6) % 7] * (0.5 + rnd());
            g.f0 = -lo + dip;
            if g.f0 <= 1e-3 {
                continue;
            }
            // A search from the start, and (every third case) one departing from a zero: the
            // function shifted so that it vanishes at `t0` with `g' > 0` there.
            let mut t0 = 0.0;
            let mut order = 0;
            if case % 3 == 0 {
                // The first upward crossing of the reference after the first root, if any.
                let mut i0 = None;
                let mut below = false;
                for i in 0..=n_scan {
                    let v = g.f0 + dense[i];
                    if v < 0.0 {
                        below = true;
                    } else if below {
                        i0 = Some(i);
                        break;
                    }
                }
                if let Some(i) = i0 {
                    let (mut a, mut b) = (grid(i - 1), grid(i));
                    for _ in 0..200 {
                        let m = 0.5 * (a + b);
                        if g.value(m) < 0.0 {
                            a = m;
                        } else {
                            b = m;
                        }
                    }
                    // The search departs from `b` with order 1 (`g(b)` is zero to rounding,
                    // `g' > 0`), as after a friction switch.
                    t0 = b;
                    order = 1;
                    departures += 1;
                }
            }
            let cands = [CandN {
                g,
                order,
                tol: 1e-15,
            }];
            let mut s = ScratchN::default();
            let (r, _) = first_root_n(&cands, t0, t_max, 1e-15, &mut s);
            steps += s.steps;
            // The reference: the first dense sample below zero after the start's own zero
            // (departures skip the first 1e-9), bisected.
            let i_start = ((t0 + 1e-9) / t_max * n_scan as f64).ceil() as usize;
            let mut reference = None;
            for i in i_start.max(1)..=n_scan {
                if g.f0 + dense[i] < 0.0 {
                    let (mut a, mut b) = (grid(i - 1).max(t0 + 1e-9), grid(i));
                    for _ in 0..200 {
                        let m = 0.5 * (a + b);
                        if g.value(m) < 0.0 {
                            b = m;
                        } else {
                            a = m;
                        }
                    }
                    reference = Some(a);
                    break;
                }
            }
            let scale = g.f0.abs() + 1.0;
            match (r, reference) {
                (Root::At(t), reference) => {
                    assert!(t >= t0, "case {case}: root {t} before the start {t0}");
                    if let Some(rf) = reference {
                        // Past it only within the function's tolerance and rounding (the
                        // stop rule `g ≤ tol`, and the reference's own rounding), where a
                        // near touch's crossing is flat.
                        let v = g.value(t);
                        assert!(
                            t <= rf + 1e-12 || v.abs() <= 1e-15 + 4.0 * f64::EPSILON * scale,
                            "case {case}: root {t} past the reference's {rf}, g = {v:e} \
                             (dip {dip:e})"
                        );
                        if t < rf - 1e-9 {
                            earlier += 1;
                        }
                    }
                    // Nothing negative before it on the dense grid.
                    for i in i_start..n_scan {
                        let ti = grid(i);
                        if ti >= t {
                            break;
                        }
                        assert!(
                            g.f0 + dense[i] > -1e-12 * scale,
                            "case {case}: g({ti}) < 0 before the root {t}"
                        );
                    }
                    // A zero (or a touch to the tolerance) at the root.
                    let v = g.value(t);
                    assert!(
                        v.abs() <= 1e-9 * scale,
                        "case {case}: g({t}) = {v:e} at the root (dip {dip:e})"
                    );
                    roots += 1;
                }
                (Root::None, None) => nones += 1,
                (Root::None, Some(rf)) => {
                    let v = g.value(rf);
                    panic!("case {case}: missed the reference root {rf} (g = {v:e}, dip {dip:e})");
                }
                (Root::Horizon(t), _) => panic!("case {case}: horizon at {t}"),
            }
        }
        eprintln!(
            "bursts: {roots} roots ({earlier} before the dense reference), {nones} none, \
             {departures} departures, {steps} steps"
        );
        assert!(
            roots > 200 && nones > 50 && departures > 50,
            "{roots} {nones} {departures}"
        );
    }
}
