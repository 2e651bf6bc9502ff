//! `densepack analyse PACKING`: is a sphere or ellipsoid packing jammed? Contacts against the
//! gap cut-off (the plateau), rattlers, the backbone's contact number beside the isostatic
//! one, Q6 and (spheres) the LP certificate of collective jamming
//! ([`densepack::analysis::jamming`]), then the structure: g(r), size classes and wall
//! profiles ([`densepack::analysis::structure`]).

use clap::Args;
use densepack::analysis::jamming::{jamming_report, JammingReport, DEFAULT_CUTOFF, Q6_FCC};
use densepack::analysis::structure::{
    check_gr, structure_report, StructureReport, DEFAULT_GR_BINS, DEFAULT_GR_RANGE,
    SLABS_PER_DIAMETER,
};
use densepack::io::packing::Packing;
use std::path::PathBuf;
use std::process::ExitCode;

/// Arguments of `densepack analyse`.
#[derive(Args, Debug)]
pub struct AnalyseArgs {
    /// Packing file (JSON).
    pub packing: PathBuf,
    /// Relative gap below which two particles (or a particle and a wall) touch: for spheres
    /// the surface gap over the sum of radii, for ellipsoids the Perram–Wertheim scale
    /// factor minus one.
    #[arg(long, default_value_t = DEFAULT_CUTOFF)]
    pub cutoff: f64,
    /// Skip the linear-programming test of collective jamming (it takes seconds to minutes
    /// for 10⁴ spheres; packings with ellipsoids always skip it).
    #[arg(long)]
    pub no_lp: bool,
    /// Seconds each of the LP test's two programs may take.
    #[arg(long, default_value_t = 600.0)]
    pub lp_seconds: f64,
    /// Seed of the LP test's random load.
    #[arg(long, default_value_t = 1)]
    pub seed: u64,
    /// Number of bins of the radial distribution function g(r) over [0, --gr-range).
    #[arg(long, default_value_t = DEFAULT_GR_BINS)]
    pub gr_bins: usize,
    /// Upper end of g(r) in r/(r_i + r_j) (contact is 1).
    #[arg(long, default_value_t = DEFAULT_GR_RANGE, allow_negative_numbers = true)]
    pub gr_range: f64,
    /// Print the report as JSON.
    #[arg(long)]
    pub json: bool,
}

/// The JSON output: the jamming report's fields, and the structure under `structure`.
#[derive(serde::Serialize)]
struct Output<'a> {
    #[serde(flatten)]
    jamming: &'a JammingReport,
    structure: &'a StructureReport,
}

/// Most particles whose contact network `densepack run` counts after a pressure stop: the
/// count (no LP) is linear in N, a fraction of a second below this size.
const RUN_SUMMARY_MAX_PARTICLES: usize = 200_000;

/// One line for `densepack run` after a stage stopped at its pressure goal: the contact
/// network at the default cut-off (rattlers, backbone contact number against the isostatic
/// one), because a pressure stop alone does not make a packing jammed. `None` for mixtures
/// with cylinders; larger packings get the advice to run `analyse`.
pub fn run_summary(packing: &Packing) -> Option<String> {
    if packing.particles.len() > RUN_SUMMARY_MAX_PARTICLES {
        return Some(format!(
            "contact network: not counted above {RUN_SUMMARY_MAX_PARTICLES} particles; \
             `densepack analyse` judges whether the packing is jammed"
        ));
    }
    let r = jamming_report(packing, DEFAULT_CUTOFF, false, 0, 0.0).ok()?;
    let row = &r.at_cutoff;
    Some(
        match (row.backbone_mean_contacts, row.constraints_per_freedom) {
            (Some(z), Some(per)) => format!(
            "contact network at cut-off {:e}: rattlers {:.2} %, backbone Z {z:.4} (isostatic {}), \
             contacts per freedom {per:.4}{}; `densepack analyse` adds the LP certificate",
            r.cutoff,
            100.0 * row.rattler_fraction,
            r.isostatic_contacts,
            // Hypostatic ellipsoid packings can be jammed (curvature), sphere packings not.
            if per < 1.0 && r.ellipsoids == 0 {
                " (hypostatic: not jammed)"
            } else {
                ""
            },
        ),
            _ => format!(
                "contact network at cut-off {:e}: every particle is a rattler, no rigid backbone: \
             NOT jammed (grow more slowly near the end, see `adaptive` in docs/scenes.md)",
                r.cutoff
            ),
        },
    )
}

