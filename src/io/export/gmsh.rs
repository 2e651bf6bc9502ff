//! Gmsh `.geo` script (OpenCASCADE kernel): the particles inside their container, fragmented
//! with the matrix so that the mesh is conforming across every particle surface.
//!
//! The script builds the container (`Box` or `Cylinder`) and one solid per particle, runs
//! `BooleanFragments`, deletes every fragment outside the container, and sorts the rest
//! into physical volumes by bounding boxes:
//!
//! | physical volume | tag | what |
//! |---|---|---|
//! | `matrix` | 1 | container minus particles (minus shells) |
//! | `aggregates` | 2 | the particles, when they are all of one kind ([`GmshGroups::ByKind`]) |
//! | `spheres`, `ellipsoids`, `cylinders` | 4, 5, 6 | the particles of each kind present, when there are several ([`GmshGroups::ByKind`]) |
//! | `particle_<i>` | 1000 + i | particle `i` of the packing (0-based, the file's order), all its periodic pieces ([`GmshGroups::ByParticle`]) |
//! | `interface` | 3 | shells of thickness `t` around the particles (only with `interface_thickness`) |
//!
//! and physical surfaces for boundary conditions, the container's faces after fragmentation
//! (on a periodic face, the pieces of the particles it cuts included):
//!
//! | container | physical surfaces (tags) |
//! |---|---|
//! | box | `xmin` (11), `xmax` (12), `ymin` (13), `ymax` (14), `zmin` (15), `zmax` (16) |
//! | cylinder | `bottom` (11), `top` (12), `side` (13) |
//!
//! Every volume keeps the tag it was created with through the final `BooleanFragments` (the
//! volumes are disjoint by then, so fragmentation only merges shared faces): the groups are
//! lists of those tags, no search by bounding boxes.
//!
//! **Periodic boxes.** A particle cut by a periodic face is written with each of its images
//! that reaches into the box, all clipped to the box, so the pieces on opposite faces match;
//! then every surface on a lower face is paired with the surface on the upper face whose
//! bounding box is its translate, and `Periodic Surface` makes the two meshes identical (the
//! pairing by bounding boxes is the method of Gmsh's tutorial t18).
//!
//! **Near-touching particles.** Jammed packings have gaps of ~10⁻¹² of a diameter, which no
//! mesher resolves; shrink the particles first ([`GmshOptions::shrink`]) so that the narrowest
//! gap is a few elements wide.

use super::{container_bounds, periodic_axes, provenance_line, ExportError};
use crate::io::packing::{ContainerRecord, Packing, ParticleRecord};
use std::io::Write;

/// Options of the Gmsh export.
#[derive(Clone, Copy, Debug, Default, PartialEq)]
pub struct GmshOptions {
    /// Thickness of interface shells around each particle (physical volume `interface`);
    /// shells must not overlap each other or leave the container.
    pub interface_thickness: Option<f64>,
    /// Largest element size written as `Mesh.MeshSizeMax` (default: the mean radius / 2).
    pub mesh_size: Option<f64>,
    /// Relative radius reduction applied to every particle before export, in `[0, 1)`:
    /// `r → (1 − shrink) r` about the same centre.
    pub shrink: f64,
    /// How the particles are sorted into physical volumes.
    pub groups: GmshGroups,
}

/// How [`write_geo`] sorts the particles into physical volumes (see the module docs).
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq)]
pub enum GmshGroups {
    /// One group per particle kind present (`aggregates` when there is one kind).
    #[default]
    ByKind,
    /// One group per particle, `particle_<i>`.
    ByParticle,
}

/// The physical volume of a particle kind in a packing with several kinds: the plural of
/// the kind's voxel phase name and tag 3 + its phase id (so that tags 1–3 keep their
/// meaning): one list of kinds for both exports.
fn kind_group(p: &ParticleRecord) -> (String, usize) {
    (format!("{}s", p.kind()), 3 + usize::from(p.phase()))
}

/// One solid of the script: a particle (or shell) translated by a periodic image shift.
struct Solid<'a> {
    particle: &'a ParticleRecord,
    /// Index of the particle in the packing.
    index: usize,
    shift: [f64; 3],
    /// Added to every radius / semi-axis (shells).
    inflate: f64,
}

