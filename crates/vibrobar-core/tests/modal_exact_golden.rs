//! Golden results of the N-mode exact solver (`ModalExact`) at the code of 172b633 (issue #8
//! merged), pinned before its speed work: every optimisation must keep them bit for bit.
//!
//! Short runs (0.05–0.1 s from rest, so none is chaotic over its length) of the paper's bar as one
//! unit mode (`ModalSystem::from_lumped`) and as a 4- and 8-mode beam, gaps 0.05 and 0.1 mm,
//! friction none / as-published / coulomb, and a three-point beam (force, response and cavity at
//! different places). Each run is reduced to a 64-bit FNV-1a digest over every event's kind, wall
//! and `t_s.to_bits()`, the event and impact counts, the proven search steps, and `∫u²` over the
//! whole run (`to_bits()`).
//!
//! Re-pinned for the speed work of issue #8 §8 (the slow-beat envelope of the N-term search,
//! then the cheap step kept per function): proofs with longer steps, so other step counts and event times that differ at the search's time
//! resolution (first events 1e-16 to 1e-11 relative, the larger ones at touches). Those
//! differences grow by a factor of about 2–3 per impact on the beam runs, as a perturbation of
//! the forcing by 4 ulp grows in the code pinned before (same events, the same growth), so
//! beyond some 10–40 events every beam case here is chaotic at the 1e-12 level; `n1_g0.05_aspub`
//! kept every event time to 2e-15 and ∫u² to 1e-14, `n1_g0.1_none` to 1e-12 up to its 63rd
//! event. The commit message gives the comparison. Then once more for `∫u²` alone (events and
//! steps unchanged): up to a segment's end it takes `e^{λb}` from the transcendentals the
//! search computed there instead of libm's, a change of 1–2e-15 relative.
//!
//! The literals were printed by this very test (`MODAL_GOLDEN_PRINT=1 cargo test --release
//! --test modal_exact_golden -- --nocapture`), not by hand. A change that moves one is a change
//! of the numerics: find out why before touching a literal.
use vibrobar_core::solver::exact::modal::ModalExact;
use vibrobar_core::solver::modal_rk4::ModalObserver;
use vibrobar_core::solver::{Event, EventKind, Observer, Segment, Wall};
use vibrobar_core::structure::{Beam, ModalState, ModalSystem, Structure};
use vibrobar_core::*;

const FNV_OFFSET: u64 = 0xcbf2_9ce4_8422_2325;
const FNV_PRIME: u64 = 0x0000_0100_0000_01b3;

struct Reducer {
    hash: u64,
    events: u64,
    impacts: u64,
    u2: f64,
}

impl Reducer {
    fn bytes(&mut self, b: &[u8]) {
        for &x in b {
            self.hash ^= x as u64;
            self.hash = self.hash.wrapping_mul(FNV_PRIME);
        }
    }
}

fn wall_code(w: Wall) -> u8 {
    match w {
        Wall::Plus => 1,
        Wall::Minus => 2,
    }
}

impl Observer for Reducer {
    fn segment(&mut self, seg: &dyn Segment) {
        self.u2 += seg.integral_u2(seg.t_start_s(), seg.t_end_s());
    }
    fn event(&mut self, ev: &Event) {
        let (kind, wall) = match ev.kind {
            EventKind::Impact { wall, .. } => (1u8, wall_code(wall)),
            EventKind::FrictionSwitch => (2, 0),
            EventKind::Stick => (3, 0),
            EventKind::Unstick => (4, 0),
            EventKind::ChatterLimit { wall, .. } => (5, wall_code(wall)),
            EventKind::ContactRelease { wall } => (6, wall_code(wall)),
        };
        self.bytes(&[kind, wall]);
        self.bytes(&ev.t_s.to_bits().to_le_bytes());
        self.events += 1;
        if kind == 1 {
            self.impacts += 1;
        }
    }
}

impl ModalObserver for Reducer {}

fn beam(n: usize, three_point: bool, gap_m: f64, f: FrictionModel, ratio: f64) -> ModalSystem {
    let sys = System::paper_damped(gap_m, f, ratio);
    let b = if three_point {
        Beam {
            modes: Some(n),
            force_position_m: Some(0.15),
            response_position_m: Some(0.1),
            ..Beam::default()
        }
    } else {
        Beam {
            modes: Some(n),
            ..Beam::default()
        }
    };
    ModalSystem {
        model: Structure::Beam(b).modal_model().unwrap(),
        damper: sys.damper,
        forcing: sys.forcing,
        gravity_m_s2: sys.gravity_m_s2,
    }
}