/// Runs `analyse`: exit 0 with the report, 2 on an unreadable packing or a bad option.
pub fn run(args: &AnalyseArgs) -> ExitCode {
    if let Err(e) = check_gr(args.gr_bins, args.gr_range) {
        errln!("error: {e}");
        return ExitCode::from(2);
    }
    let packing = match Packing::read(&args.packing) {
        Ok(p) => p,
        Err(e) => {
            errln!("error: {e}");
            return ExitCode::from(2);
        }
    };
    let report = match jamming_report(
        &packing,
        args.cutoff,
        !args.no_lp,
        args.seed,
        args.lp_seconds,
    ) {
        Ok(r) => r,
        Err(e) => {
            errln!("error: {e}");
            return ExitCode::from(2);
        }
    };
    let structure = match structure_report(&packing, &report, args.gr_bins, args.gr_range) {
        Ok(s) => s,
        Err(e) => {
            errln!("error: {e}");
            return ExitCode::from(2);
        }
    };
    if args.json {
        let output = Output {
            jamming: &report,
            structure: &structure,
        };
        outln!(
            "{}",
            serde_json::to_string_pretty(&output).expect("serialisable")
        );
    } else {
        out!("{}{}", text(&report), structure_text(&structure));
    }
    ExitCode::SUCCESS
}

/// The report for people.
fn text(r: &JammingReport) -> String {
    let opt = |x: Option<f64>| x.map_or("–".to_string(), |v| format!("{v:.4}"));
    // A whole number as such (3, 5, 6, 10, 12), a mean of mixed shapes to two decimals.
    let count = |x: f64| {
        if x.fract() == 0.0 {
            format!("{x:.0}")
        } else {
            format!("{x:.2}")
        }
    };
    let what = match r.ellipsoids {
        0 => format!("spheres {}", r.particles),
        e if e == r.particles => format!(
            "ellipsoids {} ({} degrees of freedom each)",
            r.particles,
            count(r.freedoms_per_particle)
        ),
        e => format!("particles {} ({e} ellipsoids)", r.particles),
    };
    let mut s = format!(
        "{what}  contact cut-off {:.0e}  rigid translations {}\n",
        r.cutoff, r.trivial_motions
    );
    s += "cut-off   contacts/particle  rattlers   backbone Z  contacts/freedom\n";
    for row in &r.plateau {
        s += &format!(
            "{:>7.0e}   {:>17.4}  {:>7.2} %  {:>10}  {:>16}\n",
            row.cutoff,
            row.mean_contacts,
            100.0 * row.rattler_fraction,
            opt(row.backbone_mean_contacts),
            opt(row.constraints_per_freedom),
        );
    }
    let a = &r.at_cutoff;
    s += &format!(
        "at {:.0e}: rattlers {:.2} %, backbone Z {} (isostatic: {} for a periodic packing), \
         contacts per freedom {} (isostatic: 1)\n",
        a.cutoff,
        100.0 * a.rattler_fraction,
        opt(a.backbone_mean_contacts),
        count(r.isostatic_contacts),
        opt(a.constraints_per_freedom)
    );
    // A count still growing a hundredfold further out: the cut-off is below the plateau.
    let further = r.plateau.iter().find(|row| row.cutoff >= 99.0 * r.cutoff);
    if let Some(row) = further.filter(|row| a.mean_contacts < 0.95 * row.mean_contacts) {
        s += &format!(
            "note: the cut-off is below the plateau ({:.4} contacts per particle at {:.0e}): \
             a packing at reduced pressure P has its contacts within about 1/P; pick a \
             cut-off on the plateau with --cutoff\n",
            row.mean_contacts, row.cutoff
        );
    }
    if r.ellipsoids > 0 {
        s += "jammed ellipsoid packings are hypostatic (Z below the isostatic count; Donev et al. \
              2004, 2007): rattlers have fewer than 4 contacts\n";
    }
    s += &format!(
        "Q6 {:.4} over {} bonds (random directions {:.4}, FCC {Q6_FCC})\n",
        r.q6, r.bonds, r.q6_random
    );
    if r.lp_skipped {
        s += "LP test: skipped (first-order and for spheres only: rotations and curvature \
              decide the jamming of ellipsoids)\n";
    }
    if let Some(lp) = r.lp.as_ref().filter(|lp| lp.seconds == 0.0 && !lp.jammed) {
        s += &format!(
            "LP test: NOT jammed, by counting: {} (floppy motions exist)\n",
            lp.status[0].trim_start_matches("not solved: ")
        );
    } else if let Some(lp) = &r.lp {
        let carried = |c: Option<bool>| match c {
            Some(true) => "carried",
            Some(false) => "not carried",
            None => "undecided",
        };
        s += &format!(
            "LP test: {} (random load {}, its opposite {}; largest force {:.3} × the mean \
             load; solver {} / {}, {:.1} s)\n",
            if lp.jammed {
                "collectively jammed"
            } else if lp.loads_carried.contains(&None) {
                "no verdict"
            } else {
                "NOT jammed: an unjamming or floppy motion exists"
            },
            carried(lp.loads_carried[0]),
            carried(lp.loads_carried[1]),
            lp.max_force,
            lp.status[0],
            lp.status[1],
            lp.seconds
        );
    }
    s
}