/// The `.geo` statement creating volume `tag` for a solid.
fn solid_statement(s: &Solid, scale: f64, tag: usize) -> String {
    s.particle.gmsh_solid(tag, scale, s.shift, s.inflate)
}

/// The `.geo` statement creating the box `[lo, hi]` as volume `tag`.
fn box_statement(tag: usize, lo: [f64; 3], hi: [f64; 3]) -> String {
    format!(
        "Box({tag}) = {{{}, {}, {}, {}, {}, {}}};",
        lo[0],
        lo[1],
        lo[2],
        hi[0] - lo[0],
        hi[1] - lo[1],
        hi[2] - lo[2]
    )
}

/// Image shifts of a bounding sphere `(c, r)` that reach into the box `[lo, hi]` along the
/// periodic axes, the zero shift first.
fn image_shifts(
    c: [f64; 3],
    r: f64,
    lo: [f64; 3],
    hi: [f64; 3],
    periodic: [bool; 3],
) -> Vec<[f64; 3]> {
    let mut per_axis: [Vec<f64>; 3] = std::array::from_fn(|_| vec![0.0]);
    for k in 0..3 {
        if periodic[k] {
            let len = hi[k] - lo[k];
            if c[k] - r < lo[k] {
                per_axis[k].push(len);
            }
            if c[k] + r > hi[k] {
                per_axis[k].push(-len);
            }
        }
    }
    let mut shifts = Vec::new();
    for &sx in &per_axis[0] {
        for &sy in &per_axis[1] {
            for &sz in &per_axis[2] {
                let s = [sx, sy, sz];
                // Keep the image only if its bounding sphere reaches into the box.
                let d2: f64 = (0..3)
                    .map(|k| {
                        let x = c[k] + s[k];
                        (x - x.clamp(lo[k], hi[k])).powi(2)
                    })
                    .sum();
                if d2 < r * r {
                    shifts.push(s);
                }
            }
        }
    }
    shifts
}

/// Offsets of the exported box along each periodic axis, chosen so that the faces stay as far
/// as possible from every particle surface: a face that nearly touches a particle would cut
/// off a sliver no mesher resolves. A periodic packing is invariant under translation, so the
/// box may start anywhere; per axis the face goes to the middle of the widest gap between
/// the surface extremes `c ± r` (taken modulo the box length). Returns the offsets and the
/// smallest clearance between a face and a particle's extreme.
fn face_offsets(
    spheres: &[([f64; 3], f64)],
    lo: [f64; 3],
    hi: [f64; 3],
    periodic: [bool; 3],
) -> ([f64; 3], f64) {
    let mut offsets = [0.0; 3];
    let mut clearance = f64::INFINITY;
    for k in (0..3).filter(|&k| periodic[k]) {
        let len = hi[k] - lo[k];
        let mut extremes: Vec<f64> = spheres
            .iter()
            .flat_map(|&(c, r)| [c[k] - r, c[k] + r])
            .map(|x| (x - lo[k]).rem_euclid(len))
            .collect();
        if extremes.is_empty() {
            continue;
        }
        extremes.sort_unstable_by(f64::total_cmp);
        // Widest circular gap: between consecutive extremes, or from the last around to the first.
        let mut best = (
            extremes[0] + len - extremes[extremes.len() - 1],
            extremes[extremes.len() - 1],
        );
        for w in extremes.windows(2) {
            if w[1] - w[0] > best.0 {
                best = (w[1] - w[0], w[0]);
            }
        }
        offsets[k] = (best.1 + 0.5 * best.0).rem_euclid(len);
        clearance = clearance.min(0.5 * best.0);
    }
    (offsets, clearance)
}

/// What the caller's check of the exported surfaces found. The exporter builds those
/// surfaces (the shrunk particles, or their shells around them, as a packing that claims no
/// gap) and hands them to the check [`write_geo`] is given: it has no overlap checker of its
/// own (the CLI passes `crate::verify`'s).
#[derive(Clone, Debug, Default, PartialEq)]
pub struct SurfaceCheck {
    /// Surfaces that overlap each other or leave the container.
    pub violation_count: usize,
    /// The first of them, for the message.
    pub first_violation: Option<String>,
    /// Narrowest gap between two surfaces (`None` without neighbours).
    pub min_pair_gap: Option<f64>,
    /// Narrowest gap between a surface and a wall (`None` without walls).
    pub min_wall_gap: Option<f64>,
}

