//! From sensed shapes to the model's configuration (paper, Section V-A): the model frame sits
//! at the bending section's base, found each frame from the proximal band; its orientation is
//! registered once, from poses articulated toward each tendon, and then held fixed.
//!
//! World frame: the rig's (mm). Model frame: origin at the bending base, +y along the
//! proximal section's axis, x and z the axes of κx and κz.

use nalgebra::{DVector, Point3, Rotation3, Vector3, Vector4};

use crate::{Model, ModelError, Observation};

/// What the vision pipeline measured in one frame, world frame.
#[derive(Debug, Clone, PartialEq)]
pub struct SensedPose {
    /// The bending section's base: the proximal band's centre, mm.
    pub base: Point3<f64>,
    /// Unit tangent at the base (the proximal section's axis).
    pub tangent: Vector3<f64>,
    /// The bending section's curvature vector from its circular-arc fit: the rotation axis of
    /// the arc times its curvature (1/mm), world frame.
    pub curvature: Vector3<f64>,
    /// Axial strain of the bending section measured between its bands, if measured.
    pub bend_strain: Option<f64>,
    /// The tip, mm.
    pub tip: Point3<f64>,
}

/// The sensor-to-model registration.
#[derive(Debug, Clone, PartialEq)]
pub struct SensorFrame {
    /// Model frame → world rotation (columns: the model's x, y, z axes in world).
    pub rotation: Rotation3<f64>,
    /// The bending base in the relaxed reference pose, if one was sensed: the origin of the
    /// proximal compression `ε0`.
    pub reference_base: Option<Point3<f64>>,
    /// Angle between the model's axis and the sensed base tangent, averaged over the
    /// registration poses, radians (a check of the registration).
    pub axis_residual: f64,
    /// Mean angle between the model's and the sensed bending directions of the registration
    /// poses, radians.
    pub direction_residual: f64,
}

impl SensorFrame {
    /// Registers the orientation by weighted least squares over directions (the registration
    /// poses' bending directions as the nominal model predicts them from their `y`, weighted by
    /// their sensed bending angle, and the model's axis onto the sensed base tangents); the
    /// position comes from each frame's base.
    pub fn register(
        model: &Model,
        reference: Option<&SensedPose>,
        articulated: &[(DVector<f64>, SensedPose)],
    ) -> Result<Self, ModelError> {
        let l1 = model.params().distal_length;
        let mut source = Vec::new();
        let mut target = Vec::new();
        let mut weights = Vec::new();
        let mut tangents: Vec<Vector3<f64>> = articulated.iter().map(|(_, s)| s.tangent).collect();
        tangents.extend(reference.map(|r| r.tangent));
        for (y, sensed) in articulated {
            let q = model.forward(y)?.q;
            let predicted = Vector3::new(q[0], 0.0, q[1]);
            let angle = sensed.curvature.norm() * l1;
            if predicted.norm() * l1 < 0.05 || angle < 0.05 {
                continue;
            }
            source.push(predicted.normalize());
            target.push(sensed.curvature.normalize());
            weights.push(angle);
        }
        if source.is_empty() {
            return Err(ModelError::Registration(
                "no registration pose bends by more than 3°; articulate the manipulator toward its tendons".into(),
            ));
        }
        let bend_weight: f64 = weights.iter().sum();
        for t in &tangents {
            source.push(Vector3::y());
            target.push(t.normalize());
            weights.push(bend_weight / tangents.len() as f64);
        }
        let rotation = flexshape_register::rotation_between(&source, &target, &weights)
            .map_err(|e| ModelError::Registration(e.to_string()))?;
        let axis = rotation * Vector3::y();
        let axis_residual =
            tangents.iter().map(|t| axis.angle(t)).sum::<f64>() / tangents.len() as f64;
        let bends = source.len() - tangents.len();
        let direction_residual = (0..bends)
            .map(|i| (rotation * source[i]).angle(&target[i]))
            .sum::<f64>()
            / bends as f64;
        Ok(SensorFrame {
            rotation,
            reference_base: reference.map(|r| r.base),
            axis_residual,
            direction_residual,
        })
    }