/// `(name, system, duration s)`, in a fixed order.
fn cases() -> Vec<(&'static str, ModalSystem, f64)> {
    use FrictionModel::*;
    let lumped = |g, f| ModalSystem::from_lumped(&System::paper_damped(g, f, 1.0)).unwrap();
    vec![
        ("n1_g0.1_none", lumped(0.1e-3, None), 0.1),
        ("n1_g0.05_aspub", lumped(0.05e-3, AsPublished), 0.1),
        ("n4_g0.1_none", beam(4, false, 0.1e-3, None, 1.0), 0.1),
        (
            "n4_g0.1_aspub",
            beam(4, false, 0.1e-3, AsPublished, 1.0),
            0.1,
        ),
        (
            "n4_g0.05_coulomb",
            beam(4, false, 0.05e-3, Coulomb, 1.0),
            0.1,
        ),
        (
            "n4_g0.05_aspub_r0.98",
            beam(4, false, 0.05e-3, AsPublished, 0.98),
            0.1,
        ),
        ("n8_g0.1_none", beam(8, false, 0.1e-3, None, 1.0), 0.05),
        (
            "n8_g0.05_aspub",
            beam(8, false, 0.05e-3, AsPublished, 1.0),
            0.05,
        ),
        (
            "n4_3pt_g0.1_aspub",
            beam(4, true, 0.1e-3, AsPublished, 1.0),
            0.1,
        ),
        (
            "n4_3pt_g0.05_coulomb",
            beam(4, true, 0.05e-3, Coulomb, 1.0),
            0.1,
        ),
    ]
}

/// `(name, digest, events, impacts, steps, ∫u².to_bits())`.
#[rustfmt::skip]
const GOLDEN: [(&str, u64, u64, u64, u64, u64); 10] = [
    ("n1_g0.1_none", 0x2704a0075450859a, 87, 87, 542, 0x3dc2d66fec85c572), // ∫u² 3.4265477231070973e-11 m²s
    ("n1_g0.05_aspub", 0x9e890f37cf2120ee, 227, 128, 1081, 0x3dbf60056da390b7), // ∫u² 2.85354716006028e-11 m²s
    ("n4_g0.1_none", 0xc75380c370995f98, 113, 113, 793, 0x3de169abfd7b097f), // ∫u² 1.2669465367472455e-10 m²s
    ("n4_g0.1_aspub", 0x7eb1451705f72685, 214, 110, 1823, 0x3de16fbf6954c750), // ∫u² 1.2686734012777514e-10 m²s
    ("n4_g0.05_coulomb", 0x58ecac65db21e44b, 894, 215, 6134, 0x3ded9294c7332885), // ∫u² 2.1516885807808121e-10 m²s
    ("n4_g0.05_aspub_r0.98", 0x60226bee127599ea, 1366, 428, 7957, 0x3e0367055cd9965e), // ∫u² 5.646849044783052e-10 m²s
    ("n8_g0.1_none", 0x1c0a671342075c2d, 51, 51, 440, 0x3dd63f7b54b7a3a6), // ∫u² 8.093766384482185e-11 m²s
    ("n8_g0.05_aspub", 0x9ea2966db2d175f7, 1108, 211, 8780, 0x3ddc0460873a85ec), // ∫u² 1.0192560841097665e-10 m²s
    ("n4_3pt_g0.1_aspub", 0x34a07c106128a68e, 179, 110, 1178, 0x3dab801a9ef2c142), // ∫u² 1.2505736868920522e-11 m²s
    ("n4_3pt_g0.05_coulomb", 0xcabd501a005dbe1b, 772, 156, 5483, 0x3db9e6859ef4d5d7), // ∫u² 2.3556346053268817e-11 m²s
];

#[test]
fn modal_exact_runs_are_bit_identical_to_the_pinned_ones() {
    let print = std::env::var_os("MODAL_GOLDEN_PRINT").is_some();
    let cs = cases();
    if !print {
        assert_eq!(cs.len(), GOLDEN.len());
    }
    let mut bad = Vec::new();
    for (i, (name, sys, t_end)) in cs.iter().enumerate() {
        let mut r = Reducer {
            hash: FNV_OFFSET,
            events: 0,
            impacts: 0,
            u2: 0.0,
        };
        let (sum, steps) = ModalExact::default()
            .run_counted(sys, &ModalState::REST, *t_end, &mut r)
            .expect("golden run");
        assert_eq!(
            (sum.summary.events, sum.summary.impacts),
            (r.events, r.impacts)
        );
        assert!(r.impacts > 0, "{name}: a golden case must have impacts");
        let got = (*name, r.hash, r.events, r.impacts, steps, r.u2.to_bits());
        if print {
            println!(
                "    (\"{}\", {:#018x}, {}, {}, {}, {:#018x}), // ∫u² {:e} m²s",
                got.0, got.1, got.2, got.3, got.4, got.5, r.u2
            );
        } else if got != GOLDEN[i] {
            bad.push(format!("{got:?} != pinned {:?}", GOLDEN[i]));
        }
    }
    assert!(!print, "printed the table; unset MODAL_GOLDEN_PRINT");
    assert!(bad.is_empty(), "moved golden runs:\n{}", bad.join("\n"));
}
