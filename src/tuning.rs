//! Defaults and bounds of the kernel settings a scene may set (`kernel::KernelConfig`).
//!
//! A leaf module that depends on nothing: the kernel takes its defaults and its skin cap
//! from here (and re-exports [`MAX_SKIN`]), and the scene schema (`io::scene`) gives the same
//! defaults and validates against the same bound without depending on the kernel. Turning a
//! scene into kernel settings is the runner's work (`run`).

/// Temperature `kT` of the initial velocities and of the thermostat when a scene gives none.
pub const DEFAULT_TEMPERATURE: f64 = 1.0;

/// Target number of events per particle between two time barriers when a scene gives none
/// (BENCHMARKS.md, "Defaults").
pub const DEFAULT_EVENTS_PER_INTERVAL: f64 = 4.0;

/// Initial neighbour-list skin, relative to the particle's bounding radius, when a scene
/// gives none (BENCHMARKS.md, "Defaults"); the kernel adapts it at barriers.
pub const DEFAULT_NEIGHBOUR_SKIN: f64 = 0.1;

/// Largest neighbour-list skin the kernel adapts to, and the largest a scene may start
/// with. Thicker skins lengthen the lists (their memory grows with the cube of `1 + skin`)
/// for little gain: in the φ = 0.5 fluid a fixed skin of 0.4 was as fast as any.
pub const MAX_SKIN: f64 = 0.5;
