//! Packings written by other tools, read into a [`Packing`] (`densepack import`).
//!
//! | source | file | particles | container |
//! |---|---|---|---|
//! | `csv` | header line naming the columns, then one row per sphere, comma-separated: `x`, `y`, `z` and `r` (radius) or `d` (diameter); other columns are ignored, a `type` column must say `sphere`; `#` comment and blank lines skipped (densepack's sphere CSV) | spheres | from the caller |
//! | `xyzd` | PackingGeneration's binary: per sphere four little-endian `f64` `x y z d` ([`crate::io::export::xyzd`]) | spheres | from the caller |
//! | `lammps-data` | LAMMPS data file, `Atoms # sphere` section (`id type diameter density x y z [ix iy iz]`) | spheres | the box bounds; periodic axes from the caller, else a `boundary p p f` note on the first line (densepack's export writes it), else walls |
//! | `lammps-dump` | LAMMPS text dump (`dump custom`): the last snapshot, columns `x y z` (or `xu yu zu`, or scaled `xs ys zs`) and `radius` or `diameter` | spheres | the `BOX BOUNDS` and their `pp`/`ff` flags (orthogonal boxes only) |
//! | `json` | a packing JSON (`densepack-packing` version 1; `min_gap`, `seed` and `stats` may be absent) | any | its own |
//!
//! A container given by the caller ([`ImportOptions::container`]) replaces the file's.
//! Lengths keep the file's unit; particles keep the file's order. Every reader rejects
//! malformed input naming the line (or binary record) and the field. The packing's
//! provenance records the file and format ([`Provenance::imported_from`]); it promises no gap
//! (`min_gap = 0`), so `verify` checks overlaps and containment only.

use crate::io::packing::{
    ContainerRecord, ImportedFrom, Packing, PackingError, ParticleRecord, Provenance, Timings,
};
use crate::io::record::SphereRecord;
use std::path::Path;

/// A file format `densepack import` reads (`--from`).
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum Source {
    /// Comma-separated table of spheres.
    Csv,
    /// PackingGeneration's binary `.xyzd`.
    Xyzd,
    /// LAMMPS data file, atom style sphere.
    LammpsData,
    /// LAMMPS text dump.
    LammpsDump,
    /// Packing JSON.
    Json,
}

impl Source {
    /// Every source, in the order the help lists them.
    pub const ALL: [Source; 5] = [
        Source::Csv,
        Source::Xyzd,
        Source::LammpsData,
        Source::LammpsDump,
        Source::Json,
    ];

    /// The name on the command line.
    pub fn name(self) -> &'static str {
        match self {
            Source::Csv => "csv",
            Source::Xyzd => "xyzd",
            Source::LammpsData => "lammps-data",
            Source::LammpsDump => "lammps-dump",
            Source::Json => "json",
        }
    }

    /// One line for people: what the reader expects (the CLI's `--help` lists it).
    pub fn describe(self) -> &'static str {
        match self {
            Source::Csv => {
                "Comma-separated table with a header naming x,y,z and r (radius) or d (diameter)"
            }
            Source::Xyzd => "PackingGeneration's binary .xyzd (little-endian doubles x y z d)",
            Source::LammpsData => {
                "LAMMPS data file, atom style sphere (id type diameter density x y z)"
            }
            Source::LammpsDump => {
                "LAMMPS text dump (last snapshot): x y z (or xu.., xs..) and radius or diameter"
            }
            Source::Json => "A packing JSON (min_gap, seed and stats may be absent)",
        }
    }

    /// The source called `name`; the error lists the sources.
    pub fn parse(name: &str) -> Result<Self, ImportError> {
        Self::ALL
            .into_iter()
            .find(|s| s.name() == name)
            .ok_or_else(|| ImportError::Invalid {
                option: "--from",
                message: format!(
                    "= {name:?} is not a format this reads; the formats are {}",
                    Self::ALL.map(Source::name).join(", ")
                ),
            })
    }
}

