//! Geometry of hard particles: exact intersection tests between spheres and finite cylinders.

pub mod cylinder;