/// The structure part of the report for people: g(r)'s peaks, the size classes and a line
/// per wall profile.
fn structure_text(r: &StructureReport) -> String {
    let mut s = String::new();
    if let Some(g) = &r.radial_distribution {
        s += &format!(
            "g(r) over r/(r_i + r_j) in [0, {:.3}), bins of {:.4}{}; {} reference particles{}\n",
            g.range,
            g.bin_width,
            if g.range_cut {
                " (range cut to half the periodic box)"
            } else {
                ""
            },
            g.references,
            if g.wall_margin > 0.0 {
                format!(" (centres at least {:.4} from every wall)", g.wall_margin)
            } else {
                String::new()
            }
        );
        if let Some(p) = &g.first_peak {
            s += &format!("  first peak at {:.3}, g = {:.2}\n", p.position, p.height);
        }
        if let Some(p) = &g.second_peak {
            s += &format!(
                "  second peak: {} at {:.3} (g = {:.2}) and {:.3} (g = {:.2}); √3 = 1.732, 2\n",
                if p.split {
                    "split, sub-peaks"
                } else {
                    "not split, highest bins"
                },
                p.near_sqrt3.position,
                p.near_sqrt3.height,
                p.near_2.position,
                p.near_2.height
            );
        }
    }
    let filled: Vec<_> = r.size_classes.iter().filter(|c| c.count > 0).collect();
    s += &format!(
        "size classes (diameter): {} of {} filled; mean diameter {:.4}, packing fraction {:.4}\n",
        filled.len(),
        r.size_classes.len(),
        r.mean_diameter,
        r.packing_fraction
    );
    s += "  diameter             count   volume  contacts/particle  rattlers\n";
    for c in filled {
        s += &format!(
            "  {:>8.4} – {:<8.4}  {:>7}  {:>5.1} %  {:>17}  {:>6.2} %\n",
            c.lo,
            c.hi,
            c.count,
            100.0 * c.volume_share,
            c.mean_contacts.map_or("–".into(), |z| format!("{z:.4}")),
            100.0 * c.rattler_fraction.unwrap_or(0.0)
        );
    }
    for w in &r.wall_profiles {
        let (first, densest, mean) = (
            w.fraction[0],
            w.fraction
                .iter()
                .enumerate()
                .fold((0, f64::NEG_INFINITY), |best, (k, &f)| {
                    if f > best.1 {
                        (k, f)
                    } else {
                        best
                    }
                }),
            w.fraction.iter().sum::<f64>() / w.fraction.len() as f64,
        );
        s += &format!(
            "wall {:<4} slabs of {:.4}: packing fraction {:.4} at the wall, densest {:.4} at \
             {:.2} d, mean {:.4} over {:.1} d\n",
            w.wall,
            w.slab_width,
            first,
            densest.1,
            w.distance[densest.0],
            mean,
            w.fraction.len() as f64 / SLABS_PER_DIAMETER
        );
    }
    for note in &r.notes {
        s += &format!("skipped: {note}\n");
    }
    s
}