    /// The configuration `[κx, κz, ε0, ε1]` of a sensed pose, with which components were
    /// measured (`ε0` needs the reference pose: it is the base's retreat along the axis over
    /// `L0`; `ε1` needs the band-to-band strain), and the tip in the model frame.
    pub fn observation(&self, model: &Model, sensed: &SensedPose, y: DVector<f64>) -> Observation {
        let inverse = self.rotation.inverse();
        let omega = inverse * sensed.curvature;
        let axis = self.rotation * Vector3::y();
        let eps0 = self
            .reference_base
            .map(|r| -(sensed.base - r).dot(&axis) / model.params().proximal_length);
        let q = Vector4::new(
            omega.x,
            omega.z,
            eps0.unwrap_or(f64::NAN),
            sensed.bend_strain.unwrap_or(f64::NAN),
        );
        Observation {
            q,
            measured: [true, true, eps0.is_some(), sensed.bend_strain.is_some()],
            y,
            tip: Some(Point3::from(inverse * (sensed.tip - sensed.base))),
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::{ManipulatorParams, geometry};
    use flexshape_curve::Frame;

    /// A pose sensed exactly by a rig whose world is the model frame rotated by `r` and moved.
    fn sense(model: &Model, y: &DVector<f64>, r: &Rotation3<f64>) -> SensedPose {
        let p = model.params();
        let q = model.forward(y).unwrap().q;
        let origin = Point3::new(10.0, -20.0, 5.0);
        let base = origin + r * Vector3::new(0.0, -p.proximal_length * q[2], 0.0);
        let tip = base + r * geometry::bend_tip(p, &q).coords;
        SensedPose {
            base,
            tangent: r * Vector3::y(),
            curvature: r * Vector3::new(q[0], 0.0, q[1]),
            bend_strain: Some(q[3]),
            tip,
        }
    }

    #[test]
    fn registration_recovers_the_rotation_and_the_configuration() {
        let model = Model::new(ManipulatorParams::paper_like()).unwrap();
        let r = Rotation3::from_euler_angles(0.3, -1.1, 2.0);
        let poses = crate::experiment(&model, &crate::ExperimentPlan::default()).unwrap();
        let reference = sense(&model, &poses[0].y, &r);
        let articulated: Vec<_> = poses[1..5]
            .iter()
            .map(|p| (p.y.clone(), sense(&model, &p.y, &r)))
            .collect();
        let frame = SensorFrame::register(&model, Some(&reference), &articulated).unwrap();
        assert!(frame.rotation.angle_to(&r) < 1e-9);
        assert!(frame.axis_residual < 1e-9 && frame.direction_residual < 1e-9);
        for p in &poses[5..] {
            let o = frame.observation(&model, &sense(&model, &p.y, &r), p.y.clone());
            assert!((o.q - p.q).norm() < 1e-9, "{} vs {}", o.q, p.q);
            let tip = geometry::bend_tip(model.params(), &p.q);
            assert!((o.tip.unwrap() - tip).norm() < 1e-9);
        }
        // Without a reference pose ε0 is not measured.
        let frame = SensorFrame::register(&model, None, &articulated).unwrap();
        let o = frame.observation(&model, &sense(&model, &poses[6].y, &r), poses[6].y.clone());
        assert_eq!(o.measured, [true, true, false, true]);
        let _ = Frame::identity();
    }

    #[test]
    fn straight_registration_poses_are_refused() {
        let model = Model::new(ManipulatorParams::paper_like()).unwrap();
        let straight = (
            DVector::zeros(4),
            sense(&model, &DVector::zeros(4), &Rotation3::identity()),
        );
        let e = SensorFrame::register(&model, None, &[straight]).unwrap_err();
        assert!(e.to_string().contains("articulate"), "{e}");
    }
}
