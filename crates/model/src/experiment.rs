//! Commands for the paper's model experiment (Section V): a relaxed reference pose, one pose
//! articulated toward each tendon (to register the model frame), then poses filling the
//! workspace, each found by the minimum-norm inverse with enough proximal compression that no
//! tendon goes slack.

use std::f64::consts::TAU;

use nalgebra::{DVector, Vector4};

use crate::{Model, ModelError};

/// What an experiment pose is for.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum Role {
    /// All displacements zero: the origin of the proximal compression.
    Reference,
    /// Articulated toward one tendon: registers the model frame's orientation.
    Register,
    /// A data point.
    Pose,
}

/// One commanded pose.
#[derive(Debug, Clone, PartialEq)]
pub struct CommandedPose {
    /// Tendon displacements, mm.
    pub y: DVector<f64>,
    /// The configuration the model gives for `y` (the truth when the model is the rig).
    pub q: Vector4<f64>,
    /// Its role.
    pub role: Role,
}

/// How the experiment fills the workspace.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct ExperimentPlan {
    /// Data poses (the paper used 26).
    pub poses: usize,
    /// Largest bending angle `κ·L1`, radians.
    pub max_bend_angle: f64,
    /// Bending angle of the registration poses, radians.
    pub register_bend_angle: f64,
    /// Proximal compression `ε0` asked of every loaded pose (raised where a tendon would go
    /// slack): the preload that keeps all tendons taut.
    pub preload_strain: f64,
}

impl Default for ExperimentPlan {
    fn default() -> Self {
        ExperimentPlan {
            poses: 26,
            max_bend_angle: 150f64.to_radians(),
            register_bend_angle: 90f64.to_radians(),
            preload_strain: 0.004,
        }
    }
}

/// The commands: reference, one registration pose per tendon, then `plan.poses` poses with
/// area-uniform bending angles up to the maximum and bending planes turning by the golden
/// angle.
pub fn experiment(model: &Model, plan: &ExperimentPlan) -> Result<Vec<CommandedPose>, ModelError> {
    let p = model.params();
    let n = p.tendons.len();
    let mut out = vec![CommandedPose {
        y: DVector::zeros(n),
        q: Vector4::zeros(),
        role: Role::Reference,
    }];
    let km = p.stiffness.diagonal();
    let l1 = p.distal_length;
    for t in &p.tendons {
        // Pulling one tendon bends about its moment axis, scaled by the bending stiffnesses.
        let (mx, mz) = (t.dz / km[0], -t.dx / km[1]);
        let norm = mx.hypot(mz);
        let k = plan.register_bend_angle / l1;
        out.push(CommandedPose {
            role: Role::Register,
            ..taut_command(model, [k * mx / norm, k * mz / norm], plan.preload_strain)?
        });
    }
    let golden = TAU * (1.0 - (5f64.sqrt() - 1.0) / 2.0);
    for i in 0..plan.poses {
        let u = (i as f64 + 0.5) / plan.poses as f64;
        let k = plan.max_bend_angle * u.sqrt() / l1;
        let phi = golden * i as f64;
        out.push(taut_command(
            model,
            [k * phi.cos(), k * phi.sin()],
            plan.preload_strain,
        )?);
    }
    Ok(out)
}

/// The minimum-norm command for curvatures `kappa` (1/mm) at proximal compression `eps0`,
/// raising `eps0` by half each time until no tendon is slack. Its role is [`Role::Pose`].
pub fn taut_command(
    model: &Model,
    kappa: [f64; 2],
    eps0: f64,
) -> Result<CommandedPose, ModelError> {
    let mut eps0 = eps0.max(1e-5);
    for _ in 0..40 {
        let y = model.inverse(&Vector4::new(kappa[0], kappa[1], eps0, 0.0))?;
        let f = model.forward(&y)?;
        if f.slack.is_empty() && f.tensions.iter().all(|t| *t > 0.0) {
            return Ok(CommandedPose {
                y,
                q: f.q,
                role: Role::Pose,
            });
        }
        eps0 *= 1.5;
    }
    Err(ModelError::NoTautSet)
}

