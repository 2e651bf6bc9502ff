//! Voxel label images for FFT homogenisation: `.npy` or raw bytes, each with a JSON sidecar.
//!
//! The container's bounding box is split into `n_x × n_y × n_z` voxels of spacing
//! `h_k = L_k / n_k`, with `n_k = max(1, round(L_k / h))` and `h = L_max / voxels`. A voxel
//! takes the label of the particle containing its **centre** `origin + (index + ½) h`
//! (periodic axes wrap: a particle cut by a face labels voxels on both sides). Labels:
//!
//! - [`Labels::Phase`] (`uint8`): 0 matrix, 1 sphere, 255 outside the container (cylinders);
//! - [`Labels::Particle`] (`uint32`): 0 matrix, particle index + 1, `2³² − 1` outside;
//! - [`Labels::PartialVolume`] (`float32`): the solid fraction of each voxel estimated from
//!   `s³` sample points (composite voxels), −1 outside.
//!
//! Layout: C order with shape `[n_x, n_y, n_z]` (z fastest, `index = (i n_y + j) n_z + k`),
//! little endian, so `numpy.load(f)[i, j, k]` is the voxel at `(x_i, y_j, z_k)`. The sidecar
//! `FILE.json` records shape, spacing, origin, dtype, the label meanings, the exact packing
//! fraction and the voxel one.
//!
//! **Resolution error.** A voxel is mislabelled only if its centre and some point of it lie
//! on different sides of a particle surface, i.e. the centre is within half a voxel diagonal
//! `δ = ½|h|` of the surface. So `|φ_voxels − φ| ≤ S δ / V` to first order in `δ / r`, with
//! `S` the total particle surface; for spheres, with errors of both signs cancelling, the
//! observed error is far smaller ([`resolution_bound`]).

use super::{
    container_bounds, container_volume, packing_fraction, periodic_axes, provenance_line,
    ExportError,
};
use crate::io::packing::{ContainerRecord, Packing, ParticleRecord};
use crate::io::record::PHASE_NAMES;
use rayon::prelude::*;
use std::io::Write;
use std::path::{Path, PathBuf};

/// What a voxel's label means.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum Labels {
    /// Phase id per shape kind (`uint8`).
    Phase,
    /// Particle index + 1 (`uint32`).
    Particle,
    /// Solid volume fraction of the voxel from `s³` sample points (`float32`, −1 outside a
    /// cylinder container): composite voxels ([`partial_volume`]).
    PartialVolume(usize),
}

/// Label of voxels outside a cylinder container, [`Labels::Phase`].
pub const OUTSIDE_PHASE: u8 = u8::MAX;
/// Label of voxels outside a cylinder container, [`Labels::Particle`].
pub const OUTSIDE_PARTICLE: u32 = u32::MAX;

/// The voxel grid over a container's bounding box.
#[derive(Clone, Copy, Debug, PartialEq, serde::Serialize)]
pub struct Grid {
    /// Voxels per axis.
    pub shape: [usize; 3],
    /// Voxel edge per axis.
    pub spacing: [f64; 3],
    /// Lower corner of the first voxel.
    pub origin: [f64; 3],
}

impl Grid {
    /// The grid with `voxels` voxels along the longest edge of the container's bounding box.
    pub fn new(container: &ContainerRecord, voxels: usize) -> Result<Grid, ExportError> {
        if voxels == 0 {
            return Err(ExportError::Invalid {
                option: "--voxels",
                message: "= 0 must be ≥ 1".into(),
            });
        }
        let (lo, hi) = container_bounds(container);
        let len: [f64; 3] = std::array::from_fn(|k| hi[k] - lo[k]);
        let h = len.iter().copied().fold(0.0, f64::max) / voxels as f64;
        let shape: [usize; 3] = std::array::from_fn(|k| ((len[k] / h).round() as usize).max(1));
        let total = shape.iter().try_fold(1usize, |a, &n| a.checked_mul(n));
        if total.is_none_or(|t| t > 1 << 34) {
            return Err(ExportError::Invalid {
                option: "--voxels",
                message: format!("= {voxels} gives {shape:?} voxels, more than 2³⁴"),
            });
        }
        Ok(Grid {
            shape,
            spacing: std::array::from_fn(|k| len[k] / shape[k] as f64),
            origin: lo,
        })
    }