/// Checks the options against the packing: shrink in range, shells that neither overlap each
/// other nor leave the container (as `check_surfaces` finds them on the inflated particles).
fn check(
    packing: &Packing,
    opts: &GmshOptions,
    check_surfaces: &dyn Fn(&Packing) -> SurfaceCheck,
) -> Result<GmshReport, ExportError> {
    if !(opts.shrink >= 0.0 && opts.shrink < 1.0) {
        return Err(ExportError::Invalid {
            option: "--shrink",
            message: format!("= {} is outside the allowed range [0, 1)", opts.shrink),
        });
    }
    if let Some(h) = opts.mesh_size {
        if !(h.is_finite() && h > 0.0) {
            return Err(ExportError::Invalid {
                option: "--mesh-size",
                message: format!("= {h} must be a finite number > 0"),
            });
        }
    }
    if let Some(t) = opts.interface_thickness {
        if !(t.is_finite() && t > 0.0) {
            return Err(ExportError::Invalid {
                option: "--interface",
                message: format!("= {t} must be a finite number > 0"),
            });
        }
    }
    // The outermost exported surfaces (shrunk particles, or their shells) must not overlap
    // or leave the container; their narrowest gap tells whether a mesher can resolve it.
    let shell = opts.interface_thickness.unwrap_or(0.0);
    let mut outer = packing.clone();
    outer.min_gap = 0.0;
    for p in &mut outer.particles {
        let (_, r) = p.bounding_sphere();
        *p = p.scaled(((1.0 - opts.shrink) * r + shell) / r);
    }
    let v = check_surfaces(&outer);
    if v.violation_count > 0 {
        return Err(ExportError::Invalid {
            option: "--interface",
            message: format!(
                "shells of thickness {shell} overlap or leave the container ({} violations, \
                 first: {}); use a thinner shell or a larger --shrink",
                v.violation_count,
                v.first_violation.as_deref().unwrap_or("")
            ),
        });
    }
    let narrowest = [v.min_pair_gap, v.min_wall_gap]
        .into_iter()
        .flatten()
        .fold(None, |m: Option<f64>, g| Some(m.map_or(g, |m| m.min(g))));
    Ok(GmshReport {
        mesh_size: opts
            .mesh_size
            .unwrap_or_else(|| default_mesh_size(packing, opts)),
        narrowest_gap: narrowest,
    })
}

/// Half the mean particle radius after shrinking.
fn default_mesh_size(packing: &Packing, opts: &GmshOptions) -> f64 {
    let n = packing.particles.len().max(1) as f64;
    let sum: f64 = packing
        .particles
        .iter()
        .map(|p| p.bounding_sphere().1)
        .sum();
    0.5 * sum / n * (1.0 - opts.shrink)
}

/// What the export found out about meshability.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct GmshReport {
    /// Largest element size written (`Mesh.MeshSizeMax`).
    pub mesh_size: f64,
    /// Narrowest gap between exported surfaces (particles or shells, after shrinking), pair
    /// or wall; `None` without neighbours or walls. Much below the mesh size, meshing will be
    /// slow or fail: shrink the particles.
    pub narrowest_gap: Option<f64>,
}

/// Writes the `.geo` script for `packing` to `path`, after `check_surfaces` has found the
/// exported surfaces (shrunk particles or their shells) free of overlaps and inside the
/// container ([`SurfaceCheck`]).
pub fn write_geo(
    packing: &Packing,
    opts: &GmshOptions,
    check_surfaces: &dyn Fn(&Packing) -> SurfaceCheck,
    path: &std::path::Path,
) -> Result<GmshReport, ExportError> {
    let report = check(packing, opts, check_surfaces)?;
    super::write_file(path, |w| geo(packing, opts, report.mesh_size, w))?;
    Ok(report)
}