/// Why an import failed.
#[derive(Debug, thiserror::Error)]
pub enum ImportError {
    /// Reading the file failed.
    #[error("{path}: {source}")]
    Io {
        /// The file.
        path: String,
        /// The cause.
        source: std::io::Error,
    },
    /// The file is malformed at `at` (a line, or a record of a binary file).
    #[error("{path}: {at}: {field}: {message}")]
    Malformed {
        /// The file.
        path: String,
        /// Where: `line 7`, `record 3 (byte 96)`, `end of file`.
        at: String,
        /// The field (column, keyword) at fault.
        field: String,
        /// What is wrong and what is allowed.
        message: String,
    },
    /// The container options do not fit the file (names the option).
    #[error("{option}: {message}")]
    Invalid {
        /// The option, as on the command line.
        option: &'static str,
        /// What is wrong.
        message: String,
    },
    /// A packing JSON that does not read, or a container that is not a body.
    #[error("{0}")]
    Packing(#[from] PackingError),
}

/// The container options of an import.
#[derive(Clone, Debug, Default, PartialEq)]
pub struct ImportOptions {
    /// The container, replacing the file's (required for `csv` and `xyzd`).
    pub container: Option<ContainerRecord>,
    /// Periodic axes of a box container from the file (`lammps-data`; for other box
    /// containers give them in [`ImportOptions::container`]).
    pub periodic: Option<[bool; 3]>,
}

impl ImportOptions {
    /// The options of a specimen given as numbers, as on the command line and in Python:
    /// `r#box` the edges `[x, y, z]` of a box at the origin, `cylinder` `[radius, height]`
    /// (axis along z, base centre at the origin), `periodic` three flags — in the box when
    /// one is given, else for the file's own box. Errors name the option and the count or
    /// range that is wrong.
    pub fn of_specimen(
        r#box: Option<&[f64]>,
        cylinder: Option<&[f64]>,
        periodic: Option<&[bool]>,
    ) -> Result<Self, ImportError> {
        let invalid =
            |option: &'static str, message: String| ImportError::Invalid { option, message };
        let periodic = match periodic {
            None => None,
            Some(&[a, b, c]) => Some([a, b, c]),
            Some(p) => {
                return Err(invalid(
                    "--periodic",
                    format!("{} values given, expected 3", p.len()),
                ))
            }
        };
        let (container, option) = match (r#box, cylinder) {
            (Some(_), Some(_)) => {
                return Err(invalid(
                    "--box",
                    "give the specimen as a box or a cylinder, not both".into(),
                ))
            }
            (Some(&[x, y, z]), None) => (
                Some(ContainerRecord::Box {
                    min: [0.0; 3],
                    max: [x, y, z],
                    periodic: periodic.unwrap_or([false; 3]),
                }),
                "--box",
            ),
            (Some(b), None) => {
                return Err(invalid(
                    "--box",
                    format!("{} values given, expected X,Y,Z", b.len()),
                ))
            }
            (None, Some(&[radius, height])) => (
                Some(ContainerRecord::Cylinder {
                    base_center: [0.0; 3],
                    radius,
                    height,
                }),
                "--cylinder",
            ),
            (None, Some(c)) => {
                return Err(invalid(
                    "--cylinder",
                    format!("{} values given, expected RADIUS,HEIGHT", c.len()),
                ))
            }
            (None, None) => (None, ""),
        };
        if let Some(c) = &container {
            c.check().map_err(|e| invalid(option, e))?;
        }
        Ok(ImportOptions {
            // Periodic flags alone apply to the file's box; with a box they are in it.
            periodic: periodic.filter(|_| container.is_none()),
            container,
        })
    }
}

/// The words of a LAMMPS data-file line before its `#` comment.
fn data_words(line: &str) -> Vec<&str> {
    line.split('#')
        .next()
        .unwrap_or("")
        .split_whitespace()
        .collect()
}

/// What a reader found: the particles and the container if the file has one.
#[derive(Debug)]
struct Read {
    particles: Vec<ParticleRecord>,
    container: Option<ContainerRecord>,
}

/// A malformed-input error of one reader, before the path is known.
#[derive(Debug)]
struct Bad {
    at: String,
    field: String,
    message: String,
}

fn bad(line: usize, field: impl Into<String>, message: impl Into<String>) -> Bad {
    Bad {
        at: format!("line {line}"),
        field: field.into(),
        message: message.into(),
    }
}

/// Parses `text` as a finite number for `field` on `line`.
fn number(text: &str, line: usize, field: &str) -> Result<f64, Bad> {
    match text.trim().parse::<f64>() {
        Ok(v) if v.is_finite() => Ok(v),
        _ => Err(bad(line, field, format!("{text:?} is not a finite number"))),
    }
}

/// A sphere, its diameter checked to be > 0.
fn sphere(
    center: [f64; 3],
    diameter: f64,
    line: usize,
    field: &str,
) -> Result<ParticleRecord, Bad> {
    if diameter > 0.0 {
        Ok(ParticleRecord::Sphere(SphereRecord {
            center,
            radius: 0.5 * diameter,
        }))
    } else {
        Err(bad(line, field, format!("= {diameter} must be > 0")))
    }
}

/// `csv`: see the module docs.
fn read_csv(text: &str) -> Result<Read, Bad> {
    let mut rows = text
        .lines()
        .enumerate()
        .map(|(n, l)| (n + 1, l.trim()))
        .filter(|(_, l)| !l.is_empty() && !l.starts_with('#'));
    let (header_line, header) = rows
        .next()
        .ok_or_else(|| bad(1, "header", "the file is empty (expected a header x,y,z,r)"))?;
    let names: Vec<&str> = header.split(',').map(str::trim).collect();
    let column = |name: &str| names.iter().position(|n| *n == name);
    let mut xyz = [0; 3];
    for (k, name) in ["x", "y", "z"].into_iter().enumerate() {
        xyz[k] = column(name).ok_or_else(|| {
            bad(
                header_line,
                "header",
                format!("no column {name:?} (columns: {header})"),
            )
        })?;
    }
    // (column, factor to a diameter, name)
    let size = match (column("r"), column("d")) {
        (Some(c), None) => (c, 2.0, "r"),
        (None, Some(c)) => (c, 1.0, "d"),
        _ => {
            return Err(bad(
                header_line,
                "header",
                format!("needs one of the columns \"r\" (radius) or \"d\" (diameter), not both or none (columns: {header})"),
            ))
        }
    };
    let kind = column("type");
    let mut particles = Vec::new();
    for (line, row) in rows {
        let cells: Vec<&str> = row.split(',').collect();
        if cells.len() != names.len() {
            return Err(bad(
                line,
                "row",
                format!("{} columns, the header has {}", cells.len(), names.len()),
            ));
        }
        if let Some(c) = kind {
            if cells[c].trim() != "sphere" {
                return Err(bad(
                    line,
                    "type",
                    format!("{:?}: only spheres are read", cells[c]),
                ));
            }
        }
        let center = [
            number(cells[xyz[0]], line, "x")?,
            number(cells[xyz[1]], line, "y")?,
            number(cells[xyz[2]], line, "z")?,
        ];
        let d = size.1 * number(cells[size.0], line, size.2)?;
        particles.push(sphere(center, d, line, size.2)?);
    }
    Ok(Read {
        particles,
        container: None,
    })
}

/// `xyzd`: see the module docs.
fn read_xyzd(bytes: &[u8]) -> Result<Read, Bad> {
    const RECORD: usize = 32;
    if !bytes.len().is_multiple_of(RECORD) {
        return Err(Bad {
            at: "end of file".into(),
            field: "length".into(),
            message: format!(
                "{} bytes is not a whole number of 32-byte records (x y z d as f64)",
                bytes.len()
            ),
        });
    }
    bytes
        .chunks_exact(RECORD)
        .enumerate()
        .map(|(i, record)| {
            let v: [f64; 4] = std::array::from_fn(|k| {
                f64::from_le_bytes(record[8 * k..8 * k + 8].try_into().expect("8 bytes"))
            });
            let at = format!("record {} (byte {})", i + 1, i * RECORD);
            if let Some(k) = (0..4).find(|&k| !v[k].is_finite()) {
                return Err(Bad {
                    at,
                    field: ["x", "y", "z", "d"][k].into(),
                    message: format!("= {} is not a finite number", v[k]),
                });
            }
            sphere([v[0], v[1], v[2]], v[3], 0, "d").map_err(|b| Bad { at, ..b })
        })
        .collect::<Result<_, _>>()
        .map(|particles| Read {
            particles,
            container: None,
        })
}

/// Periodic axes from a `boundary p p f` note (densepack's LAMMPS export header).
fn boundary_note(line: &str) -> Option<[bool; 3]> {
    let rest = &line[line.find("boundary ")? + "boundary ".len()..];
    let letters: Vec<&str> = rest.split_whitespace().take(3).collect();
    let flag = |s: &str| match s.trim_end_matches(')') {
        "p" => Some(true),
        "f" | "s" | "m" | "fs" | "fm" | "sm" => Some(false),
        _ => None,
    };
    match letters[..] {
        [a, b, c] => Some([flag(a)?, flag(b)?, flag(c)?]),
        _ => None,
    }
}

/// `lammps-data`: see the module docs.
fn read_lammps_data(text: &str, periodic: Option<[bool; 3]>) -> Result<Read, Bad> {
    let lines: Vec<&str> = text.lines().collect();
    let periodic = periodic
        .or_else(|| lines.first().and_then(|l| boundary_note(l)))
        .unwrap_or([false; 3]);
    let mut atoms: Option<usize> = None;
    let mut lo = [f64::NAN; 3];
    let mut hi = [f64::NAN; 3];
    let mut n = 1; // the first line is a title
    let section = loop {
        n += 1;
        let Some(raw) = lines.get(n - 1) else {
            return Err(bad(n, "Atoms", "no Atoms section"));
        };
        let words = data_words(raw);
        match words[..] {
            [] => continue,
            [count, "atoms"] => {
                atoms =
                    Some(count.parse().map_err(|_| {
                        bad(n, "atoms", format!("{count:?} is not a count of atoms"))
                    })?)
            }
            [a, b, lo_name, hi_name] if lo_name.ends_with("lo") && hi_name.ends_with("hi") => {
                let k = match lo_name {
                    "xlo" => 0,
                    "ylo" => 1,
                    "zlo" => 2,
                    _ => return Err(bad(n, lo_name, "expected xlo, ylo or zlo")),
                };
                lo[k] = number(a, n, lo_name)?;
                hi[k] = number(b, n, hi_name)?;
            }
            [_, _, _, "xy", "xz", "yz"] => {
                return Err(bad(n, "xy xz yz", "triclinic boxes are not supported"))
            }
            ["Atoms", ..] => {
                let style = raw.split('#').nth(1).map(str::trim);
                if style.is_some_and(|s| s != "sphere") {
                    return Err(bad(
                        n,
                        "Atoms",
                        format!(
                            "atom style {:?}: only \"sphere\" is read",
                            style.unwrap_or("")
                        ),
                    ));
                }
                break n;
            }
            [first, ..] if first.chars().next().is_some_and(char::is_alphabetic) => {
                return Err(bad(
                    n,
                    first,
                    "a section before Atoms (only Atoms is read; put it first)",
                ))
            }
            _ => {} // other header keywords (atom types, bonds, …)
        }
    };
    let atoms = atoms.ok_or_else(|| bad(section, "atoms", "the header has no \"N atoms\" line"))?;
    if let Some(k) = (0..3).find(|&k| lo[k].is_nan()) {
        let name = ["x", "y", "z"][k];
        return Err(bad(
            section,
            format!("{name}lo {name}hi"),
            "missing from the header",
        ));
    }
    let mut particles = Vec::with_capacity(atoms);
    let mut n = section;
    while particles.len() < atoms {
        n += 1;
        let Some(raw) = lines.get(n - 1) else {
            return Err(bad(
                n,
                "Atoms",
                format!("{} atom lines, the header says {atoms}", particles.len()),
            ));
        };
        let words = data_words(raw);
        if words.is_empty() {
            continue;
        }
        if words.len() != 7 && words.len() != 10 {
            return Err(bad(
                n,
                "Atoms",
                format!(
                    "{} columns; atom style sphere has 7 (id type diameter density x y z) or 10 (+ image flags)",
                    words.len()
                ),
            ));
        }
        let center = [
            number(words[4], n, "x")?,
            number(words[5], n, "y")?,
            number(words[6], n, "z")?,
        ];
        particles.push(sphere(
            center,
            number(words[2], n, "diameter")?,
            n,
            "diameter",
        )?);
    }
    Ok(Read {
        particles,
        container: Some(ContainerRecord::Box {
            min: lo,
            max: hi,
            periodic,
        }),
    })
}

/// `lammps-dump`: see the module docs.
fn read_lammps_dump(text: &str) -> Result<Read, Bad> {
    let lines: Vec<&str> = text.lines().collect();
    let mut last: Option<Read> = None;
    let mut n = 0;
    let line = |n: usize| -> Result<&str, Bad> {
        lines
            .get(n - 1)
            .copied()
            .ok_or_else(|| bad(n, "ITEM", "the file ends inside a snapshot"))
    };
    while n < lines.len() {
        n += 1;
        let item = line(n)?.trim();
        if item.is_empty() {
            continue;
        }
        if item != "ITEM: TIMESTEP" {
            return Err(bad(
                n,
                "ITEM",
                format!("{item:?}: expected \"ITEM: TIMESTEP\""),
            ));
        }
        n += 2;
        if line(n)?.trim() != "ITEM: NUMBER OF ATOMS" {
            return Err(bad(n, "ITEM", "expected \"ITEM: NUMBER OF ATOMS\""));
        }
        n += 1;
        let count: usize = line(n)?
            .trim()
            .parse()
            .map_err(|_| bad(n, "NUMBER OF ATOMS", "not a count"))?;
        n += 1;
        let bounds = line(n)?.trim();
        let flags: Vec<&str> = match bounds.strip_prefix("ITEM: BOX BOUNDS") {
            Some(rest) => rest.split_whitespace().collect(),
            None => return Err(bad(n, "ITEM", "expected \"ITEM: BOX BOUNDS\"")),
        };
        if flags.iter().any(|f| ["xy", "xz", "yz"].contains(f)) {
            return Err(bad(n, "BOX BOUNDS", "triclinic boxes are not supported"));
        }
        if flags.len() != 3 {
            return Err(bad(
                n,
                "BOX BOUNDS",
                "expected three boundary flags (pp pp ff)",
            ));
        }
        let periodic: [bool; 3] = std::array::from_fn(|k| flags[k] == "pp");
        let mut lo = [0.0; 3];
        let mut hi = [0.0; 3];
        for k in 0..3 {
            n += 1;
            let words: Vec<&str> = line(n)?.split_whitespace().collect();
            let name = ["x", "y", "z"][k];
            if words.len() != 2 {
                return Err(bad(n, format!("{name}lo {name}hi"), "expected two numbers"));
            }
            lo[k] = number(words[0], n, &format!("{name}lo"))?;
            hi[k] = number(words[1], n, &format!("{name}hi"))?;
        }
        n += 1;
        let columns: Vec<&str> = match line(n)?.trim().strip_prefix("ITEM: ATOMS") {
            Some(rest) => rest.split_whitespace().collect(),
            None => return Err(bad(n, "ITEM", "expected \"ITEM: ATOMS …\"")),
        };
        let find = |names: &[&str]| {
            names
                .iter()
                .find_map(|m| columns.iter().position(|c| c == m))
        };
        let mut xyz = [(0, false); 3];
        for (k, name) in ["x", "y", "z"].into_iter().enumerate() {
            let plain = [name.to_string(), format!("{name}u")];
            xyz[k] = match find(&[&plain[0], &plain[1]]) {
                Some(c) => (c, false),
                None => (
                    find(&[&format!("{name}s")]).ok_or_else(|| {
                        bad(n, "ATOMS", format!("no column {name}, {name}u or {name}s"))
                    })?,
                    true,
                ),
            };
        }
        let (size, factor, size_name) = match (find(&["radius"]), find(&["diameter"])) {
            (Some(c), _) => (c, 2.0, "radius"),
            (None, Some(c)) => (c, 1.0, "diameter"),
            _ => return Err(bad(n, "ATOMS", "no column radius or diameter")),
        };
        let mut particles = Vec::with_capacity(count);
        for _ in 0..count {
            n += 1;
            let words: Vec<&str> = line(n)?.split_whitespace().collect();
            if words.len() != columns.len() {
                return Err(bad(
                    n,
                    "ATOMS",
                    format!("{} values for {} columns", words.len(), columns.len()),
                ));
            }
            let mut center = [0.0; 3];
            for k in 0..3 {
                let (c, scaled) = xyz[k];
                let v = number(words[c], n, columns[c])?;
                center[k] = if scaled {
                    lo[k] + v * (hi[k] - lo[k])
                } else {
                    v
                };
            }
            let d = factor * number(words[size], n, size_name)?;
            particles.push(sphere(center, d, n, size_name)?);
        }
        last = Some(Read {
            particles,
            container: Some(ContainerRecord::Box {
                min: lo,
                max: hi,
                periodic,
            }),
        });
    }
    last.ok_or_else(|| bad(1, "ITEM", "no snapshot (expected \"ITEM: TIMESTEP\")"))
}

/// Reads `path` as `source` into a packing (see the module docs); `options` gives the
/// container where the file has none.
pub fn import(
    path: &Path,
    source: Source,
    options: &ImportOptions,
) -> Result<Packing, ImportError> {
    let name = path.display().to_string();
    let io = |source| ImportError::Io {
        path: name.clone(),
        source,
    };
    let malformed = |b: Bad| ImportError::Malformed {
        path: name.clone(),
        at: b.at,
        field: b.field,
        message: b.message,
    };
    if options.periodic.is_some() && source != Source::LammpsData {
        return Err(ImportError::Invalid {
            option: "--periodic",
            message: format!(
                "applies to the box of a lammps-data file; for --from {} give it with --box",
                source.name()
            ),
        });
    }
    let read = match source {
        Source::Xyzd => read_xyzd(&std::fs::read(path).map_err(io)?).map_err(malformed)?,
        Source::Json => {
            let packing = Packing::read(path)?;
            Read {
                particles: packing.particles,
                container: Some(packing.container),
            }
        }
        text_source => {
            let text = std::fs::read_to_string(path).map_err(io)?;
            match text_source {
                Source::Csv => read_csv(&text),
                Source::LammpsData => read_lammps_data(&text, options.periodic),
                _ => read_lammps_dump(&text),
            }
            .map_err(malformed)?
        }
    };
    let container = options.container.clone().or(read.container).ok_or_else(|| {
        ImportError::Invalid {
            option: "--box",
            message: format!(
                "a {} file holds no container: give --box X,Y,Z (with --periodic) or --cylinder R,H",
                source.name()
            ),
        }
    })?;
    container.check().map_err(|message| ImportError::Invalid {
        option: "--box",
        message,
    })?;
    let file = path
        .file_name()
        .map_or(name.clone(), |f| f.to_string_lossy().into_owned());
    Ok(Packing {
        provenance: Some(Provenance {
            imported_from: Some(ImportedFrom {
                file,
                format: source.name().into(),
            }),
            ..Provenance::new(serde_json::Value::Null, 0, Timings::default())
        }),
        ..Packing::new(container, read.particles)
    })
}

#[cfg(test)]
mod tests {
    use super::*;