/// A continuous sweep of the workspace in time, as the demo drives the catheter: the bending
/// plane turns steadily while the bending angle swings between straight and the maximum.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct Sweep {
    /// Largest bending angle `κ·L1`, radians.
    pub max_bend_angle: f64,
    /// Seconds from straight to fully bent and back.
    pub bend_period: f64,
    /// Seconds per turn of the bending plane.
    pub turn_period: f64,
    /// Proximal compression asked of every pose (raised where a tendon would go slack).
    pub preload_strain: f64,
}

impl Default for Sweep {
    fn default() -> Self {
        Sweep {
            max_bend_angle: 120f64.to_radians(),
            bend_period: 4.0,
            turn_period: 11.0,
            preload_strain: 0.004,
        }
    }
}

impl Sweep {
    /// The command at time `t` seconds into the sweep.
    pub fn command(&self, model: &Model, t: f64) -> Result<CommandedPose, ModelError> {
        let swing = 0.5 - 0.5 * (TAU * t / self.bend_period).cos();
        let k = self.max_bend_angle * swing / model.params().distal_length;
        let phi = TAU * t / self.turn_period;
        taut_command(model, [k * phi.cos(), k * phi.sin()], self.preload_strain)
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::ManipulatorParams;

    #[test]
    fn the_sweep_is_taut_continuous_and_covers_the_workspace() {
        let m = Model::new(ManipulatorParams::paper_like()).unwrap();
        let sweep = Sweep::default();
        let l1 = m.params().distal_length;
        let (mut largest, mut planes) = (0.0f64, Vec::new());
        let mut previous: Option<Vector4<f64>> = None;
        for i in 0..=300 {
            let t = i as f64 * 0.04;
            let c = sweep.command(&m, t).unwrap();
            assert!(m.forward(&c.y).unwrap().slack.is_empty(), "t = {t}");
            let bend = c.q[0].hypot(c.q[1]) * l1;
            largest = largest.max(bend);
            if bend > 0.5 {
                planes.push(c.q[1].atan2(c.q[0]));
            }
            // 40 ms apart, the curvature moves by a small step (no jumps between frames).
            if let Some(p) = previous {
                let step = ((c.q[0] - p[0]).hypot(c.q[1] - p[1])) * l1;
                assert!(step < 0.12, "t = {t}: the bend jumps by {step:.3} rad");
            }
            previous = Some(c.q);
        }
        assert!((largest - sweep.max_bend_angle).abs() < 0.02, "{largest}");
        // The bending plane goes all the way round within the 12 s.
        let mut sorted = planes.clone();
        sorted.sort_by(f64::total_cmp);
        let widest_gap = sorted
            .windows(2)
            .map(|w| w[1] - w[0])
            .fold(TAU - (sorted[sorted.len() - 1] - sorted[0]), f64::max);
        assert!(
            widest_gap < 0.8,
            "bending planes leave a gap of {widest_gap:.2} rad"
        );
    }

    #[test]
    fn every_loaded_pose_is_taut_and_bends_as_asked() {
        let m = Model::new(ManipulatorParams::paper_like()).unwrap();
        let plan = ExperimentPlan::default();
        let poses = experiment(&m, &plan).unwrap();
        assert_eq!(poses.len(), 1 + 4 + plan.poses);
        assert_eq!(poses[0].role, Role::Reference);
        assert!(poses[0].y.iter().all(|v| *v == 0.0));
        let l1 = m.params().distal_length;
        let mut largest: f64 = 0.0;
        for p in &poses[1..] {
            let f = m.forward(&p.y).unwrap();
            assert!(f.slack.is_empty());
            assert!(f.q[2] >= plan.preload_strain * 0.999, "{}", f.q[2]);
            largest = largest.max(f.q[0].hypot(f.q[1]) * l1);
        }
        assert!((largest - plan.max_bend_angle).abs() < 0.1, "{largest}");
        // The registration poses bend toward their tendons: tendon 0 at +x bends toward +x,
        // i.e. κz < 0 (κz bends toward −x).
        let r0 = &poses[1];
        assert!(r0.q[1] < 0.0 && r0.q[0].abs() < 1e-9, "{:?}", r0.q);
    }
}
