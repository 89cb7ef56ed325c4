//! The model's algebra: forward/inverse consistency, tensions, slack tendons, estimation.

use flexshape_model::{
    ManipulatorParams, Model, ModelError, Observation, Tendon, estimate_stiffness, geometry,
};
use nalgebra::{DVector, Vector4};
use rand::rngs::Xoshiro256PlusPlus;
use rand::{RngExt, SeedableRng};
use rand_distr::{Distribution, Normal};

fn model() -> Model {
    Model::new(ManipulatorParams::paper_like()).unwrap()
}

#[test]
fn inverse_reproduces_the_pruned_configuration_and_tensions_match_cm() {
    let m = model();
    let a = m.forward_matrix().unwrap();
    let cm = m.compliance();
    let mut rng = Xoshiro256PlusPlus::seed_from_u64(1);
    for _ in 0..100 {
        let q = Vector4::new(
            rng.random_range(-0.02..0.02),
            rng.random_range(-0.02..0.02),
            rng.random_range(0.0005..0.003),
            0.0,
        );
        let y = m.inverse(&q).unwrap();
        let back = &a * &y;
        for j in 0..3 {
            assert!(
                (back[j] - q[j]).abs() < 1e-12 * (1.0 + q[j].abs() * 1e3),
                "{back} vs {q}"
            );
        }
        // ε1 follows ε0 by the axial stiffness ratio (the pruned row is dependent).
        let p = m.params().stiffness;
        assert!((back[3] - back[2] * p.ka0 / p.ka1).abs() < 1e-12);
        // y = Cm τ, and Km q = D τ.
        let tau = m.tensions(&y).unwrap();
        assert!((&cm * &tau - &y).amax() < 1e-9);
        let km_q = Vector4::from(p.diagonal())
            .component_mul(&Vector4::new(back[0], back[1], back[2], back[3]));
        assert!((km_q - m.moment_arms() * &tau).amax() < 1e-9);
    }
}

#[test]
fn slack_tendons_never_carry_negative_tension() {
    let m = model();
    let mut rng = Xoshiro256PlusPlus::seed_from_u64(2);
    let mut slack_seen = 0;
    for _ in 0..500 {
        let y = DVector::from_fn(4, |_, _| rng.random_range(-3.0..6.0));
        let f = m.forward(&y).unwrap();
        assert!(f.tensions.iter().all(|&t| t >= 0.0), "{}", f.tensions);
        for &i in &f.slack {
            assert_eq!(f.tensions[i], 0.0);
        }
        slack_seen += f.slack.len();
        // Taut tendons obey their spring law: y_i = (Dᵀ L0 q)_i + Lt_i/Kt_i τ_i.
        let p = m.params();
        let l = Vector4::new(
            p.distal_length,
            p.distal_length,
            p.proximal_length,
            p.distal_length,
        );
        let path = m.moment_arms().transpose() * l.component_mul(&f.q);
        for i in (0..4).filter(|i| !f.slack.contains(i)) {
            let t = &p.tendons[i];
            assert!((y[i] - path[i] - t.length / t.stiffness * f.tensions[i]).abs() < 1e-9);
        }
        // Slack ones are not stretched.
        for &i in &f.slack {
            assert!(y[i] <= path[i] + 1e-9);
        }
    }
    assert!(
        slack_seen > 100,
        "the sample should exercise slack tendons ({slack_seen})"
    );
    // All taut when every tension is positive: the plain linear map.
    let y = m.inverse(&Vector4::new(0.01, 0.0, 0.002, 0.0)).unwrap();
    let f = m.forward(&y).unwrap();
    assert!(f.slack.is_empty());
    assert!((f.q - (m.forward_matrix().unwrap() * &y).fixed_rows::<4>(0)).amax() < 1e-12);
}

fn observations(m: &Model, n: usize, rng: &mut Xoshiro256PlusPlus) -> Vec<Observation> {
    (0..n)
        .map(|i| {
            // Bending in every direction with enough compression to keep tendons taut.
            let phi = i as f64 * 2.399;
            let k = 0.004 + 0.016 * rng.random::<f64>();
            let q = Vector4::new(
                k * phi.cos(),
                k * phi.sin(),
                0.006 + 0.004 * rng.random::<f64>(),
                0.0,
            );
            let y = m.inverse(&q).unwrap();
            let f = m.forward(&y).unwrap();
            assert!(
                f.slack.is_empty(),
                "pose {i} has slack tendons: the estimate assumes none"
            );
            Observation::new(f.q, y)
        })
        .collect()
}