    fn err(r: Result<Read, Bad>) -> String {
        match r {
            Ok(_) => panic!("accepted"),
            Err(b) => format!("{}: {}: {}", b.at, b.field, b.message),
        }
    }

    #[test]
    fn csv_reads_radius_or_diameter_columns_in_any_order() {
        let r = read_csv("# comment\nd,z,y,x,id\n2,3,2,1,7\n\n1e0,0.5,0.5,0.5,8\n").unwrap();
        assert_eq!(
            r.particles,
            vec![
                ParticleRecord::Sphere(SphereRecord {
                    center: [1.0, 2.0, 3.0],
                    radius: 1.0
                }),
                ParticleRecord::Sphere(SphereRecord {
                    center: [0.5, 0.5, 0.5],
                    radius: 0.5
                })
            ]
        );
    }

    #[test]
    fn malformed_csv_names_the_line_and_the_field() {
        assert_eq!(
            err(read_csv("x,y,z,r\n1,2,3,0.5\n1,2,nan,1\n")),
            "line 3: z: \"nan\" is not a finite number"
        );
        assert_eq!(
            err(read_csv("x,y,z,r\n1,2,3,-1\n")),
            "line 2: r: = -2 must be > 0"
        );
        assert!(err(read_csv("x,y,r\n")).starts_with("line 1: header: no column \"z\""));
        assert_eq!(
            err(read_csv("x,y,z,r\n1,2,3\n")),
            "line 2: row: 3 columns, the header has 4"
        );
        assert!(err(read_csv("type,x,y,z,r\ncylinder,1,2,3,4\n")).starts_with("line 2: type:"));
    }

