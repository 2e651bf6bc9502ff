//! Changing a scene without editing its file: another seed ([`AnyScene::with_seed`]) and
//! dotted overrides ([`AnyScene::with_values`], [`parse_assignment`]).
//!
//! An override is a dotted key and a TOML value: `particles.d_min = 2.0`,
//! `container.size = [10.0, 10.0, 10.0]`, `stage.1.rate = 0.01`. Each segment of the key
//! names a key of a table, or — where the value reached so far is an array, such as the
//! `[[stage]]` tables or `container.size` — the index of an element, counted **from 0** as in
//! every message about stages (`stage[1].rate`, "stage 1 stopped …"); `stage[1].rate` is
//! accepted as a spelling of `stage.1.rate`. Every segment but the last must exist; the last
//! may be a key the table does not have yet (the schema then accepts it or rejects it as an
//! unknown field, exactly as in a file). The overrides are applied in order to the scene's
//! TOML table, which is then parsed and validated like a file, with the same messages.

use super::{AnyScene, MixtureScene, Scene, SceneError};

/// An error about override `key`.
fn bad_key(key: &str, message: impl Into<String>) -> SceneError {
    SceneError::Invalid {
        field: key.to_string(),
        message: message.into(),
    }
}

/// One step of a key's path: a table key or an array index.
#[derive(Debug, PartialEq)]
enum Step {
    Key(String),
    Index(usize),
}

/// The steps of `key`: dotted segments, each a name optionally followed by `[i]` indices,
/// or a bare index.
fn steps(key: &str) -> Result<Vec<Step>, SceneError> {
    let malformed = || {
        bad_key(
            key,
            "is not a dotted key (segments such as `particles.d_min`, `stage.1.rate` or \
             `stage[1].rate`)",
        )
    };
    let mut out = Vec::new();
    for segment in key.split('.') {
        let (name, mut rest) = match segment.find('[') {
            Some(k) => segment.split_at(k),
            None => (segment, ""),
        };
        if name.is_empty() && rest.is_empty() {
            return Err(malformed());
        }
        if !name.is_empty() {
            if !name
                .chars()
                .all(|c| c.is_ascii_alphanumeric() || c == '_' || c == '-')
            {
                return Err(malformed());
            }
            out.push(match name.parse::<usize>() {
                Ok(i) => Step::Index(i),
                Err(_) => Step::Key(name.to_string()),
            });
        }
        while !rest.is_empty() {
            let inner = rest.strip_prefix('[').ok_or_else(malformed)?;
            let (index, after) = inner.split_once(']').ok_or_else(malformed)?;
            out.push(Step::Index(index.parse().map_err(|_| malformed())?));
            rest = after;
        }
    }
    Ok(out)
}

/// Sets `key` to `value` in the scene table `root` (see the module documentation for the
/// path rules).
fn set(root: &mut toml::Value, key: &str, value: toml::Value) -> Result<(), SceneError> {
    let steps = steps(key)?;
    let (last, parents) = steps.split_last().expect("a key has a segment");
    let mut here = root;
    let mut path = String::new();
    for step in parents {
        here = child(here, step, key, &path)?;
        path = joined(&path, step);
    }
    match (here, last) {
        (toml::Value::Table(t), Step::Key(name)) => {
            t.insert(name.clone(), value);
        }
        (toml::Value::Table(t), Step::Index(i)) => {
            t.insert(i.to_string(), value);
        }
        (toml::Value::Array(a), Step::Index(i)) => {
            let len = a.len();
            *a.get_mut(*i)
                .ok_or_else(|| out_of_range(key, &path, *i, len))? = value;
        }
        (other, step) => return Err(not_a_container(key, &path, other, step)),
    }
    Ok(())
}

