//! `Scene`: a validated scene (spheres, ellipsoids or a sphere + cylinder mixture).

use crate::{os_error, value_error};
use densepack::io::scene::AnyScene;
use pyo3::prelude::*;
use pyo3::types::{PyDict, PyString};
use std::path::PathBuf;

/// A validated scene. Build it with `Scene.from_toml` or `Scene.from_dict`; derive variants
/// with `with_seed` and `with_values`. Immutable and picklable.
#[pyclass(module = "densepack._densepack", frozen, eq)]
#[derive(Clone, PartialEq)]
pub struct Scene {
    pub(crate) scene: AnyScene,
}

impl Scene {
    /// The scene parsed and validated from TOML text (the file's rules and messages).
    pub(crate) fn parse(text: &str) -> PyResult<Self> {
        Self::parse_at(text, None)
    }

    /// A scene from the text of a file in directory `base` (a relative `particles.from` is
    /// relative to it).
    fn parse_at(text: &str, base: Option<&std::path::Path>) -> PyResult<Self> {
        AnyScene::from_toml_at(text, base)
            .map(|scene| Self { scene })
            .map_err(value_error)
    }
}

#[pymethods]
impl Scene {
    /// A scene from a TOML file (a `pathlib.Path`, or a `str` naming an existing file) or
    /// from TOML text (a `str` that is not a file name). Raises `ValueError` naming the
    /// field and its allowed range when the scene is invalid, `OSError` when the file
    /// cannot be read.
    #[staticmethod]
    fn from_toml(source: &Bound<'_, PyAny>) -> PyResult<Self> {
        let (text, base) = if let Ok(s) = source.cast::<PyString>() {
            let s = s.to_cow()?;
            let s = s.as_ref();
            let path = std::path::Path::new(s);
            if !s.contains('\n') && path.is_file() {
                (read(path)?, path.parent().map(PathBuf::from))
            } else if !s.contains('\n') && !s.contains('=') && s.ends_with(".toml") {
                return Err(os_error(format!("{s}: no such scene file")));
            } else {
                (s.to_owned(), None)
            }
        } else {
            let path: PathBuf = source.extract()?;
            (read(&path)?, path.parent().map(PathBuf::from))
        };
        Self::parse_at(&text, base.as_deref())
    }

    /// A scene from a dict of the TOML schema (`Scene.to_dict()` gives one): validated
    /// exactly like a file.
    #[staticmethod]
    fn from_dict(d: &Bound<'_, PyDict>) -> PyResult<Self> {
        let table: toml::Table = pythonize::depythonize(d.as_any())
            .map_err(|e| value_error(format!("not a scene table: {e}")))?;
        Self::parse(&table.to_string())
    }

    /// The scene as a dict of the TOML schema, every default filled in.
    fn to_dict<'py>(&self, py: Python<'py>) -> PyResult<Bound<'py, PyAny>> {
        let table: toml::Table = toml::from_str(&self.scene.to_toml())
            .map_err(|e| value_error(format!("the scene's TOML does not parse back: {e}")))?;
        Ok(pythonize::pythonize(py, &table)?)
    }

    /// The scene as TOML text, every default filled in.
    fn to_toml(&self) -> String {
        self.scene.to_toml()
    }

    /// The same scene with another seed.
    fn with_seed(&self, seed: u64) -> Self {
        Self {
            scene: self.scene.with_seed(seed),
        }
    }

    /// The scene with dotted keys set (`{"particles.d_min": 4.0, "stage.0.rate": 0.01}`),
    /// validated exactly like a file: `ValueError` names the field and its allowed range.
    fn with_values(&self, values: &Bound<'_, PyDict>) -> PyResult<Self> {
        let mut assignments = Vec::with_capacity(values.len());
        for (key, value) in values.iter() {
            let key: String = key
                .extract()
                .map_err(|_| value_error(format!("{key}: a key is a dotted str")))?;
            let value: toml::Value = pythonize::depythonize(&value)
                .map_err(|e| value_error(format!("{key}: not a TOML value: {e}")))?;
            assignments.push((key, value));
        }
        self.scene
            .with_values(&assignments)
            .map(|scene| Self { scene })
            .map_err(value_error)
    }

    /// The seed of the random generator.
    #[getter]
    fn seed(&self) -> u64 {
        self.scene.seed()
    }

    /// What the scene packs: `"spheres"`, `"ellipsoids"` or `"mixture"`.
    #[getter]
    fn kind(&self) -> &'static str {
        match &self.scene {
            AnyScene::Spheres(s) if s.particles.ellipsoid.is_some() => "ellipsoids",
            AnyScene::Spheres(_) => "spheres",
            AnyScene::Mixture(_) => "mixture",
        }
    }

    fn __repr__(&self) -> String {
        format!("<densepack.Scene {} seed={}>", self.kind(), self.seed())
    }

    /// Pickles as its TOML text.
    fn __reduce__<'py>(slf: &Bound<'py, Self>) -> PyResult<(Bound<'py, PyAny>, (String,))> {
        let from_toml = slf.get_type().getattr("from_toml")?;
        Ok((from_toml, (slf.get().scene.to_toml(),)))
    }
}

fn read(path: &std::path::Path) -> PyResult<String> {
    std::fs::read_to_string(path).map_err(|e| os_error(format!("{}: {e}", path.display())))
}
