//! The project's own scenes, built into the binary: the default scene of
//! `hybrid render` and the glossy scene the estimators are measured on.
//! Their files live in `dae/`; these are the same bytes.

use super::collada::{self, LoadError};
use super::{NormalMode, Scene};

/// A scene file compiled into the binary.
#[derive(Clone, Copy, Debug)]
pub struct Builtin {
    /// Its path in the project, used in messages and tables.
    pub name: &'static str,
    pub text: &'static str,
}

impl Builtin {
    /// The file this scene was compiled from, as an absolute path, if it
    /// is still there with the same bytes (a command naming it then works
    /// from any folder).
    pub fn file_on_disk(&self) -> Option<std::path::PathBuf> {
        let path = std::path::Path::new(env!("CARGO_MANIFEST_DIR")).join(self.name);
        let same = std::fs::read_to_string(&path).is_ok_and(|t| t == self.text);
        same.then_some(path)
    }

    pub fn load(&self, normals: NormalMode) -> Result<Scene, LoadError> {
        collada::load_str(self.text, self.name, normals)
    }
}

/// The default scene: a Cornell box with a rough gold cube and a mirror
/// sphere.
pub const CORNELL: Builtin = Builtin {
    name: "dae/cornell.dae",
    text: include_str!("../../dae/cornell.dae"),
};

/// Two rough metal spheres (Beckmann alpha 0.025 and 0.25), a mirror
/// sphere and an area light: where light sampling alone is noisy.
pub const GLOSSY: Builtin = Builtin {
    name: "dae/glossy.dae",
    text: include_str!("../../dae/glossy.dae"),
};