/// A `.geo` list of volume tags, runs of consecutive tags written as ranges `a:b`.
fn tag_list(tags: &[usize]) -> String {
    let mut parts: Vec<String> = Vec::new();
    let mut k = 0;
    while k < tags.len() {
        let mut end = k;
        while end + 1 < tags.len() && tags[end + 1] == tags[end] + 1 {
            end += 1;
        }
        parts.push(if end == k {
            tags[k].to_string()
        } else {
            format!("{}:{}", tags[k], tags[end])
        });
        k = end + 1;
    }
    parts.join(", ")
}

/// The physical surfaces of the container's faces (see the module docs): each face is the
/// set of surfaces inside a box `eps` thick around its plane; a cylinder's side is the rest
/// of the model's outer boundary.
fn write_face_groups(
    w: &mut impl Write,
    container: &ContainerRecord,
    lo: [f64; 3],
    hi: [f64; 3],
    eps: f64,
) -> std::io::Result<()> {
    let slab = |axis: usize, at: f64| -> String {
        let mut a = lo.map(|x| x - eps);
        let mut b = hi.map(|x| x + eps);
        a[axis] = at - eps;
        b[axis] = at + eps;
        format!(
            "Surface In BoundingBox{{{}, {}, {}, {}, {}, {}}}",
            a[0], a[1], a[2], b[0], b[1], b[2]
        )
    };
    writeln!(w, "// Container faces, for boundary conditions.")?;
    match container {
        ContainerRecord::Box { .. } => {
            for (axis, letter) in ["x", "y", "z"].into_iter().enumerate() {
                for (side, (suffix, at)) in [("min", lo[axis]), ("max", hi[axis])]
                    .into_iter()
                    .enumerate()
                {
                    writeln!(
                        w,
                        "Physical Surface(\"{letter}{suffix}\", {}) = {};",
                        11 + 2 * axis + side,
                        slab(axis, at)
                    )?;
                }
            }
        }
        ContainerRecord::Cylinder { .. } => {
            writeln!(w, "bottom() = {};", slab(2, lo[2]))?;
            writeln!(w, "top() = {};", slab(2, hi[2]))?;
            writeln!(w, "side() = Abs(CombinedBoundary{{ Volume{{:}}; }});")?;
            writeln!(w, "side() -= {{bottom(), top()}};")?;
            writeln!(w, "Physical Surface(\"bottom\", 11) = {{bottom()}};")?;
            writeln!(w, "Physical Surface(\"top\", 12) = {{top()}};")?;
            writeln!(w, "Physical Surface(\"side\", 13) = {{side()}};")?;
        }
    }
    Ok(())
}