/// The element of `here` that `step` names; `path` is the key so far (for messages).
fn child<'v>(
    here: &'v mut toml::Value,
    step: &Step,
    key: &str,
    path: &str,
) -> Result<&'v mut toml::Value, SceneError> {
    let missing = || {
        bad_key(
            key,
            format!(
                "`{}` does not exist in the scene",
                joined(path, step).trim_start_matches('.')
            ),
        )
    };
    match (here, step) {
        (toml::Value::Table(t), Step::Key(name)) => t.get_mut(name).ok_or_else(missing),
        (toml::Value::Table(t), Step::Index(i)) => t.get_mut(&i.to_string()).ok_or_else(missing),
        (toml::Value::Array(a), Step::Index(i)) => {
            let len = a.len();
            a.get_mut(*i)
                .ok_or_else(|| out_of_range(key, path, *i, len))
        }
        (other, step) => Err(not_a_container(key, path, other, step)),
    }
}

/// `path` holds `value`, which has no element `step`.
fn not_a_container(key: &str, path: &str, value: &toml::Value, step: &Step) -> SceneError {
    let wanted = match step {
        Step::Key(name) => format!("a table with a key `{name}`"),
        Step::Index(i) => format!("an array with an element {i}"),
    };
    bad_key(
        key,
        format!("`{}` is {}, not {wanted}", shown(path), value.type_str()),
    )
}

fn out_of_range(key: &str, path: &str, i: usize, len: usize) -> SceneError {
    let range = if len == 0 {
        "it is empty".to_string()
    } else {
        format!("indices count from 0 and run to {}", len - 1)
    };
    bad_key(
        key,
        format!(
            "index {i} is out of range: `{}` has {len} elements ({range})",
            shown(path)
        ),
    )
}

/// `path` extended by `step`, dotted.
fn joined(path: &str, step: &Step) -> String {
    let segment = match step {
        Step::Key(name) => name.clone(),
        Step::Index(i) => i.to_string(),
    };
    if path.is_empty() {
        segment
    } else {
        format!("{path}.{segment}")
    }
}

/// A path for messages (the scene itself when empty).
fn shown(path: &str) -> &str {
    if path.is_empty() {
        "the scene"
    } else {
        path
    }
}

/// Splits `key=value` (spaces around either allowed) into the key and the value parsed as a
/// TOML value (`4.0`, `[1, 2, 3]`, `"heap"`, `true`, `{ gap = 1.0 }`). A bare word that is
/// not valid TOML (letters, digits, `_`, `-`, `.`) is taken as a string, so `queue=heap`
/// means `queue = "heap"`. The error names the text.
pub fn parse_assignment(text: &str) -> Result<(String, toml::Value), SceneError> {
    let bad = |why: &str| SceneError::Parse(format!("`{text}`: {why}"));
    let (key, value) = text
        .split_once('=')
        .ok_or_else(|| bad("expected key=value (e.g. particles.d_min=2.0)"))?;
    let (key, value) = (key.trim(), value.trim());
    if key.is_empty() {
        return Err(bad("the key before `=` is empty"));
    }
    steps(key).map_err(|e| bad(&e.to_string()))?;
    if value.is_empty() {
        return Err(bad("the value after `=` is empty"));
    }
    match toml::from_str::<toml::Table>(&format!("value = {value}")) {
        Ok(mut t) => Ok((key.to_string(), t.remove("value").expect("parsed"))),
        Err(_)
            if value
                .chars()
                .all(|c| c.is_alphanumeric() || matches!(c, '_' | '-' | '.')) =>
        {
            Ok((key.to_string(), toml::Value::String(value.to_string())))
        }
        Err(e) => Err(bad(&format!(
            "the value is not a TOML value ({})",
            e.message()
        ))),
    }
}

impl Scene {
    /// The same scene with another seed (the seed is never validated: any `u64`).
    pub fn with_seed(&self, seed: u64) -> Scene {
        Scene {
            seed,
            ..self.clone()
        }
    }
}

impl MixtureScene {
    /// The same scene with another seed.
    pub fn with_seed(&self, seed: u64) -> MixtureScene {
        MixtureScene {
            seed,
            ..self.clone()
        }
    }
}

impl AnyScene {
    /// The seed of the random generator.
    pub fn seed(&self) -> u64 {
        match self {
            AnyScene::Spheres(s) => s.seed,
            AnyScene::Mixture(m) => m.seed,
        }
    }