    /// Number of voxels.
    pub fn len(&self) -> usize {
        self.shape.iter().product()
    }

    /// Whether the grid has no voxels (never, for a grid from [`Grid::new`]).
    pub fn is_empty(&self) -> bool {
        self.len() == 0
    }

    fn centre(&self, k: usize, i: i64) -> f64 {
        self.origin[k] + (i as f64 + 0.5) * self.spacing[k]
    }
}

/// Labels every voxel: `matrix` by default, `outside` where the centre is outside a cylinder
/// container, `label(index, particle)` where a particle contains the centre.
pub fn voxelize<T: Copy + Send>(
    packing: &Packing,
    grid: &Grid,
    matrix: T,
    outside: T,
    label: impl Fn(usize, &ParticleRecord) -> T + Sync,
) -> Vec<T> {
    let [nx, ny, nz] = grid.shape;
    let mut image = vec![matrix; grid.len()];
    if let ContainerRecord::Cylinder {
        base_center: b,
        radius,
        ..
    } = &packing.container
    {
        for i in 0..nx {
            let x = grid.centre(0, i as i64) - b[0];
            for j in 0..ny {
                let y = grid.centre(1, j as i64) - b[1];
                if x * x + y * y > radius * radius {
                    let row = (i * ny + j) * nz;
                    image[row..row + nz].fill(outside);
                }
            }
        }
    }
    for_each_inside_sample(packing, grid, 1, &mut image, |particle, voxel| {
        *voxel = label(particle, &packing.particles[particle]);
    });
    image
}

/// Calls `visit(particle index, its voxel of image)` for every sample point inside a
/// particle. Each voxel holds `s³` sample points `origin + (index + (m + ½)/s) · spacing`,
/// `m = 0 … s−1` per axis (`s = 1`: the voxel centre); periodic axes wrap.
///
/// The image (x-major) is cut into slabs of whole x-planes, filled on all threads: each slab
/// visits, in particle order, the particles whose bounding box meets it, so every voxel sees
/// its particles in the order one thread would (the last label written wins, as there).
fn for_each_inside_sample<T: Send>(
    packing: &Packing,
    grid: &Grid,
    s: usize,
    image: &mut [T],
    visit: impl Fn(usize, &mut T) + Sync,
) {
    let [nx, ny, nz] = grid.shape;
    let periodic = periodic_axes(&packing.container);
    let sample = |k: usize, i: i64, m: usize| {
        grid.origin[k] + (i as f64 + (m as f64 + 0.5) / s as f64) * grid.spacing[k]
    };
    let wrap = |k: usize, i: i64| i.rem_euclid(grid.shape[k] as i64) as usize;
    // Unwrapped index ranges of the voxels meeting a particle's bounding box.
    let range_of = |p: &ParticleRecord| -> [(i64, i64); 3] {
        let (c, r) = p.bounding_sphere();
        std::array::from_fn(|k| {
            let n = grid.shape[k] as i64;
            let first = ((c[k] - r - grid.origin[k]) / grid.spacing[k]).floor() as i64;
            let last = ((c[k] + r - grid.origin[k]) / grid.spacing[k]).floor() as i64;
            if periodic[k] {
                (first, last.min(first + n - 1))
            } else {
                (first.max(0), last.min(n - 1))
            }
        })
    };
    let planes = (nx / (4 * rayon::current_num_threads())).max(1);
    let slabs = nx.div_ceil(planes);
    // The particles of each slab, ascending.
    let mut members: Vec<Vec<u32>> = vec![Vec::new(); slabs];
    for (index, p) in packing.particles.iter().enumerate() {
        let (first, last) = range_of(p)[0];
        for i in first..=last {
            let slab = &mut members[wrap(0, i) / planes];
            if slab.last() != Some(&(index as u32)) {
                slab.push(index as u32);
            }
        }
    }
    image
        .par_chunks_mut(planes * ny * nz)
        .zip(members)
        .enumerate()
        .for_each(|(slab, (part, members))| {
            let x0 = slab * planes;
            for index in members.into_iter().map(|i| i as usize) {
                let p = &packing.particles[index];
                let range = range_of(p);
                for i in range[0].0..=range[0].1 {
                    let x = wrap(0, i);
                    if x < x0 || x >= x0 + planes {
                        continue;
                    }
                    for j in range[1].0..=range[1].1 {
                        let row = ((x - x0) * ny + wrap(1, j)) * nz;
                        for k in range[2].0..=range[2].1 {
                            let voxel = &mut part[row + wrap(2, k)];
                            for (mi, mj, mk) in
                                (0..s * s * s).map(|m| (m / (s * s), m / s % s, m % s))
                            {
                                let x = [sample(0, i, mi), sample(1, j, mj), sample(2, k, mk)];
                                if p.contains(x) {
                                    visit(index, voxel);
                                }
                            }
                        }
                    }
                }
            }
        });
}