fn geo(
    packing: &Packing,
    opts: &GmshOptions,
    mesh_size: f64,
    w: &mut impl Write,
) -> std::io::Result<()> {
    let (lo0, hi0) = container_bounds(&packing.container);
    let periodic = periodic_axes(&packing.container);
    let scale = 1.0 - opts.shrink;
    let shell = opts.interface_thickness.unwrap_or(0.0);
    let outer: Vec<([f64; 3], f64)> = packing
        .particles
        .iter()
        .map(|p| {
            let (c, r) = p.bounding_sphere();
            (c, r * scale + shell)
        })
        .collect();
    let (offset, clearance) = face_offsets(&outer, lo0, hi0, periodic);
    let lo: [f64; 3] = std::array::from_fn(|k| lo0[k] + offset[k]);
    let hi: [f64; 3] = std::array::from_fn(|k| hi0[k] + offset[k]);
    let extent = (0..3).map(|k| hi[k] - lo[k]).fold(0.0, f64::max);
    let eps = 1e-6 * extent;

    writeln!(w, "// {}", provenance_line(packing))?;
    writeln!(
        w,
        "// Physical volumes: \"matrix\" (1), the particles' groups (below){}; physical surfaces:\n\
         // the container's faces. Lengths in the packing's unit.",
        if opts.interface_thickness.is_some() {
            ", \"interface\" (3)"
        } else {
            ""
        }
    )?;
    writeln!(
        w,
        "// Particle radii scaled by {scale}; interface shell thickness {shell}."
    )?;
    if periodic.iter().any(|&p| p) {
        writeln!(
            w,
            "// Periodic box translated by {offset:?} (a symmetry of the packing) so that no face \
             comes closer than {clearance:.4e} to a particle's extreme."
        )?;
    }
    writeln!(
        w,
        "// Mesh it with: gmsh -3 FILE.geo -o FILE.msh (add -order 2 for curved elements: linear\n\
         // tetrahedra under-represent a sphere's volume by about 2 % at the size set below)."
    )?;
    writeln!(w, "SetFactory(\"OpenCASCADE\");")?;
    writeln!(w, "eps = {eps};")?;
    match &packing.container {
        ContainerRecord::Box { .. } => writeln!(w, "{}", box_statement(1, lo, hi))?,
        ContainerRecord::Cylinder {
            base_center: b,
            radius,
            height,
        } => writeln!(
            w,
            "Cylinder(1) = {{{}, {}, {}, 0, 0, {height}, {radius}}};",
            b[0], b[1], b[2]
        )?,
    }

    // Solids: cores (and shells), each with its periodic images. Tags: 1 container,
    // 2 clipping box (periodic only), then cores, then shells.
    let clip = periodic.iter().any(|&p| p);
    let mut cores: Vec<Solid> = Vec::new();
    let mut shells: Vec<Solid> = Vec::new();
    for (index, p) in packing.particles.iter().enumerate() {
        let (c, r) = p.bounding_sphere();
        // Wrap into the (translated) box first; the images then reach across its faces.
        let wrap: [f64; 3] = std::array::from_fn(|k| {
            if periodic[k] {
                lo[k] + (c[k] - lo[k]).rem_euclid(hi[k] - lo[k]) - c[k]
            } else {
                0.0
            }
        });
        let wrapped: [f64; 3] = std::array::from_fn(|k| c[k] + wrap[k]);
        for image in image_shifts(wrapped, r * scale + shell, lo, hi, periodic) {
            let shift: [f64; 3] = std::array::from_fn(|k| wrap[k] + image[k]);
            cores.push(Solid {
                particle: p,
                index,
                shift,
                inflate: 0.0,
            });
            if opts.interface_thickness.is_some() {
                shells.push(Solid {
                    particle: p,
                    index,
                    shift,
                    inflate: shell,
                });
            }
        }
    }
    if clip {
        writeln!(w, "{}", box_statement(2, lo, hi))?;
    }
    let first_core = if clip { 3 } else { 2 };
    for (k, solid) in cores.iter().enumerate() {
        writeln!(w, "{}", solid_statement(solid, scale, first_core + k))?;
    }
    let last_core = first_core + cores.len() - 1;
    writeln!(
        w,
        "// Aggregates (clipped to the box on periodic axes), interface shells, matrix: disjoint"
    )?;
    writeln!(
        w,
        "// volumes whose tags the final fragmentation keeps (it only merges shared faces)."
    )?;
    // The physical volumes of the particles: (name, tag, core tags), in order of first
    // appearance. Cores are pushed particle by particle, so a particle's tags are contiguous.
    let kinds = {
        let mut seen: Vec<u8> = packing
            .particles
            .iter()
            .map(ParticleRecord::phase)
            .collect();
        seen.sort_unstable();
        seen.dedup();
        seen.len()
    };
    let mut groups: Vec<(String, usize, Vec<usize>)> = Vec::new();
    for (k, solid) in cores.iter().enumerate() {
        let (name, tag) = match opts.groups {
            GmshGroups::ByParticle => (format!("particle_{}", solid.index), 1000 + solid.index),
            GmshGroups::ByKind if kinds == 1 => ("aggregates".to_string(), 2),
            GmshGroups::ByKind => kind_group(solid.particle),
        };
        match groups.iter_mut().find(|g| g.1 == tag) {
            Some(g) => g.2.push(first_core + k),
            None => groups.push((name, tag, vec![first_core + k])),
        }
    }
    writeln!(w, "aggregates() = {{}};")?;
    for (g, (_, _, tags)) in groups.iter().enumerate() {
        let list = tag_list(tags);
        if clip {
            // The clipping box (tag 2) is kept as the tool of every group and deleted after.
            writeln!(
                w,
                "group{g}() = BooleanIntersection{{ Volume{{{list}}}; Delete; }}{{ Volume{{2}}; }};"
            )?;
        } else {
            writeln!(w, "group{g}() = {{{list}}};")?;
        }
        writeln!(w, "aggregates() += group{g}();")?;
    }
    if clip {
        writeln!(w, "Recursive Delete {{ Volume{{2}}; }}")?;
    }
    if opts.interface_thickness.is_some() && !cores.is_empty() {
        let first_shell = last_core + 1;
        for (k, solid) in shells.iter().enumerate() {
            writeln!(w, "{}", solid_statement(solid, scale, first_shell + k))?;
        }
        let last_shell = first_shell + shells.len() - 1;
        if clip {
            let clip_tag = last_shell + 1;
            writeln!(w, "{}", box_statement(clip_tag, lo, hi))?;
            writeln!(
                w,
                "outer() = BooleanIntersection{{ Volume{{{first_shell}:{last_shell}}}; Delete; }}{{ Volume{{{clip_tag}}}; Delete; }};"
            )?;
        } else {
            writeln!(w, "outer() = {{{first_shell}:{last_shell}}};")?;
        }
        writeln!(
            w,
            "interface() = BooleanDifference{{ Volume{{outer()}}; Delete; }}{{ Volume{{aggregates()}}; }};"
        )?;
    } else {
        writeln!(w, "interface() = {{}};")?;
    }
    if cores.is_empty() {
        writeln!(w, "matrix() = {{1}};")?;
    } else {
        writeln!(
            w,
            "matrix() = BooleanDifference{{ Volume{{1}}; Delete; }}{{ Volume{{aggregates(), interface()}}; }};"
        )?;
        writeln!(
            w,
            "all() = BooleanFragments{{ Volume{{matrix(), interface(), aggregates()}}; Delete; }}{{}};"
        )?;
    }
    writeln!(w, "Physical Volume(\"matrix\", 1) = {{matrix()}};")?;
    if groups.is_empty() {
        writeln!(w, "Physical Volume(\"aggregates\", 2) = {{}};")?;
    }
    for (g, (name, tag, _)) in groups.iter().enumerate() {
        writeln!(w, "Physical Volume(\"{name}\", {tag}) = {{group{g}()}};")?;
    }
    if opts.interface_thickness.is_some() {
        writeln!(w, "Physical Volume(\"interface\", 3) = {{interface()}};")?;
    }
    write_face_groups(w, &packing.container, lo, hi, eps)?;

    for k in (0..3).filter(|&k| periodic[k]) {
        let len = hi[k] - lo[k];
        let mut t = [0.0; 3];
        t[k] = len;
        let mut face_hi = hi;
        face_hi[k] = lo[k];
        writeln!(w, "// Periodic faces along axis {k}.")?;
        writeln!(
            w,
            "lower() = Surface In BoundingBox{{{}, {}, {}, {}, {}, {}}};",
            lo[0] - eps,
            lo[1] - eps,
            lo[2] - eps,
            face_hi[0] + eps,
            face_hi[1] + eps,
            face_hi[2] + eps
        )?;
        writeln!(w, "For i In {{0:#lower()-1}}")?;
        writeln!(w, "  bb() = BoundingBox Surface{{lower(i)}};")?;
        writeln!(
            w,
            "  upper() = Surface In BoundingBox{{bb(0)-eps+{}, bb(1)-eps+{}, bb(2)-eps+{}, bb(3)+eps+{}, bb(4)+eps+{}, bb(5)+eps+{}}};",
            t[0], t[1], t[2], t[0], t[1], t[2]
        )?;
        writeln!(w, "  For j In {{0:#upper()-1}}")?;
        writeln!(w, "    bu() = BoundingBox Surface{{upper(j)}};")?;
        writeln!(
            w,
            "    If (Fabs(bu(0)-{}-bb(0)) < eps && Fabs(bu(1)-{}-bb(1)) < eps && Fabs(bu(2)-{}-bb(2)) < eps && Fabs(bu(3)-{}-bb(3)) < eps && Fabs(bu(4)-{}-bb(4)) < eps && Fabs(bu(5)-{}-bb(5)) < eps)",
            t[0], t[1], t[2], t[0], t[1], t[2]
        )?;
        writeln!(
            w,
            "      Periodic Surface{{upper(j)}} = {{lower(i)}} Translate{{{}, {}, {}}};",
            t[0], t[1], t[2]
        )?;
        writeln!(w, "    EndIf\n  EndFor\nEndFor")?;
    }
    writeln!(w, "Mesh.MeshSizeMax = {mesh_size};")?;
    writeln!(w, "Mesh.MeshSizeFromCurvature = 24;")?;
    Ok(())
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::io::record::SphereRecord;

    /// Spheres in a walled box, every pair and wall measured exactly: the check the tests
    /// give the exporter (independent of `crate::verify`).
    fn spheres_in_walled_box(packing: &Packing) -> SurfaceCheck {
        let ContainerRecord::Box { min, max, .. } = packing.container else {
            panic!("a box");
        };
        let spheres: Vec<([f64; 3], f64)> = packing
            .particles
            .iter()
            .map(|p| match *p {
                ParticleRecord::Sphere(SphereRecord { center, radius }) => (center, radius),
                _ => panic!("spheres"),
            })
            .collect();
        let mut out = SurfaceCheck::default();
        let mut note = |gap: f64, slot: &mut Option<f64>, what: String| {
            *slot = Some(slot.map_or(gap, |m: f64| m.min(gap)));
            if gap < 0.0 {
                out.violation_count += 1;
                out.first_violation.get_or_insert(what);
            }
        };
        let (mut pair, mut wall) = (None, None);
        for (i, &(c, r)) in spheres.iter().enumerate() {
            for k in 0..3 {
                note(c[k] - r - min[k], &mut wall, format!("{i} leaves the box"));
                note(max[k] - c[k] - r, &mut wall, format!("{i} leaves the box"));
            }
            for (j, &(d, s)) in spheres.iter().enumerate().skip(i + 1) {
                let dist = (0..3).map(|k| (c[k] - d[k]).powi(2)).sum::<f64>().sqrt();
                note(dist - r - s, &mut pair, format!("{i} and {j} overlap"));
            }
        }
        out.min_pair_gap = pair;
        out.min_wall_gap = wall;
        out
    }

    #[test]
    fn the_narrowest_gap_is_measured_after_shrinking_and_overlapping_shells_are_refused() {
        // Radii 1 and 2, centres 3.5 apart in a walled 10-cube. Shrunk by 10 %: radii 0.9
        // and 1.8, pair gap 3.5 − 2.7 = 0.8; wall gaps 2 − 0.9 = 1.1 and 10 − 5.5 − 1.8 = 2.7.
        let packing: Packing = serde_json::from_str(
            r#"{"format": "densepack-packing", "version": 1,
                "container": {"type": "box", "min": [0,0,0], "max": [10,10,10], "periodic": [false,false,false]},
                "particles": [{"type": "sphere", "center": [2, 5, 5], "radius": 1},
                              {"type": "sphere", "center": [5.5, 5, 5], "radius": 2}],
                "min_gap": 0, "seed": 0,
                "stats": {"packing_fraction": 0, "reduced_pressure": 0, "events": 0,
                          "collisions": 0, "wall_seconds": 0, "stop_reason": ""}}"#,
        )
        .unwrap();
        let opts = GmshOptions {
            shrink: 0.1,
            ..Default::default()
        };
        let report = check(&packing, &opts, &spheres_in_walled_box).unwrap();
        assert!((report.narrowest_gap.unwrap() - 0.8).abs() < 1e-12);
        assert!((report.mesh_size - 0.5 * 1.5 * 0.9).abs() < 1e-12);
        // Shells of 0.3 leave 0.8 − 0.6 = 0.2 between them; 0.5 would overlap.
        let shells = |t: f64| GmshOptions {
            interface_thickness: Some(t),
            ..opts
        };
        let report = check(&packing, &shells(0.3), &spheres_in_walled_box).unwrap();
        assert!((report.narrowest_gap.unwrap() - 0.2).abs() < 1e-12);
        assert!(check(&packing, &shells(0.5), &spheres_in_walled_box).is_err());
    }

    #[test]
    fn tag_lists_write_runs_of_consecutive_tags_as_ranges() {
        assert_eq!(tag_list(&[2, 3, 4, 7, 9, 10]), "2:4, 7, 9:10");
        assert_eq!(tag_list(&[5]), "5");
        assert_eq!(tag_list(&[]), "");
    }

    #[test]
    fn mixtures_get_a_volume_per_kind_or_per_particle_and_boxes_six_named_faces() {
        let packing: Packing = serde_json::from_str(
            r#"{"format": "densepack-packing", "version": 1,
                "container": {"type": "box", "min": [0,0,0], "max": [10,10,10], "periodic": [false,false,false]},
                "particles": [{"type": "sphere", "center": [2, 5, 5], "radius": 1},
                              {"type": "cylinder", "center": [6, 5, 5], "radius": 1, "half_axis": [0, 0, 2]},
                              {"type": "sphere", "center": [8.5, 5, 5], "radius": 1}],
                "min_gap": 0, "seed": 0,
                "stats": {"packing_fraction": 0, "reduced_pressure": 0, "events": 0,
                          "collisions": 0, "wall_seconds": 0, "stop_reason": ""}}"#,
        )
        .unwrap();
        let script = |groups| {
            let mut out = Vec::new();
            let opts = GmshOptions {
                groups,
                ..Default::default()
            };
            geo(&packing, &opts, 0.5, &mut out).unwrap();
            String::from_utf8(out).unwrap()
        };
        // Tags: container 1, then the three particles 2, 3, 4.
        let by_kind = script(GmshGroups::ByKind);
        assert!(by_kind.contains("group0() = {2, 4};"), "{by_kind}");
        assert!(by_kind.contains("group1() = {3};"), "{by_kind}");
        assert!(by_kind.contains("Physical Volume(\"spheres\", 4) = {group0()};"));
        assert!(by_kind.contains("Physical Volume(\"cylinders\", 6) = {group1()};"));
        assert!(!by_kind.contains("\"aggregates\""));
        let by_particle = script(GmshGroups::ByParticle);
        for i in 0..3 {
            assert!(
                by_particle.contains(&format!("Physical Volume(\"particle_{i}\", {})", 1000 + i)),
                "{by_particle}"
            );
        }
        for (face, tag) in [
            ("xmin", 11),
            ("xmax", 12),
            ("ymin", 13),
            ("ymax", 14),
            ("zmin", 15),
            ("zmax", 16),
        ] {
            assert!(by_kind.contains(&format!("Physical Surface(\"{face}\", {tag})")));
        }
    }

    #[test]
    fn periodic_faces_go_to_the_middle_of_the_widest_gap_between_particle_extremes() {
        // Extremes along x at 0.5..1.5 and 9.5..10.5 ≡ 9.5..0.5 (mod 10): the covered set is
        // 9.5..1.5, so the widest gap is 1.5..9.5 and the face goes to 5.5, clearance 4.
        let spheres = [([1.0, 5.0, 5.0], 0.5), ([10.0, 5.0, 5.0], 0.5)];
        let (offset, clearance) = face_offsets(&spheres, [0.0; 3], [10.0; 3], [true, false, false]);
        assert_eq!(offset, [5.5, 0.0, 0.0]);
        assert_eq!(clearance, 4.0);
    }

    #[test]
    fn images_of_a_sphere_at_a_corner_are_those_that_reach_into_the_box() {
        let lo = [0.0; 3];
        let hi = [10.0; 3];
        // Crosses the three lower faces; its corner image reaches in along the diagonal
        // (distance √3·0.2 < 1).
        let shifts = image_shifts([0.2, 0.2, 0.2], 1.0, lo, hi, [true; 3]);
        assert_eq!(shifts.len(), 8);
        assert_eq!(shifts[0], [0.0; 3]);
        assert!(shifts.contains(&[10.0, 10.0, 10.0]));
        // At (0.9, 0.9, 0.9) the edge images are √2·0.9 = 1.27 > 1 away and the corner image
        // √3·0.9: only the three face images reach in.
        let shifts = image_shifts([0.9, 0.9, 0.9], 1.0, lo, hi, [true; 3]);
        assert_eq!(shifts.len(), 4);
        // Walls: no images.
        let shifts = image_shifts([0.2, 0.2, 0.2], 1.0, lo, hi, [false; 3]);
        assert_eq!(shifts, vec![[0.0; 3]]);
    }
}
