//! Configuration → shape: the straight proximal section (length `L0`, compressed by `ε0`) then
//! the constant-curvature bending section (length `L1`, compressed by `ε1`, curvatures κx, κz
//! about its frame's x and z axes, axis along y), in the model frame (origin at the proximal
//! section's base, its axis along +y).

use flexshape_curve::{Frame, Section, SectionChain};
use nalgebra::{Point3, Vector4};

use crate::ManipulatorParams;

/// The two sections for configuration `q = [κx, κz, ε0, ε1]`, from `base` (the model frame:
/// `Frame::identity()`).
pub fn shape(params: &ManipulatorParams, q: &Vector4<f64>, base: Frame) -> SectionChain {
    SectionChain {
        base,
        sections: vec![
            Section {
                length: params.proximal_length,
                kappa: [0.0, 0.0],
                strain: q[2],
            },
            Section {
                length: params.distal_length,
                kappa: [q[0], q[1]],
                strain: q[3],
            },
        ],
    }
}

/// The bending section alone, from its base (the frame the paper registers to): the tip
/// position in that frame, mm.
pub fn bend_tip(params: &ManipulatorParams, q: &Vector4<f64>) -> Point3<f64> {
    Section {
        length: params.distal_length,
        kappa: [q[0], q[1]],
        strain: q[3],
    }
    .local_frame(params.distal_length * (1.0 - q[3]))
    .position
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn closed_forms_of_the_tip() {
        let p = ManipulatorParams::paper_like();
        let l = p.distal_length;
        // Straight, compressed: along +y by L1(1 − ε1); the whole chain adds L0(1 − ε0).
        let q = Vector4::new(0.0, 0.0, 0.01, 0.02);
        assert!((bend_tip(&p, &q) - Point3::new(0.0, l * 0.98, 0.0)).norm() < 1e-12);
        let tip = shape(&p, &q, Frame::identity()).tip().position;
        assert!((tip.y - (1000.0 * 0.99 + l * 0.98)).abs() < 1e-9);
        // Pure κx bends toward +z: (0, sin θ/κ, (1 − cos θ)/κ) with θ = κ·L1(1 − ε1).
        let k = 1.0 / 80.0;
        let theta = k * l * 0.98;
        let expect = Point3::new(0.0, theta.sin() / k, (1.0 - theta.cos()) / k);
        assert!((bend_tip(&p, &Vector4::new(k, 0.0, 0.0, 0.02)) - expect).norm() < 1e-9);
        // Pure κz bends toward −x.
        let expect = Point3::new(-(1.0 - theta.cos()) / k, theta.sin() / k, 0.0);
        assert!((bend_tip(&p, &Vector4::new(0.0, k, 0.0, 0.02)) - expect).norm() < 1e-9);
        // Small-curvature limit: the tip leaves the axis by κL²/2 and falls short by Lθ²/6.
        let k = 1e-7;
        let theta = k * l;
        let tip = bend_tip(&p, &Vector4::new(k, 0.0, 0.0, 0.0));
        assert!(
            (tip.z - k * l * l / 2.0 * (1.0 - theta * theta / 12.0)).abs() < 1e-15,
            "{tip}"
        );
        assert!(
            (tip.y - l * (1.0 - theta * theta / 6.0)).abs() < 1e-12,
            "{tip}"
        );
    }
}
