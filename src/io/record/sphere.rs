//! A written sphere: `{"type": "sphere", "center": [x, y, z], "radius": r}`.

use super::{placed, Body, RecordShape, SectionCut};
use crate::io::export::vtk::VtkAttributes;
use serde::{Deserialize, Serialize};
use std::f64::consts::PI;

/// A sphere.
#[derive(Clone, Copy, Debug, PartialEq, Serialize, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct SphereRecord {
    /// Centre.
    pub center: [f64; 3],
    /// Radius.
    pub radius: f64,
}

impl RecordShape for SphereRecord {
    const NAME: &'static str = "sphere";
    const PHASE: u8 = 1;

    fn center(&self) -> [f64; 3] {
        self.center
    }

    fn bounding_radius(&self) -> f64 {
        self.radius
    }

    fn volume(&self) -> f64 {
        4.0 / 3.0 * PI * self.radius.powi(3)
    }

    fn surface_area(&self) -> f64 {
        4.0 * PI * self.radius * self.radius
    }

    fn contains(&self, x: [f64; 3]) -> bool {
        let d2: f64 = (0..3).map(|k| (x[k] - self.center[k]).powi(2)).sum();
        d2 <= self.radius * self.radius
    }

    fn in_frame(self, origin: [f64; 3], scale: &dyn Fn(f64) -> f64) -> Self {
        Self {
            center: placed(self.center, origin, scale),
            radius: scale(self.radius),
        }
    }

    fn scaled(&self, factor: f64) -> Self {
        Self {
            center: self.center,
            radius: self.radius * factor,
        }
    }

    fn sieve_diameter(&self) -> f64 {
        2.0 * self.radius
    }

    fn rotations(&self) -> u8 {
        0
    }

    /// A disc of radius `√(r² − t²)`.
    fn plane_cut(
        &self,
        particle: usize,
        center: [f64; 2],
        _axes: [usize; 3],
        t: f64,
    ) -> Option<SectionCut> {
        let r2 = self.radius * self.radius - t * t;
        (r2 > 0.0).then(|| SectionCut::Disc {
            center,
            radius: r2.sqrt(),
            particle,
        })
    }

    fn csv_row(&self) -> String {
        let c = self.center;
        format!(
            "sphere,{},{},{},{},,,,,,,,,,",
            c[0], c[1], c[2], self.radius
        )
    }

    fn gmsh_solid(&self, tag: usize, scale: f64, shift: [f64; 3], inflate: f64) -> String {
        let c = self.center;
        format!(
            "Sphere({tag}) = {{{}, {}, {}, {}}};",
            c[0] + shift[0],
            c[1] + shift[1],
            c[2] + shift[2],
            self.radius * scale + inflate
        )
    }

    fn vtk_attributes(&self) -> VtkAttributes {
        let r = self.radius;
        VtkAttributes {
            center: self.center,
            radius: r,
            semi_axes: [r; 3],
            orientation: [1.0, 0.0, 0.0, 0.0],
            shape_tensor: [r, 0.0, 0.0, 0.0, r, 0.0, 0.0, 0.0, r],
            half_axis: [0.0; 3],
            shape: Self::PHASE,
        }
    }

    fn size_error(&self) -> Option<String> {
        let r = self.radius;
        (!(r.is_finite() && r > 0.0)).then(|| format!("radius {r} is not finite and > 0"))
    }

    fn body(&self) -> Body {
        Body::Ball {
            center: self.center,
            radius: self.radius,
        }
    }
}