/// Partial-volume image: per voxel the fraction of its `s³` sample points inside particles
/// (an estimate of the solid volume fraction of the voxel, for composite-voxel FFT schemes);
/// voxels outside a cylinder container get −1.
pub fn partial_volume(packing: &Packing, grid: &Grid, s: usize) -> Vec<f32> {
    let mut counts = vec![0u32; grid.len()];
    for_each_inside_sample(packing, grid, s, &mut counts, |_, count| *count += 1);
    let outside = voxelize(packing, grid, false, true, |_, _| false);
    let per_sample = 1.0 / (s * s * s) as f64;
    counts
        .iter()
        .zip(&outside)
        .map(|(&n, &out)| {
            if out {
                -1.0
            } else {
                (f64::from(n) * per_sample) as f32
            }
        })
        .collect()
}

/// First-order bound on `|φ_voxels − φ|`: total particle surface × half the voxel diagonal /
/// container volume (see the module docs).
pub fn resolution_bound(packing: &Packing, grid: &Grid) -> f64 {
    let half_diagonal = 0.5 * grid.spacing.iter().map(|h| h * h).sum::<f64>().sqrt();
    let surface: f64 = packing
        .particles
        .iter()
        .map(ParticleRecord::surface_area)
        .sum();
    surface * half_diagonal / container_volume(&packing.container)
}

/// Options of a voxel export.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct VoxelOptions {
    /// Voxels along the longest edge of the container's bounding box.
    pub voxels: usize,
    /// Label kind.
    pub labels: Labels,
    /// `.npy` (with its header) or raw bytes.
    pub npy: bool,
}

/// What a voxel export wrote.
#[derive(Clone, Debug, PartialEq, serde::Serialize)]
pub struct VoxelSummary {
    /// The grid.
    #[serde(flatten)]
    pub grid: Grid,
    /// Exact packing fraction of the particles.
    pub packing_fraction_exact: f64,
    /// Particle voxels × voxel volume / container volume.
    pub packing_fraction_voxels: f64,
    /// First-order bound on their difference ([`resolution_bound`]).
    pub resolution_bound: f64,
    /// The sidecar file (`.npy` and raw only).
    pub sidecar: Option<PathBuf>,
}

/// The sidecar path of a voxel file: `FILE.json`.
pub fn sidecar_path(path: &Path) -> PathBuf {
    let mut s = path.as_os_str().to_owned();
    s.push(".json");
    PathBuf::from(s)
}

/// The NumPy format 1.0 header for a C-order array. Hand-written: the format is a magic
/// string, a version, a length and a Python dict literal padded to 64 bytes, and the crates
/// that write it bring a whole array library along.
fn npy_header(descr: &str, shape: [usize; 3]) -> Vec<u8> {
    let dict = format!(
        "{{'descr': '{descr}', 'fortran_order': False, 'shape': ({}, {}, {}), }}",
        shape[0], shape[1], shape[2]
    );
    // magic (6) + version (2) + header length (2) + dict + padding + '\n' ≡ 0 (mod 64)
    let unpadded = 10 + dict.len() + 1;
    let padding = (64 - unpadded % 64) % 64;
    let mut h = b"\x93NUMPY\x01\x00".to_vec();
    h.extend_from_slice(&((dict.len() + padding + 1) as u16).to_le_bytes());
    h.extend_from_slice(dict.as_bytes());
    h.extend(std::iter::repeat_n(b' ', padding));
    h.push(b'\n');
    h
}

/// A voxel image in memory, C order (`[nx, ny, nz]`, z fastest), one variant per label kind.
#[derive(Clone, Debug, PartialEq)]
pub enum VoxelImage {
    /// [`Labels::Phase`].
    Phase(Vec<u8>),
    /// [`Labels::Particle`].
    Particle(Vec<u32>),
    /// [`Labels::PartialVolume`]: the solid fraction of each voxel from `samples³` points.
    PartialVolume {
        /// Sample points per axis and voxel.
        samples: usize,
        /// Solid fraction per voxel (−1 outside a cylinder container).
        fractions: Vec<f32>,
    },
}