#[test]
fn stiffnesses_are_recovered_exactly_and_within_bounds_from_noise() {
    let m = model();
    let truth = m.params().stiffness.diagonal();
    let mut rng = Xoshiro256PlusPlus::seed_from_u64(4);
    let data = observations(&m, 26, &mut rng);
    let e = estimate_stiffness(m.params(), &data).unwrap();
    for (k, t) in e.stiffness.diagonal().iter().zip(truth) {
        assert!((k / t - 1.0).abs() < 1e-9, "{k} vs {t}");
    }
    assert!(e.tip_error_percent < 1e-9);
    // Sensed curvature with 0.3 % noise and strain with 2e-5 absolute (about what the arc fit
    // gives on the simulator for κ; strain is harder): the stiffnesses within 10 %, the tip
    // error under 1 %. The estimate is sensitive: the tendons' stretch (what reveals the
    // tension) is a small difference of large path lengths, so 2 % curvature noise already
    // moves Kx by ~30 % with these parameters.
    let noise = Normal::new(0.0, 1.0).unwrap();
    let noisy: Vec<Observation> = data
        .iter()
        .map(|o| {
            let k = o.q[0].hypot(o.q[1]);
            let mut q = o.q;
            q[0] += 0.003 * k * noise.sample(&mut rng);
            q[1] += 0.003 * k * noise.sample(&mut rng);
            q[2] += 2e-5 * noise.sample(&mut rng);
            q[3] += 2e-5 * noise.sample(&mut rng);
            Observation::new(q, o.y.clone())
        })
        .collect();
    let e = estimate_stiffness(m.params(), &noisy).unwrap();
    let got = e.stiffness.diagonal();
    println!(
        "noisy estimate {got:?} (truth {truth:?}), tip error {:.2} %",
        e.tip_error_percent
    );
    for j in 0..2 {
        assert!(
            (got[j] / truth[j] - 1.0).abs() < 0.05,
            "{j}: {} vs {}",
            got[j],
            truth[j]
        );
    }
    for j in 2..4 {
        assert!(
            (got[j] / truth[j] - 1.0).abs() < 0.15,
            "{j}: {} vs {}",
            got[j],
            truth[j]
        );
    }
    assert!(e.tip_error_percent < 3.0);
}

#[test]
fn bad_input_gets_clear_errors() {
    let mut p = ManipulatorParams::paper_like();
    // Two tendons at the same place and no others: Cm is singular only without tendon stretch,
    // so put all four on one spot with infinite-looking stiffness.
    p.tendons = vec![
        Tendon {
            dx: 1.0,
            dz: 0.0,
            length: 1.0,
            stiffness: 1e18
        };
        4
    ];
    assert!(matches!(
        Model::new(p),
        Err(ModelError::SingularCompliance { .. })
    ));
    let mut p = ManipulatorParams::paper_like();
    p.tendons[2].length = -1.0;
    let e = Model::new(p).unwrap_err().to_string();
    assert!(e.contains("tendons[2].length"), "{e}");
    let m = model();
    assert_eq!(
        m.forward(&DVector::zeros(3)).unwrap_err(),
        ModelError::TendonCount {
            found: 3,
            expected: 4
        }
    );
    // Data that never bend about z cannot give Kz: it is held at its nominal value, with why
    // and what would determine it, and the rest are estimated all the same.
    let y = m.inverse(&Vector4::new(0.01, 0.0, 0.002, 0.0)).unwrap();
    let q = m.forward(&y).unwrap().q;
    let only_x = vec![Observation::new(
        Vector4::new(q[0], 0.0, q[2], q[3]),
        y.clone(),
    )];
    let e = estimate_stiffness(m.params(), &only_x).unwrap();
    assert_eq!(e.estimated, [true, false, true, true]);
    assert_eq!(e.stiffness.kz, m.params().stiffness.kz);
    assert!((e.stiffness.kx / m.params().stiffness.kx - 1.0).abs() < 1e-6);
    assert_eq!(e.held.len(), 1);
    assert_eq!(e.held[0].parameter, "Kz");
    assert!(
        e.held[0]
            .reason
            .contains("no pose exercises bending about z")
    );
    assert!(e.held[0].remedy.contains("z axis"));
    assert!(matches!(
        estimate_stiffness(m.params(), &[]),
        Err(ModelError::Unobservable { .. })
    ));
    let wrong = vec![Observation::new(q, DVector::zeros(2))];
    assert!(
        estimate_stiffness(m.params(), &wrong)
            .unwrap_err()
            .to_string()
            .contains("observation 0")
    );
    let _ = geometry::bend_tip(m.params(), &q);
}