    #[test]
    fn malformed_xyzd_names_the_record_and_the_field() {
        assert!(err(read_xyzd(&[0; 33])).starts_with("end of file: length: 33 bytes"));
        let mut bytes: Vec<u8> = [1.0f64, 2.0, 3.0, 1.0, 1.0, 2.0, 3.0, 0.0]
            .iter()
            .flat_map(|v| v.to_le_bytes())
            .collect();
        assert_eq!(
            err(read_xyzd(&bytes)),
            "record 2 (byte 32): d: = 0 must be > 0"
        );
        bytes[8..16].copy_from_slice(&f64::INFINITY.to_le_bytes());
        assert_eq!(
            err(read_xyzd(&bytes)),
            "record 1 (byte 0): y: = inf is not a finite number"
        );
    }

    const DATA: &str = "LAMMPS data file: test (boundary p p f)\n\n2 atoms\n1 atom types\n\n\
                        0 10 xlo xhi\n0 10 ylo yhi\n-1 9 zlo zhi\n\nAtoms # sphere\n\n\
                        1 1 1.5 1 1 2 3\n2 1 1 1 4 5 6 0 0 0\n";

    #[test]
    fn lammps_data_reads_atoms_box_and_the_boundary_note() {
        let r = read_lammps_data(DATA, None).unwrap();
        assert_eq!(r.particles.len(), 2);
        assert_eq!(
            r.particles[0],
            ParticleRecord::Sphere(SphereRecord {
                center: [1.0, 2.0, 3.0],
                radius: 0.75
            })
        );
        assert_eq!(
            r.container,
            Some(ContainerRecord::Box {
                min: [0.0, 0.0, -1.0],
                max: [10.0, 10.0, 9.0],
                periodic: [true, true, false]
            })
        );
        let walls = read_lammps_data(DATA, Some([false; 3])).unwrap();
        assert!(matches!(
            walls.container,
            Some(ContainerRecord::Box {
                periodic: [false, false, false],
                ..
            })
        ));
    }