impl VoxelImage {
    /// The image of `packing` on `grid` with `labels` (sample counts of
    /// [`Labels::PartialVolume`] in `1..=16`).
    pub fn of(packing: &Packing, grid: &Grid, labels: Labels) -> Result<Self, ExportError> {
        Ok(match labels {
            Labels::Phase => Self::Phase(voxelize(packing, grid, 0u8, OUTSIDE_PHASE, |_, p| {
                p.phase()
            })),
            Labels::Particle => {
                Self::Particle(voxelize(packing, grid, 0u32, OUTSIDE_PARTICLE, |i, _| {
                    i as u32 + 1
                }))
            }
            Labels::PartialVolume(samples) => {
                if samples == 0 || samples > 16 {
                    return Err(ExportError::Invalid {
                        option: "--partial-volume",
                        message: format!("= {samples} is outside the allowed range 1..=16"),
                    });
                }
                Self::PartialVolume {
                    samples,
                    fractions: partial_volume(packing, grid, samples),
                }
            }
        })
    }

    /// Solid volume in voxels: particle voxels, or the sum of the solid fractions.
    fn solid_voxels(&self) -> f64 {
        match self {
            Self::Phase(v) => v.iter().filter(|&&x| x != 0 && x != OUTSIDE_PHASE).count() as f64,
            Self::Particle(v) => v
                .iter()
                .filter(|&&x| x != 0 && x != OUTSIDE_PARTICLE)
                .count() as f64,
            Self::PartialVolume { fractions, .. } => fractions
                .iter()
                .filter(|&&x| x > 0.0)
                .map(|&x| f64::from(x))
                .sum(),
        }
    }

    /// The element type: its name and its NumPy `descr`.
    pub(super) fn dtype(&self) -> (&'static str, &'static str) {
        match self {
            Self::Phase(_) => ("uint8", "|u1"),
            Self::Particle(_) => ("uint32", "<u4"),
            Self::PartialVolume { .. } => ("float32", "<f4"),
        }
    }

    /// The voxels as little-endian bytes.
    pub(super) fn write_le(&self, w: &mut impl Write) -> std::io::Result<()> {
        match self {
            Self::Phase(v) => w.write_all(v),
            Self::Particle(v) => v.iter().try_for_each(|x| w.write_all(&x.to_le_bytes())),
            Self::PartialVolume { fractions, .. } => fractions
                .iter()
                .try_for_each(|x| w.write_all(&x.to_le_bytes())),
        }
    }

    /// What the values mean, for the sidecar.
    fn meaning(&self) -> serde_json::Value {
        match self {
            Self::Phase(_) => {
                let mut names = serde_json::Map::new();
                for (id, name) in PHASE_NAMES {
                    names.insert(id.to_string(), name.into());
                }
                names.insert(OUTSIDE_PHASE.to_string(), "outside the container".into());
                serde_json::Value::Object(names)
            }
            Self::Particle(_) => serde_json::json!({
                "0": "matrix",
                "i + 1": "particle i (packing order)",
                OUTSIDE_PARTICLE.to_string(): "outside the container",
            }),
            Self::PartialVolume { samples, .. } => {
                serde_json::json!({
                    "value": format!(
                        "fraction of the voxel's {samples}³ sample points (x_i + (m + 0.5)/{samples} \
                         spacing) inside particles"
                    ),
                    "samples_per_axis": samples,
                    "-1": "outside the container (voxel centre outside the cylinder)",
                })
            }
        }
    }
}

/// Voxelises `packing` with `voxels` along the longest edge and `labels`: the image and its
/// summary (packing fractions exact and in voxels, resolution bound; no sidecar yet). Every
/// voxel format ([`write_voxels`], [`super::vti`], [`super::abaqus`]) starts here.
pub fn image_and_summary(
    packing: &Packing,
    voxels: usize,
    labels: Labels,
) -> Result<(VoxelImage, VoxelSummary), ExportError> {
    let grid = Grid::new(&packing.container, voxels)?;
    let voxel_volume: f64 = grid.spacing.iter().product();
    let image = VoxelImage::of(packing, &grid, labels)?;
    let summary = VoxelSummary {
        grid,
        packing_fraction_exact: packing_fraction(packing),
        packing_fraction_voxels: image.solid_voxels() * voxel_volume
            / container_volume(&packing.container),
        // Sample points `s` times denser than the voxels: the bound of that finer grid.
        resolution_bound: resolution_bound(packing, &grid)
            / match labels {
                Labels::PartialVolume(samples) => samples as f64,
                Labels::Phase | Labels::Particle => 1.0,
            },
        sidecar: None,
    };
    Ok((image, summary))
}

