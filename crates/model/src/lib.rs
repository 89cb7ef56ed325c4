//! Tendon-driven continuum manipulator mechanics: forward/inverse kinematics and stiffness estimation (issue 6; not yet built).