    #[test]
    fn malformed_lammps_data_names_the_line_and_the_field() {
        assert_eq!(
            err(read_lammps_data(
                &DATA.replace("1 1 1.5 1 1 2 3", "1 1 1.5 1 1 x 3"),
                None
            )),
            "line 12: y: \"x\" is not a finite number"
        );
        assert_eq!(
            err(read_lammps_data(
                &DATA.replace("# sphere", "# atomic"),
                None
            )),
            "line 10: Atoms: atom style \"atomic\": only \"sphere\" is read"
        );
        assert_eq!(
            err(read_lammps_data(&DATA.replace("2 atoms", "3 atoms"), None)),
            "line 14: Atoms: 2 atom lines, the header says 3"
        );
        assert!(err(read_lammps_data(
            &DATA.replace("1 1 1.5 1 1 2 3", "1 1 1.5 1 1 2"),
            None
        ))
        .starts_with("line 12: Atoms: 6 columns"));
    }

    const DUMP: &str = "ITEM: TIMESTEP\n0\nITEM: NUMBER OF ATOMS\n1\nITEM: BOX BOUNDS pp pp ff\n\
                        0 4\n0 4\n0 8\nITEM: ATOMS id type xs ys zs radius\n1 1 0.5 0.25 0.5 0.5\n\
                        ITEM: TIMESTEP\n100\nITEM: NUMBER OF ATOMS\n1\nITEM: BOX BOUNDS pp pp ff\n\
                        0 4\n0 4\n0 8\nITEM: ATOMS id x y z diameter\n1 1 2 3 0.5\n";