/// Voxelises `packing` and writes the image and its sidecar.
pub fn write_voxels(
    packing: &Packing,
    opts: &VoxelOptions,
    path: &Path,
) -> Result<VoxelSummary, ExportError> {
    let (image, mut summary) = image_and_summary(packing, opts.voxels, opts.labels)?;
    let grid = summary.grid;
    let (dtype, descr) = image.dtype();
    super::write_file(path, |w| {
        if opts.npy {
            w.write_all(&npy_header(descr, grid.shape))?;
        }
        image.write_le(w)
    })?;
    let labels_json = image.meaning();
    let sidecar_path = sidecar_path(path);
    let sidecar = serde_json::json!({
        "format": "densepack-voxels",
        "version": 1,
        "file": path.file_name().map(|n| n.to_string_lossy().into_owned()),
        "encoding": if opts.npy { "npy" } else { "raw" },
        "dtype": dtype,
        "numpy_descr": descr,
        "byte_order": "little",
        "order": "C: shape [nx, ny, nz], z fastest, index = (i*ny + j)*nz + k",
        "shape": grid.shape,
        "spacing": grid.spacing,
        "origin": grid.origin,
        "voxel_centre": "origin + (index + 0.5) * spacing",
        "periodic": periodic_axes(&packing.container),
        "labels": labels_json,
        "packing_fraction_exact": summary.packing_fraction_exact,
        "packing_fraction_voxels": summary.packing_fraction_voxels,
        "resolution_bound": summary.resolution_bound,
        "seed": packing.seed,
        "provenance": provenance_line(packing),
    });
    super::write_file(&sidecar_path, |w| {
        serde_json::to_writer_pretty(&mut *w, &sidecar).map_err(std::io::Error::other)?;
        writeln!(w)
    })?;
    summary.sidecar = Some(sidecar_path);
    Ok(summary)
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::io::record::SphereRecord;

    fn packing(container: ContainerRecord, particles: Vec<ParticleRecord>) -> Packing {
        Packing::new(container, particles)
    }

    fn cube(periodic: bool) -> ContainerRecord {
        ContainerRecord::Box {
            min: [0.0; 3],
            max: [10.0; 3],
            periodic: [periodic; 3],
        }
    }

    fn sphere(center: [f64; 3], radius: f64) -> ParticleRecord {
        ParticleRecord::Sphere(SphereRecord { center, radius })
    }

    /// Filled on several threads, the images equal one thread's voxel for voxel, where
    /// overlapping spheres make the label depend on the order particles are visited in
    /// (random spheres in a box periodic along x and y, crossing its faces).
    #[test]
    fn images_on_many_threads_equal_one_threads() {
        use rand::{Rng, SeedableRng};
        let mut rng = rand_xoshiro::Xoshiro256PlusPlus::seed_from_u64(3);
        let particles = (0..3000)
            .map(|_| {
                let center = std::array::from_fn(|_| rng.gen_range(0.0..10.0));
                sphere(center, rng.gen_range(0.1..0.8))
            })
            .collect();
        let container = ContainerRecord::Box {
            min: [0.0; 3],
            max: [10.0; 3],
            periodic: [true, true, false],
        };
        let p = packing(container, particles);
        let grid = Grid::new(&p.container, 37).unwrap();
        let images = |threads: usize| {
            rayon::ThreadPoolBuilder::new()
                .num_threads(threads)
                .build()
                .unwrap()
                .install(|| {
                    (
                        voxelize(&p, &grid, 0u32, u32::MAX, |i, _| i as u32 + 1),
                        partial_volume(&p, &grid, 2),
                    )
                })
        };
        let one = images(1);
        assert!(one.0.iter().filter(|&&l| l > 0).count() > grid.len() / 2);
        for threads in [2, 5] {
            assert_eq!(images(threads), one);
        }
    }

    #[test]
    fn npy_header_is_padded_to_64_bytes_and_ends_with_a_newline() {
        let h = npy_header("|u1", [3, 4, 5]);
        assert_eq!(h.len() % 64, 0);
        assert_eq!(*h.last().unwrap(), b'\n');
        let len = u16::from_le_bytes([h[8], h[9]]) as usize;
        assert_eq!(len + 10, h.len());
    }

    #[test]
    fn a_sphere_crossing_a_corner_of_a_periodic_box_labels_the_same_voxels_as_when_centred() {
        // Voxel centres sit at (i + ½)·0.5; shifting the sphere by a whole number of voxels
        // (here −5 along every axis, across the corner) must only permute the labels.
        let grid = Grid::new(&cube(true), 20).unwrap();
        let centred = packing(cube(true), vec![sphere([5.1, 4.9, 5.05], 2.3)]);
        let wrapped = packing(cube(true), vec![sphere([0.1, 9.9, 0.05], 2.3)]);
        let a = voxelize(&centred, &grid, 0u8, 9, |_, p| p.phase());
        let b = voxelize(&wrapped, &grid, 0u8, 9, |_, p| p.phase());
        let count = |v: &[u8]| v.iter().filter(|&&x| x == 1).count();
        assert!(count(&a) > 0);
        assert_eq!(count(&a), count(&b));
        for i in 0..20 {
            for j in 0..20 {
                for k in 0..20 {
                    let wi = (i + 10) % 20;
                    let wj = (j + 10) % 20;
                    let wk = (k + 10) % 20;
                    assert_eq!(a[(i * 20 + j) * 20 + k], b[(wi * 20 + wj) * 20 + wk]);
                }
            }
        }
    }

    #[test]
    fn voxel_fraction_of_a_sphere_converges_to_its_volume_within_the_bound() {
        let p = packing(cube(false), vec![sphere([4.3, 5.2, 5.7], 3.1)]);
        let exact = 4.0 / 3.0 * std::f64::consts::PI * 3.1f64.powi(3) / 1000.0;
        for voxels in [16, 64, 128] {
            let grid = Grid::new(&p.container, voxels).unwrap();
            let image = voxelize(&p, &grid, 0u8, 9, |_, p| p.phase());
            let phi = image.iter().filter(|&&v| v == 1).count() as f64 / grid.len() as f64;
            let bound = resolution_bound(&p, &grid);
            assert!(
                (phi - exact).abs() <= bound,
                "{voxels}: {phi} vs {exact} (bound {bound})"
            );
        }
    }

    #[test]
    fn partial_volumes_lie_in_0_1_and_sum_to_the_sphere_volume_within_the_finer_bound() {
        let p = packing(cube(true), vec![sphere([9.3, 5.2, 0.4], 2.2)]); // wraps in x and z
        let exact = 4.0 / 3.0 * std::f64::consts::PI * 2.2f64.powi(3);
        let grid = Grid::new(&p.container, 20).unwrap();
        let samples = 4;
        let image = partial_volume(&p, &grid, samples);
        assert!(image.iter().all(|&v| (0.0..=1.0).contains(&v)));
        assert!(image.iter().any(|&v| v > 0.0 && v < 1.0)); // composite voxels at the surface
        let volume: f64 = image.iter().map(|&v| f64::from(v)).sum::<f64>() * 0.125;
        let bound = resolution_bound(&p, &grid) / samples as f64 * 1000.0;
        assert!(
            (volume - exact).abs() <= bound,
            "{volume} vs {exact} (bound {bound})"
        );
    }

    #[test]
    fn cylinder_voxels_outside_the_mantle_are_labelled_outside() {
        let c = ContainerRecord::Cylinder {
            base_center: [0.0; 3],
            radius: 5.0,
            height: 10.0,
        };
        let p = packing(c, vec![]);
        let grid = Grid::new(&p.container, 100).unwrap();
        let image = voxelize(&p, &grid, 0u8, OUTSIDE_PHASE, |_, p| p.phase());
        let inside = image.iter().filter(|&&v| v == 0).count() as f64 / grid.len() as f64;
        // Fraction of the square cross-section inside the circle: π/4.
        assert!(
            (inside - std::f64::consts::FRAC_PI_4).abs() < 2e-3,
            "{inside}"
        );
    }
}