    /// The same scene with another seed.
    pub fn with_seed(&self, seed: u64) -> AnyScene {
        match self {
            AnyScene::Spheres(s) => AnyScene::Spheres(Box::new(s.with_seed(seed))),
            AnyScene::Mixture(m) => AnyScene::Mixture(Box::new(m.with_seed(seed))),
        }
    }

    /// The scene as TOML: [`AnyScene::from_toml`] of it gives an equal scene.
    pub fn to_toml(&self) -> String {
        match self {
            AnyScene::Spheres(s) => toml::to_string(s.as_ref()),
            AnyScene::Mixture(m) => toml::to_string(m.as_ref()),
        }
        .expect("a scene is a TOML table")
    }

    /// The scene with the dotted `values` set in order (see the module documentation), parsed
    /// and validated like a file: a value out of range gets the message the same value in the
    /// file gets. A key whose parent does not exist, or an index out of range, is an error
    /// naming the key.
    pub fn with_values(&self, values: &[(String, toml::Value)]) -> Result<AnyScene, SceneError> {
        let mut root: toml::Value =
            toml::from_str(&self.to_toml()).expect("a serialised scene parses");
        for (key, value) in values {
            set(&mut root, key, value.clone())?;
        }
        let text = toml::to_string(&root).map_err(|e| SceneError::Parse(e.to_string()))?;
        AnyScene::from_toml(&text)
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    const SCENE: &str = r#"
seed = 3
[container]
type = "box"
size = [6.0, 6.0, 6.0]
periodic = [true, true, true]
[particles]
count = 20
diameter = 1.0
packing_fraction = 0.2
[[stage]]
growth = "relative"
rate = 0.1
until = { packing_fraction = 0.3 }
[[stage]]
growth = "none"
until = { time = 1.0 }
"#;

    fn scene() -> AnyScene {
        AnyScene::from_toml(SCENE).unwrap()
    }

    fn with(pairs: &[&str]) -> Result<AnyScene, SceneError> {
        let values: Vec<_> = pairs.iter().map(|p| parse_assignment(p).unwrap()).collect();
        scene().with_values(&values)
    }

    fn spheres(s: AnyScene) -> Scene {
        match s {
            AnyScene::Spheres(s) => *s,
            AnyScene::Mixture(_) => panic!("a sphere scene"),
        }
    }

    #[test]
    fn assignments_parse_toml_values_and_bare_words() {
        let v = |t: &str| parse_assignment(t).unwrap();
        assert_eq!(v("a.b=4.0"), ("a.b".into(), toml::Value::Float(4.0)));
        assert_eq!(v(" a = 4 "), ("a".into(), toml::Value::Integer(4)));
        assert_eq!(v("queue=heap"), ("queue".into(), "heap".into()));
        assert_eq!(v("queue=\"heap\""), ("queue".into(), "heap".into()));
        assert_eq!(v("x=true"), ("x".into(), toml::Value::Boolean(true)));
        assert_eq!(
            v("size=[1,2,3]").1,
            toml::Value::Array(vec![1.into(), 2.into(), 3.into()])
        );
        for bad in ["novalue", "=3", "a=", "a=[1,2", "a..b=1", "a=two words"] {
            let e = parse_assignment(bad).unwrap_err().to_string();
            assert!(e.contains(&format!("`{bad}`")), "{bad}: {e}");
        }
    }

    #[test]
    fn keys_walk_tables_and_arrays_from_zero() {
        let s = spheres(with(&["stage.1.until.time=2.5", "container.size.2=7.0"]).unwrap());
        assert_eq!(s.stages[1].until.time, Some(2.5));
        assert_eq!(s.stages[0].until.time, None);
        match s.container {
            super::super::ContainerSpec::Box { size, .. } => assert_eq!(size, [6.0, 6.0, 7.0]),
            _ => panic!("a box"),
        }
        // The bracket spelling of the messages is the same key.
        let a = spheres(with(&["stage[0].rate=0.2"]).unwrap());
        let b = spheres(with(&["stage.0.rate=0.2"]).unwrap());
        assert_eq!(a, b);
        assert_eq!(a.stages[0].rate, Some(0.2));
        // A key new to an existing table is set; the schema decides (here: it accepts).
        let s = spheres(with(&["stage.1.max_events=1000"]).unwrap());
        assert_eq!(s.stages[1].max_events, Some(1000));
        let e = with(&["particles.seed_scale=0.9"]).unwrap_err().to_string();
        assert!(e.contains("not both"), "{e}");
        // Later overrides win.
        let s = spheres(with(&["seed=5", "seed=6"]).unwrap());
        assert_eq!(s.seed, 6);
    }

    #[test]
    fn missing_parents_and_indices_out_of_range_name_the_key() {
        let e = with(&["stage.2.rate=0.1"]).unwrap_err();
        assert_eq!(
            e,
            bad_key(
                "stage.2.rate",
                "index 2 is out of range: `stage` has 2 elements (indices count from 0 and run to 1)"
            )
        );
        let e = with(&["nothing.here=1"]).unwrap_err().to_string();
        assert!(
            e.starts_with("nothing.here: `nothing` does not exist"),
            "{e}"
        );
        let e = with(&["seed.x=1"]).unwrap_err().to_string();
        assert!(
            e.starts_with("seed.x: `seed` is integer, not a table"),
            "{e}"
        );
        let e = with(&["particles.0=1"]).unwrap_err().to_string();
        // A numeric key in a table is a key: the schema rejects it as unknown.
        assert!(e.contains("unknown field `0`"), "{e}");
        let e = with(&["particles.colour=1"]).unwrap_err().to_string();
        assert!(e.contains("unknown field `colour`"), "{e}");
    }

    #[test]
    fn an_override_is_the_edited_file_and_fails_with_its_message() {
        let edited = SCENE.replace("rate = 0.1", "rate = 0.05");
        assert_eq!(
            with(&["stage.0.rate=0.05"]).unwrap(),
            AnyScene::from_toml(&edited).unwrap()
        );
        let edited = SCENE.replace("packing_fraction = 0.2", "packing_fraction = 1.5");
        assert_eq!(
            with(&["particles.packing_fraction=1.5"]).unwrap_err(),
            AnyScene::from_toml(&edited).unwrap_err()
        );
        let edited = SCENE.replace("rate = 0.1", "rate = 1e9");
        let file = AnyScene::from_toml(&edited).unwrap_err();
        assert_eq!(with(&["stage.0.rate=1e9"]).unwrap_err(), file);
        assert!(file.to_string().starts_with("stage[0].rate:"), "{file}");
    }

    /// Every shipped scene, written out and read back, is the same scene: what a checkpoint
    /// stores and what `with_values` edits is the scene itself.
    #[test]
    fn every_example_scene_round_trips() {
        let dir = std::path::Path::new(env!("CARGO_MANIFEST_DIR")).join("examples/scenes");
        let mut count = 0;
        for entry in std::fs::read_dir(dir).unwrap() {
            let path = entry.unwrap().path();
            if path.extension().is_none_or(|e| e != "toml") {
                continue;
            }
            let scene = AnyScene::from_toml(&std::fs::read_to_string(&path).unwrap())
                .unwrap_or_else(|e| panic!("{}: {e}", path.display()));
            let again = AnyScene::from_toml(&scene.to_toml())
                .unwrap_or_else(|e| panic!("{}: {e}\n{}", path.display(), scene.to_toml()));
            assert_eq!(again, scene, "{}", path.display());
            assert_eq!(scene.with_values(&[]).unwrap(), scene);
            count += 1;
        }
        assert!(count >= 30, "{count} scenes");
    }

    #[test]
    fn with_seed_changes_the_seed_alone() {
        let s = scene();
        let t = s.with_seed(99);
        assert_eq!(t.seed(), 99);
        assert_eq!(t.with_seed(3), s);
    }
}