    #[test]
    fn lammps_dump_reads_the_last_snapshot_scaled_or_not() {
        let r = read_lammps_dump(DUMP).unwrap();
        assert_eq!(
            r.particles,
            vec![ParticleRecord::Sphere(SphereRecord {
                center: [1.0, 2.0, 3.0],
                radius: 0.25
            })]
        );
        assert_eq!(
            r.container,
            Some(ContainerRecord::Box {
                min: [0.0; 3],
                max: [4.0, 4.0, 8.0],
                periodic: [true, true, false]
            })
        );
        let first = DUMP.split("ITEM: TIMESTEP\n100").next().unwrap();
        let r = read_lammps_dump(first).unwrap();
        assert_eq!(
            r.particles,
            vec![ParticleRecord::Sphere(SphereRecord {
                center: [2.0, 1.0, 4.0],
                radius: 0.5
            })]
        );
    }

    #[test]
    fn malformed_lammps_dump_names_the_line_and_the_field() {
        assert_eq!(
            err(read_lammps_dump(&DUMP.replace("1 1 2 3 0.5", "1 1 2 3"))),
            "line 20: ATOMS: 4 values for 5 columns"
        );
        assert_eq!(
            err(read_lammps_dump(&DUMP.replace(
                "0 4\n0 4\n0 8\nITEM: ATOMS id x",
                "0 4\n0 q\n0 8\nITEM: ATOMS id x"
            ))),
            "line 17: yhi: \"q\" is not a finite number"
        );
        assert_eq!(
            err(read_lammps_dump(
                &DUMP.replace("id x y z diameter", "id x y z")
            )),
            "line 19: ATOMS: no column radius or diameter"
        );
    }
}
